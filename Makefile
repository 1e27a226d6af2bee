# Two commands do everything on a fresh machine: `make demo` and `make test`.
PY      ?= python3.11
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.lantern-installed

.PHONY: setup demo test bench clean system-deps

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

clean:
	rm -rf out .pytest_cache
