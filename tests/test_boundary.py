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
- Across the package, pxr is imported only in `engine/usd/`, `exporters/usd/` and the
  few modules PXR_ELSEWHERE names with the reason; no module imports another package's
  private (`_`) names; the modules import one another without cycles (an AST walk,
  module to module, lazy imports included); only `__main__` imports the CLI.
- Modules of `engine/` and `cli/` stay at MODULE_LINES lines or fewer: one past it is
  split by job.
"""
import ast
import functools
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
    # Uploads itself; uniforms, and the compiler's pipe to its helper (not GL memory).
    allowed = {"resources.py", "programs.py", "compiler.py", "compile_helper.py"}
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


# --- the whole package: pxr, private names, cycles, the CLI -------------------------------

# Modules outside engine/usd/ and exporters/usd/ that may import pxr, and why.
PXR_ELSEWHERE = {
    "exporters/api.py": "makes the in-memory stage an export writes into",
    "exporters/validate.py": "runs pxr's validators on an exported stage",
    "exporters/live.py": "edits the viewport's mirror stage in place, gathering and "
                         "writing one changed object, material or pose at a time",
}


def _pxr_offences(root=REPO):
    out = []
    for path in _package_files_under(root):
        rel = path.relative_to(root).as_posix()
        if rel.startswith(("engine/usd/", "exporters/usd/")) or rel in PXR_ELSEWHERE:
            continue
        for module, level in _imports(path):
            if level == 0 and _top(module) == "pxr":
                out.append(f"{rel} imports pxr")
    return out


def test_pxr_only_in_the_usd_modules():
    offences = _pxr_offences()
    assert not offences, offences
    for rel in PXR_ELSEWHERE:   # a named module that no longer needs pxr leaves the list
        assert any(_top(m) == "pxr" for m, level in _imports(REPO / rel) if not level), rel


def _package_files_under(root):
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root).parts
        if parts[0] in SCRIPTS or path in SCENE_SCRIPTS:
            continue
        yield path


def _module_name(path, root=REPO, package="lantern"):
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join([package, *parts])


@functools.lru_cache(maxsize=None)
def _module_names(root, package):
    return frozenset(_module_name(p, root, package) for p in _package_files_under(root))


def _module_imports(path, root=REPO, package="lantern"):
    """(imported module, [names taken from it]) for every import of the package's own
    modules in a file; `from A import b` where A.b is a module counts as importing A.b."""
    modules = _module_names(root, package)
    tree = ast.parse(path.read_text(), filename=str(path))
    own = path.relative_to(root).parent.parts
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == package:
                    yield alias.name, []
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(own[: len(own) - (node.level - 1)])
                name = ".".join([package, *base, *([node.module] if node.module else [])])
            elif (node.module or "").split(".")[0] == package:
                name = node.module
            else:
                continue
            taken = []
            for alias in node.names:
                if f"{name}.{alias.name}" in modules:
                    yield f"{name}.{alias.name}", []
                else:
                    taken.append(alias.name)
            if taken:
                yield name, taken


def _private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _private_offences(root=REPO, package="lantern"):
    out = []
    for path in _package_files_under(root):
        importer = _module_name(path, root, package)
        own_package = importer if path.name == "__init__.py" else importer.rpartition(".")[0]
        for module, names in _module_imports(path, root, package):
            module_package = module.rpartition(".")[0] if module != package else module
            hidden = [n for n in names if _private(n)]
            if any(_private(part) for part in module.split(".")[1:]) and \
                    module_package != own_package:
                hidden.append(module)
            if hidden and module_package != own_package and module != own_package:
                out.append(f"{path.relative_to(root)} imports {', '.join(hidden)} from {module}")
    return out


def test_no_module_imports_another_packages_private_names():
    offences = _private_offences()
    assert not offences, offences


def _import_graph(root=REPO, package="lantern"):
    """module -> the package's modules it imports (anywhere in it, lazily or not)."""
    files = {_module_name(p, root, package): p for p in _package_files_under(root)}
    graph = {}
    for name, path in files.items():
        graph[name] = {m for m, _ in _module_imports(path, root, package)
                       if m in files and m != name}
    return graph


