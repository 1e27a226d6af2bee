# Two commands do everything on a fresh machine: `make demo` and `make test`.
PY      ?= python3.11
VENV    := .venv
VPY     := $(VENV)/bin/python
SITE    := $(VENV)/lib/python3.11/site-packages
STAMP   := $(VENV)/.lantern-installed

.PHONY: setup demo test bench clean system-deps extension compare bytecode

setup: $(STAMP) bytecode

# Lantern's bytecode, written ahead: where PYTHONDONTWRITEBYTECODE is set (as on this
# project's machines) every new process would otherwise compile the sources it imports,
# about 0.3 s of a cold `lantern render`. Up-to-date files are skipped.
bytecode: $(STAMP)
	@$(VPY) -m compileall -q -x '/(\.venv|\.git|out|dist|wheels)/' . > /dev/null

$(STAMP): pyproject.toml
	@$(MAKE) --no-print-directory system-deps
	test -x $(VPY) || $(PY) -m venv $(VENV)
	$(VPY) -m pip install -q --upgrade pip
	$(VPY) -m pip install -q -e '.[blender,dev]'
	# The package by a plain path entry (a link named lantern to this folder) instead of
	# setuptools' editable finder, whose imports cost 50 ms at every start of Python: a
	# Ctrl-C must find lantern's handler in place, and the CLI starts sooner.
	rm -f $(SITE)/__editable__.lantern-*.pth $(SITE)/__editable___lantern_*_finder.py
	mkdir -p $(VENV)/src && ln -sfn $(CURDIR) $(VENV)/src/lantern
	echo $(abspath $(VENV)/src) > $(SITE)/lantern.pth
	touch $(STAMP)

# EGL/Mesa for the standalone GL context, and the X/Vulkan libraries bpy links against.
system-deps:
	@bash .ci/system-deps.sh

demo: setup
	$(VPY) -m lantern.demo

# Every run prints its 25 slowest tests: the suite stays under about 15 minutes on 2 cores.
test: setup
	$(VPY) -m pytest -q --durations=25

bench: setup
	$(VPY) bench/run_all.py

# `lantern compare` over the suite (calibration scenes, the corpus, the rigged crowd):
# one report per scene and out/compare/index.html linking them. Not part of `make test`.
compare: setup
	$(VPY) bench/compare_suite.py

# The Blender extension zip, built and validated by Blender's own extension tool. The
# wheels the manifest names (ModernGL, glcontext and mapbox-earcut, every platform, cp311
# and cp313; Blender 4.2+ needs glibc 2.28, so manylinux_2_28 wheels qualify; `+` joins
# the platform tags one download accepts) are
# downloaded once into ./wheels; a wheel the manifest names but pip did not fetch fails
# the build.
BLENDER_EXT     := $(VENV)/lib/python3.11/site-packages/bpy/5.0/scripts/addons_core/bl_pkg/cli/blender_ext.py
EXT_VERSION     := $(shell sed -n 's/^version = "\(.*\)"/\1/p' blender_manifest.toml)
EXT_ZIP         := dist/lantern-$(EXT_VERSION).zip
WHEEL_PINS      := moderngl==5.12.0 glcontext==3.0.0 mapbox-earcut==2.1.0
WHEEL_PYTHONS   := 3.11 3.13
WHEEL_PLATFORMS := manylinux2014_x86_64+manylinux_2_28_x86_64 win_amd64 macosx_11_0_arm64 macosx_11_0_x86_64
WHEEL_STAMP     := wheels/.downloaded

$(WHEEL_STAMP): blender_manifest.toml | $(STAMP)
	for py in $(WHEEL_PYTHONS); do for plat in $(WHEEL_PLATFORMS); do \
	  $(VPY) -m pip download -q --no-deps --only-binary=:all: --python-version $$py \
	    $$(printf -- '--platform %s ' $$(echo $$plat | tr + ' ')) -d wheels $(WHEEL_PINS) \
	    || exit 1; done; done
	touch $@

extension: setup $(WHEEL_STAMP)
	mkdir -p dist
	$(VPY) $(BLENDER_EXT) build --source-dir . --output-dir dist
	$(VPY) $(BLENDER_EXT) validate $(EXT_ZIP)

clean:
	rm -rf out .pytest_cache dist wheels
