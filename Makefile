# Two commands do everything on a fresh machine: `make demo` and `make test`.
PY      ?= python3.11
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.lantern-installed

.PHONY: setup demo test bench clean system-deps extension

setup: $(STAMP)

$(STAMP): pyproject.toml
	@$(MAKE) --no-print-directory system-deps
	test -x $(VPY) || $(PY) -m venv $(VENV)
	$(VPY) -m pip install -q --upgrade pip
	$(VPY) -m pip install -q -e '.[blender,dev]'
	touch $(STAMP)

# EGL/Mesa for the standalone GL context, and the X/Vulkan libraries bpy links against.
system-deps:
	@bash .ci/system-deps.sh

demo: setup
	$(VPY) -m lantern.demo

test: setup
	$(VPY) -m pytest -q

bench: setup
	$(VPY) bench/run_all.py

# The Blender extension zip, with ModernGL wheels for every platform Blender 5 runs on.
BLENDER_EXT := $(VENV)/lib/python3.11/site-packages/bpy/5.0/scripts/addons_core/bl_pkg/cli/blender_ext.py
extension: setup
	for plat in manylinux2014_x86_64 macosx_11_0_arm64 win_amd64; do \
	  $(VPY) -m pip download -q --no-deps --only-binary=:all: --python-version 3.11 \
	    --platform $$plat -d wheels moderngl==5.13.0 glcontext==3.1.0 || exit 1; done
	mkdir -p dist
	$(VPY) $(BLENDER_EXT) build --source-dir . --output-dir dist

clean:
	rm -rf out .pytest_cache dist wheels
