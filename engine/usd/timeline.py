"""Time sampling: what of a read stage may vary in time (UsdGeom's
TransformMightBeTimeVarying up the ancestors, attributes' ValueMightBeTimeVarying,
UsdSkel's animation queries), and reading only that again at a new time."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import UsdGeom

from ..scene import Changes
from .skel import blend_weights


@dataclass
class Dynamic:
    """What of one instance may change with time (and so is read again per frame)."""
    world_prim: str                 # the prim whose local-to-world places it
    world: bool = False
    mesh: bool = False
    shapes: bool = False
    skel: str | None = None         # the skeleton posing it
    materials: tuple = ()


NOT_GEOMETRY = ("xformOp", "visibility", "purpose", "proxyPrim", "material:", "skel:",
                "primvars:skel:")


def mesh_attributes_vary(prim) -> bool:
    """Points, normals, primvars or topology with time samples: the mesh is rebuilt at
    every new time (and never shared)."""
    return any(a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()
               if not a.GetName().startswith(NOT_GEOMETRY))


class TimeSampling:
    """StageReader's time job: which records vary, and the re-read at a new time
    (state: stage.py)."""

    def _xform_varies(self, prim) -> bool:
        """Whether the prim's local-to-world may change in time (any xformable
        ancestor's transform may)."""
        path = str(prim.GetPath())
        memo = self._xform_memo.get(path)
        if memo is None:
            xf = UsdGeom.Xformable(prim)
            own = bool(xf) and xf.TransformMightBeTimeVarying()
            parent = prim.GetParent()
            memo = own or (bool(parent) and not parent.IsPseudoRoot()
                           and self._xform_varies(parent))
            self._xform_memo[path] = memo
        return memo

    def _advance(self, changes: Changes):
        """A new time: read again only what may vary in time."""
        for path, was in list(self._visibility.items()):
            prim = self.stage.GetPrimAtPath(path)
            now = UsdGeom.Imageable(prim).GetVisibilityAttr().Get(self._t) if prim else None
            if now != was:
                self._resync(path, changes)
        for key, s in self._skels.items():
            if s.varies and key not in self._read:
                self._pose(key, s)
                changes.skeletons.add(key)
        for path, dyn in list(self._inst.items()):
            if path in self._read or path not in self._inst:
                continue
            prim = self.stage.GetPrimAtPath(path)
            if dyn.mesh:
                self._read_instance(prim, changes, rebuild=True)
                continue
            inst = self.scene.instances[path]
            if dyn.world:
                world = self._world(dyn.world_prim)
                if not np.isfinite(world).all():
                    self._read.add(path)
                    self._non_finite_world(path, dyn, changes)
                    continue
                if not np.array_equal(world, inst.world):
                    inst.world = world
                    changes.instances.add(path)
                self._read.add(path)
            if dyn.shapes:
                skel_query, sq = self.skel.get(path)
                inst.shapes = blend_weights(skel_query, sq, self._shape_queries, prim, self._t)
                changes.shapes.add(path)
                self._read.add(path)
        for path, state in list(self._instancers.items()):
            prim = self.stage.GetPrimAtPath(path)
            if state.varies and prim and path not in self._read:
                self._read_instancer(prim, changes)
        for path, varies in list(self._points.items()):
            prim = self.stage.GetPrimAtPath(path)
            if varies and prim and path not in self._read:
                self._read_points(prim, changes)
        for path in list(self._retry):
            prim = self.stage.GetPrimAtPath(path)
            if prim and path not in self._read:
                self.scene.warnings.pop(path, None)
                self._read_instance(prim, changes, rebuild=False)
        for path, varies in list(self._light_prims.items()):
            if varies is None:             # read since the last new time: asked now
                varies = self._light_varies(path)
            if varies and path not in self._read:
                self._read_light(self.stage.GetPrimAtPath(path), changes)
            if path in self._light_prims:
                self._light_prims[path] = varies
        for name, varies in list(self._material_varies.items()):
            if varies and name not in self._read:
                self._reread_material(name, changes)
