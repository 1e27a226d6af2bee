"""Starts the engine host: `python -s -P boot.py PACKAGE_DIR HANDLE`, or the program
compiler's helper (engine/gpu/compile_helper.py) with `compiler` in HANDLE's place.

Run by Blender's own Python in a child process. The package is loaded from its
folder under the name `lantern` (inside Blender it is `bl_ext.<repo>.lantern`, which a
plain Python cannot import); the modules it needs beyond the standard library (numpy,
Blender's pxr, the extension's moderngl and glcontext wheels) are on PYTHONPATH,
which Blender's side sets (addon/host.py). HANDLE is the pipe to Blender."""
import importlib.util
import os
import sys


def main():
    package_dir, handle = sys.argv[1], sys.argv[2]
    spec = importlib.util.spec_from_file_location(
        "lantern", os.path.join(package_dir, "__init__.py"),
        submodule_search_locations=[package_dir])
    package = importlib.util.module_from_spec(spec)
    sys.modules["lantern"] = package
    spec.loader.exec_module(package)
    if handle == "compiler":
        from lantern.engine.gpu import compile_helper
        sys.exit(compile_helper.main())
    from lantern.engine.host import child
    sys.exit(child.main(handle))


if __name__ == "__main__":
    main()
