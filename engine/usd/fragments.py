"""Stage edits as messages between processes.

A *fragment* carries the specs at some paths of a layer and what to do with each:
copy it (a prim with its subtree, or one property), set a prim's own fields (its
metadata, or the layer's), or remove it. The specs travel as usda text, except
numeric arrays of ARRAY_MIN values or more, which travel beside it as numpy arrays
(exact, and a fraction of their text size). A fragment is plain data (str, lists,
numpy arrays): it pickles across a process boundary and names no class of Lantern.

The sender keeps a mirror of the receiver's stage (Mirror, below). It edits the mirror
with the USD API and encodes what USD reports changed (Usd.Notice.ObjectsChanged,
collected by engine/usd/changes.py). USD skips a value set to what it was, and Sdf.CopySpec and
Sdf.Layer.TransferContent change only the fields that differ, so the report is the
minimal edit, whatever was rewritten. The receiver applies a fragment the same way
(CopySpec, TransferContent), so what listens to its stage (a Session) sees that same
minimal edit and reads again only what it touches.

    fragment = mirror.fragment()        # sender (a Mirror)
    apply(stage, fragment)              # receiver
"""
from __future__ import annotations

import numpy as np
from pxr import Sdf, Usd, Vt

from .changes import ChangeTracker

ARRAY_MIN = 16          # arrays with this many scalars or more travel as numpy
ROOT = Sdf.Path.absoluteRootPath


def _spec_path(text: str) -> Sdf.Path:
    """The prim or property a changed path belongs to (a relationship target or a
    connection path stands for its property)."""
    path = Sdf.Path(text)
    while not (path.IsPrimPath() or path.IsPropertyPath() or path == ROOT):
        path = path.GetParentPath()
    return path


def plan(layer: Sdf.Layer, resynced, changed) -> dict:
    """What to send for the paths USD reported: {"all": True} for the whole layer,
    else copy / fields / remove lists of path strings (no path under another's
    copied or removed subtree)."""
    resynced = {_spec_path(p) for p in resynced}
    changed = {_spec_path(p) for p in changed}
    if ROOT in resynced:
        return {"all": True, "copy": [], "fields": [], "remove": []}
    copy, remove, fields = set(), set(), set()
    for path in resynced | {p for p in changed if p.IsPropertyPath()}:
        (copy if layer.GetObjectAtPath(path) else remove).add(path)
    for path in changed:
        if (path.IsPrimPath() or path == ROOT) and layer.GetObjectAtPath(path):
            fields.add(path)
    subtrees = {p for p in copy | remove if p.IsPrimPath()}

    def covered(path):
        prim = path.GetPrimPath()
        return any(prim.HasPrefix(root) and (prim != root or path.IsPropertyPath())
                   for root in subtrees)

    out = {"all": False}
    out["copy"] = sorted(str(p) for p in copy if not covered(p))
    out["remove"] = sorted(str(p) for p in remove if not covered(p))
    out["fields"] = sorted(str(p) for p in fields if not any(p.HasPrefix(r) for r in subtrees))
    return out


def encode(layer: Sdf.Layer, resynced=(), changed=()) -> dict | None:
    """The fragment that brings a copy of `layer` as it was up to `layer` as it is,
    given the paths USD reported changed (resynced, info-only); None when nothing
    changed."""
    todo = plan(layer, resynced, changed)
    if not (todo["all"] or todo["copy"] or todo["fields"] or todo["remove"]):
        return None
    frag = Sdf.Layer.CreateAnonymous(".usda")
    if todo["all"]:
        frag.TransferContent(layer)
    _copy_specs(layer, frag, todo["copy"])
    for text in todo["fields"]:
        path = Sdf.Path(text)
        src = layer.GetObjectAtPath(path)
        dst = frag.pseudoRoot if path == ROOT else Sdf.CreatePrimInLayer(frag, path)
        for key in src.ListInfoKeys():
            dst.SetInfo(key, src.GetInfo(key))
    arrays = _take_arrays(frag)
    return {"all": todo["all"], "copy": todo["copy"], "fields": todo["fields"],
            "remove": todo["remove"], "text": frag.ExportToString(), "arrays": arrays}


def _copy_specs(src: Sdf.Layer, dst: Sdf.Layer, paths) -> None:
    """Copies each spec (a prim with its subtree, or one property) at the same path,
    making its parent prim in `dst` first (as an `over`)."""
    for text in paths:
        path = Sdf.Path(text)
        parent = path.GetPrimPath() if path.IsPropertyPath() else path.GetParentPath()
        if parent != ROOT:
            Sdf.CreatePrimInLayer(dst, parent)
        Sdf.CopySpec(src, path, dst, path)


