"""The USD stage is the only contract between exporters and engine: guard the imports,
and the engine's layering.

- `engine/` (and the CLI, which must run without Blender) never imports Blender modules.
- Only `exporters/` and `addon/` import bpy among the package's runtime modules, and
  `compare/`, a tool that drives Cycles and EEVEE in worker processes. Scripts that
  author scenes inside Blender (tests, bench, the demo scene builder) are not runtime
  code and are exempt.
- The engine never imports `compare/` (the tool uses the engine, not the reverse).
- `engine` and `exporters` never import each other.
- Inside the engine, `engine/usd/` is the only code that imports pxr and
  `engine/gpu/` the only code that imports moderngl or glcontext; the rest
  (records, views, light and rig numbers, the Session) is plain Python and numpy.
- `core/` is pure: the standard library and numpy, nothing of Lantern but itself.
- The engine and core never edit `sys.path` (exporters/blender_env.py alone does, to
  put Blender's own pxr first in a bpy process), and no GL state is kept in globals
  keyed by a context's id (programs belong to the context object).
- In `engine/gpu/`, bytes reach GL buffers and textures only through
  `resources.Uploads`, which counts them (`bytes_uploaded` cannot drift).
"""
import ast
import pathlib
import sys

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


def _layer_offences(folder="engine"):
    out = []
    for path in _package_files(folder):
        rel = path.relative_to(REPO).as_posix()
        for module, level in _imports(path):
            top = _top(_resolve(path, module, level))
            if top == "pxr" and not rel.startswith("engine/usd/"):
                out.append(f"{rel} imports pxr (only engine/usd/ may)")
            if top in ("moderngl", "glcontext") and not rel.startswith("engine/gpu/"):
                out.append(f"{rel} imports {top} (only engine/gpu/ may)")
    return out


def test_engine_layers():
    offences = _layer_offences()
    assert not offences, offences


# What core/ may import besides the standard library: numpy, and mapbox-earcut (a small
# native triangulator the extension bundles as wheels).
CORE_ALLOWED = ("numpy", "mapbox_earcut", "__future__")


def test_core_is_pure():
    offences = []
    for path in _package_files("core"):
        for module, level in _imports(path):
            name = _resolve(path, module, level)
            top = _top(name)
            if level:
                if not name.startswith("lantern.core"):
                    offences.append(f"{path.relative_to(REPO)} imports {name}")
            elif top not in CORE_ALLOWED and top not in sys.stdlib_module_names:
                offences.append(f"{path.relative_to(REPO)} imports {name}")
    assert not offences, offences


def _calls(path):
    """(receiver source, method name, call node) of every attribute call in a file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            yield ast.unparse(node.func.value), node.func.attr, node


def _sys_path_edits(path):
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr == "path" and \
                isinstance(node.value, ast.Name) and node.value.id == "sys":
            yield node.lineno


def test_no_sys_path_edits_or_context_keyed_globals():
    offences = [f"{p.relative_to(REPO)}:{line} uses sys.path"
                for folder in ("engine", "core") for p in _package_files(folder)
                for line in _sys_path_edits(p)]
    offences += [f"{p.relative_to(REPO)} keys something by id(ctx)"
                 for p in _package_files("engine") if "id(ctx)" in p.read_text()]
    assert not offences, offences


def _gl_writes(path):
    """GL memory written past Uploads: .write(...) on anything but an Uploads, or a
    buffer or texture made with data."""
    for receiver, method, call in _calls(path):
        via_uploads = receiver.split(".")[-1] == "uploads"
        if method == "write" and not via_uploads:
            yield f"{receiver}.write"
        if method == "buffer" and not via_uploads and (call.args or any(
                k.arg == "data" for k in call.keywords)):
            yield f"{receiver}.buffer with data"
        if method == "texture" and not via_uploads and (len(call.args) > 2 or any(
                k.arg == "data" for k in call.keywords)):
            yield f"{receiver}.texture with data"


def test_gl_uploads_go_through_one_counter():
    allowed = {"resources.py", "programs.py"}   # Uploads itself; uniforms (not GL memory)
    offences = [f"{p.relative_to(REPO)}: {w}" for p in _package_files("engine/gpu")
                if p.name not in allowed for w in _gl_writes(p)]
    assert not offences, offences


@pytest.mark.parametrize("source, rule", [
    ("from pxr import Usd", "layers"),
    ("import moderngl", "layers"),
    ("import sys\nsys.path.insert(0, 'x')", "sys.path"),
    ("def f(ctx, buf, data):\n    buf.write(data)\n    ctx.buffer(data)", "uploads"),
])
def test_the_layer_guards_can_fail(source, rule):
    """Planted offending files are caught by the checks above."""
    planted = REPO / "engine" / "gpu" / "passes" / "_planted_for_boundary_test.py"
    if rule == "layers":
        planted = REPO / "engine" / "_planted_for_boundary_test.py"
    planted.write_text(source + "\n")
    try:
        if rule == "layers":
            assert _layer_offences()
        elif rule == "sys.path":
            assert list(_sys_path_edits(planted))
        else:
            assert len(list(_gl_writes(planted))) == 2
    finally:
        planted.unlink()


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
