"""Prim-path relations the stage reader needs: whether a path is under another, where
paths stand in the stage's traversal, and what a path inside an instancing prototype
stands for."""
from __future__ import annotations

from pxr import Usd

PROTOTYPE_ROOT = "/__Prototype_"


def under(path: str, root: str) -> bool:
    """Whether prim path `path` is `root` or below it (an instancer's batches,
    `<instancer>{<mesh>}`, are below the instancer)."""
    return root == "/" or path == root or path.startswith(root + "/") or \
        path.startswith(root + "{")


def map_prototypes(stage, paths) -> set:
    """Paths inside an instancing prototype stand for the same place under each of
    its instances (where the reader sees them, as instance proxies)."""
    out = set()
    for path in paths:
        if not path.startswith(PROTOTYPE_ROOT):
            out.add(path)
            continue
        root, _, rest = path[1:].partition("/")
        proto = stage.GetPrimAtPath("/" + root)
        for inst in (proto.GetInstances() if proto else []):
            out.add(str(inst.GetPath()) + ("/" + rest if rest else ""))
    return out


def traversal_order(stage, paths: set) -> dict:
    """path -> position in the stage's traversal, for the paths given."""
    order, left = {}, set(paths)
    for i, prim in enumerate(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies())):
        p = str(prim.GetPath())
        if p in left:
            order[p] = i
            left.discard(p)
            if not left:
                break
    return order