def _is_numeric_array(value) -> bool:
    return type(value).__name__.endswith("Array") and hasattr(type(value), "FromNumpy")


def _take_arrays(frag: Sdf.Layer) -> list:
    """Moves numeric arrays of ARRAY_MIN scalars or more out of `frag`:
    [(attribute path, time or None, Vt type name, numpy array)]."""
    paths = []
    frag.Traverse(ROOT, lambda p: paths.append(p) if p.IsPropertyPath() else None)
    out = []
    for path in paths:
        spec = frag.GetAttributeAtPath(path)
        if spec is None:
            continue
        if spec.HasDefaultValue():
            value = spec.default
            if _is_numeric_array(value) and len(value) and np.size(value) >= ARRAY_MIN:
                out.append((str(path), None, type(value).__name__, np.array(value)))
                spec.ClearDefaultValue()
        for t in frag.ListTimeSamplesForPath(path):
            value = frag.QueryTimeSample(path, t)
            if _is_numeric_array(value) and len(value) and np.size(value) >= ARRAY_MIN:
                out.append((str(path), float(t), type(value).__name__, np.array(value)))
                frag.EraseTimeSample(path, t)
    return out


def size(fragment: dict | None) -> int:
    """Bytes a fragment carries (text and arrays)."""
    if fragment is None:
        return 0
    return len(fragment["text"].encode()) + sum(a.nbytes for *_, a in fragment["arrays"])


def decode(fragment: dict) -> Sdf.Layer:
    """The fragment's specs as an anonymous layer, arrays put back."""
    frag = Sdf.Layer.CreateAnonymous(".usda")
    if not frag.ImportFromString(fragment["text"]):
        raise ValueError("a stage fragment's text did not parse")
    for path, t, type_name, array in fragment["arrays"]:
        value = getattr(Vt, type_name).FromNumpy(np.ascontiguousarray(array))
        if t is None:
            frag.GetAttributeAtPath(path).default = value
        else:
            frag.SetTimeSample(Sdf.Path(path), t, value)
    return frag


def receiver() -> Usd.Stage:
    """An empty in-memory stage for fragments to fill (the engine host's)."""
    return Usd.Stage.CreateInMemory()


def apply(stage, fragment: dict) -> None:
    """Applies a fragment to `stage`'s root layer (as one change block)."""
    src = decode(fragment)
    layer = stage.GetRootLayer()
    with Sdf.ChangeBlock():
        if fragment["all"]:
            layer.TransferContent(src)
            return
        for text in fragment["remove"]:
            _remove(layer, Sdf.Path(text))
        _copy_specs(src, layer, fragment["copy"])
        for text in fragment["fields"]:
            path = Sdf.Path(text)
            spec = src.GetObjectAtPath(path)
            dst = layer.pseudoRoot if path == ROOT else Sdf.CreatePrimInLayer(layer, path)
            keys = set(spec.ListInfoKeys())
            for key in dst.ListInfoKeys():
                if key not in keys:
                    dst.ClearInfo(key)
            for key in keys:
                if dst.GetInfo(key) != spec.GetInfo(key):
                    dst.SetInfo(key, spec.GetInfo(key))


def _remove(layer: Sdf.Layer, path: Sdf.Path):
    spec = layer.GetObjectAtPath(path)
    if spec is None:
        return
    if path.IsPropertyPath():
        layer.GetPrimAtPath(path.GetPrimPath()).RemoveProperty(spec)
        return
    parent = layer.pseudoRoot if path.GetParentPath() == ROOT else \
        layer.GetPrimAtPath(path.GetParentPath())
    del parent.nameChildren[path.name]


class Mirror:
    """The sender's copy of a stage the receiver holds, and what changed in it since
    the last fragment."""

    def __init__(self):
        self.stage = Usd.Stage.CreateInMemory()
        self.tracker = ChangeTracker(self.stage)

    def fragment(self):
        """The edits since the last call, as a fragment (None: nothing changed)."""
        return encode(self.stage.GetRootLayer(), *self.tracker.take())

    def replace(self, write):
        """write(stage) fills a new in-memory stage, whose contents then replace the
        mirror's (only the fields that differ change); returns what write returned."""
        scratch = Usd.Stage.CreateInMemory()
        result = write(scratch)
        self.stage.GetRootLayer().TransferContent(scratch.GetRootLayer())
        return result

    def close(self):
        self.tracker.close()
