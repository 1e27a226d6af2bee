"""The USD stage is the only contract between exporters and engine: guard the imports.

- `engine/` (and the CLI, which must run without Blender) never imports Blender modules.
- Only `exporters/` and `addon/` import bpy among the package's runtime modules, and
  `compare/`, a tool that drives Cycles and EEVEE in worker processes. Scripts that
  author scenes inside Blender (tests, bench, the demo scene builder) are not runtime
  code and are exempt.
- The engine never imports `compare/` (the tool uses the engine, not the reverse).
- `engine` and `exporters` never import each other.
"""
import ast
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
BLENDER_MODULES = {"bpy", "mathutils", "gpu", "gpu_extras", "bmesh", "bpy_extras", "bl_math", "aud"}
SCRIPTS = {"tests", "bench", ".venv", ".git"}
SCENE_SCRIPTS = {REPO / "demo" / "build_scene.py"}


def _imports(path):
    """Yields (absolute-or-relative module name, level) for every import in a file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, 0
        elif isinstance(node, ast.ImportFrom):
            yield (node.module or ""), node.level
            if node.level and not node.module:
                for alias in node.names:  # `from .. import exporters`
                    yield alias.name, node.level


def _resolve(path, module, level):
    """The import as a dotted name inside the `lantern` package, or as written if absolute."""
    if level == 0:
        return module
    package = list(path.relative_to(REPO).parent.parts)
    base = package[: len(package) - (level - 1)] if level > 1 else package
    return ".".join(["lantern", *base, *([module] if module else [])])


def _package_files(folder=None):
    root = REPO / folder if folder else REPO
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(REPO).parts
        if parts[0] in SCRIPTS or path in SCENE_SCRIPTS:
            continue
        yield path


def _top(name):
    return name.split(".")[0]


def test_engine_never_imports_blender_or_exporters():
    offences = []
    for path in _package_files("engine"):
        for module, level in _imports(path):
            name = _resolve(path, module, level)
            if _top(name) in BLENDER_MODULES or name.startswith(("lantern.exporters",
                                                                  "lantern.compare")):
                offences.append(f"{path.relative_to(REPO)} imports {name}")
    assert not offences, offences


def test_exporters_never_import_engine():
    offences = [f"{path.relative_to(REPO)} imports {name}"
                for path in _package_files("exporters")
                for module, level in _imports(path)
                if (name := _resolve(path, module, level)).startswith("lantern.engine")]
    assert not offences, offences


def test_only_exporters_and_addon_import_bpy():
    offences = []
    for path in _package_files():
        top_folder = path.relative_to(REPO).parts[0]
        if top_folder in {"exporters", "addon", "compare"}:
            continue
        for module, level in _imports(path):
            if _top(_resolve(path, module, level)) in BLENDER_MODULES:
                offences.append(f"{path.relative_to(REPO)} imports {module}")
    assert not offences, offences


@pytest.mark.parametrize("source, expected", [
    ("from ..exporters import api", "lantern.exporters"),
    ("import bpy", "bpy"),
    ("from .. import exporters", "lantern.exporters"),
    ("from ..compare import run", "lantern.compare"),
])
def test_the_guard_sees_forbidden_imports(tmp_path, source, expected):
    """The checks above can fail: a planted offending file is detected."""
    planted = REPO / "engine" / "_planted_for_boundary_test.py"
    planted.write_text(source + "\n")
    try:
        names = [_resolve(planted, m, lvl) for m, lvl in _imports(planted)]
        assert any(n.startswith(expected) for n in names), names
        with pytest.raises(AssertionError):
            test_engine_never_imports_blender_or_exporters()
    finally:
        planted.unlink()