def _cycles(graph):
    """The import cycles of a graph, each as [a, b, ..., a] (Tarjan's strongly
    connected components, then one path around each)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def connect(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in sorted(graph.get(node, ())):
            if other not in index:
                connect(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                out.append(_loop(graph, set(component)))

    for node in sorted(graph):
        if node not in index:
            connect(node)
    return out


def _loop(graph, component):
    """One cycle through a strongly connected component, for the message."""
    start = min(component)
    path, seen = [start], {start}
    while True:
        step = next(m for m in sorted(graph[path[-1]]) if m in component)
        if step in seen:
            return path[path.index(step):] + [step]
        path.append(step)
        seen.add(step)


def test_no_import_cycles():
    cycles = _cycles(_import_graph())
    assert not cycles, [" -> ".join(c) for c in cycles]


def test_only_main_imports_the_cli():
    cli = REPO / "cli"
    offences = [f"{path.relative_to(REPO)} imports lantern.cli"
                for path in _package_files_under(REPO)
                if path.name != "__main__.py" and cli not in path.parents
                for module, _ in _module_imports(path)
                if module == "lantern.cli" or module.startswith("lantern.cli.")]
    assert not offences, offences


def _tree(root, files):
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)


def test_the_package_guards_can_fail(tmp_path):
    """A temporary module tree with a deliberate cycle (through a lazy import), a
    private name taken across packages and pxr outside the USD modules: each caught."""
    _tree(tmp_path, {
        "__init__.py": "",
        "a/__init__.py": "",
        "a/one.py": "from .two import helper\n",
        "a/two.py": "def helper():\n    from ..b.three import _secret\n",
        "b/__init__.py": "",
        "b/three.py": "from pxr import Usd\nfrom ..a import one\n_secret = 1\n",
        "c/__init__.py": "",
        "c/free.py": "from ..a.one import helper\n",
    })
    graph = _import_graph(tmp_path, "pkg")
    assert graph["pkg.a.one"] == {"pkg.a.two"} and graph["pkg.c.free"] == {"pkg.a.one"}
    cycles = _cycles(graph)
    assert [set(c) for c in cycles] == [{"pkg.a.one", "pkg.a.two", "pkg.b.three"}], cycles
    assert cycles[0][0] == cycles[0][-1]
    assert _private_offences(tmp_path, "pkg") == ["a/two.py imports _secret from pkg.b.three"]
    assert _pxr_offences(tmp_path) == ["b/three.py imports pxr"]
    (tmp_path / "b" / "three.py").write_text("_secret = 1\n")    # the cycle broken
    assert _cycles(_import_graph(tmp_path, "pkg")) == []


def test_every_module_says_what_it_is_for():
    """Each of the package's modules opens with a docstring (its first sentence says
    what the module is for)."""
    missing = [str(path.relative_to(REPO)) for path in _package_files_under(REPO)
               if not ast.get_docstring(ast.parse(path.read_text()))]
    assert not missing, missing


# The house's size for a module of the engine and the command line.
MODULE_LINES = 450
SIZED_FOLDERS = ("engine", "cli")


def _long_modules(root):
    """'path: N lines' of each module of SIZED_FOLDERS under `root` longer than
    MODULE_LINES."""
    return [f"{path.relative_to(root)}: {n} lines" for folder in SIZED_FOLDERS
            for path in sorted((root / folder).rglob("*.py"))
            if (n := len(path.read_text().splitlines())) > MODULE_LINES]


def test_engine_and_cli_modules_stay_small():
    long = _long_modules(REPO)
    assert not long, f"past {MODULE_LINES} lines, split by job: {long}"


def test_the_size_guard_can_fail(tmp_path):
    for folder in SIZED_FOLDERS:
        (tmp_path / folder / "deep").mkdir(parents=True)
        (tmp_path / folder / "deep" / "fits.py").write_text("x = 1\n" * MODULE_LINES)
        (tmp_path / folder / "deep" / "long.py").write_text("x = 1\n" * (MODULE_LINES + 1))
    assert _long_modules(tmp_path) == [f"{folder}/deep/long.py: {MODULE_LINES + 1} lines"
                                       for folder in SIZED_FOLDERS]
