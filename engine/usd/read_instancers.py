"""The reading of PointInstancers (one batch of GPU instances per prototype mesh and
mirroring), and of Points prims and curves drawn as round tubes, into scene records."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene import Changes, Instance, PointCloud
from .curve_shapes import tubes
from .gprims import is_curves
from .instancers import instance_matrices, points_data, prototype_meshes
from .read import asset_path
from .skel import pose_might_vary, skinned_points
from .timeline import NOT_GEOMETRY, Dynamic, mesh_attributes_vary
from .validate import NOT_FINITE


@dataclass
class InstancerState:
    """A PointInstancer read: its batches (Instance paths), the prototypes it draws,
    whether anything of it may vary in time."""
    batches: set = field(default_factory=set)
    protos: tuple = ()
    varies: bool = False


class InstancerReading:
    """StageReader's reading of PointInstancers and Points (state: stage.py)."""

    def _read_instancer(self, prim, changes: Changes, rebuild: bool = False):
        """(Re)reads a PointInstancer: one batch (an Instance with `worlds`) per
        prototype mesh and mirroring, drawn with GPU instancing."""
        path = str(prim.GetPath())
        self._read.add(path)
        warnings = self.scene.warnings[path] = []
        state = self._instancers.get(path) or InstancerState()
        old = set(state.batches)
        state.batches = set()
        protos, indices, mats, keep = instance_matrices(prim, self._t, warnings)
        state.protos = tuple(protos)
        world = self._world(path)
        state.varies = self._xform_varies(prim) or any(
            a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()
            if not a.GetName().startswith(NOT_GEOMETRY))
        if not np.isfinite(world).all():
            warnings.append(f"{path}: its world transform is {NOT_FINITE} "
                            f"({self._bad_op(prim) or path}); nothing drawn")
            keep = np.zeros(len(indices), bool)
        undrawn_warned = False
        for k, proto in enumerate(protos):
            sel = keep & (indices == k)
            proto_prim = self.stage.GetPrimAtPath(proto)
            if not proto_prim:
                if sel.any():
                    warnings.append(f"{path}: prototype {proto} does not exist; its "
                                    f"{int(sel.sum())} instances are skipped")
                continue
            if not sel.any():
                continue
            inside = prototype_meshes(self.stage, proto, self._t, warnings, (path,))
            if inside.undrawn and not undrawn_warned:
                undrawn_warned = True
                warnings.append(f"{path}: Points and curve tubes in prototypes "
                                f"({inside.undrawn[0]}) are not drawn")
            state.protos += tuple(inside.protos)
            state.varies |= any(self._xform_varies(p) or mesh_attributes_vary(p)
                                for p in inside.instancers)
            placed = world @ mats[sel]
            for mesh_prim, rel in inside.meshes:
                worlds = (placed[:, None] @ rel[None]).reshape(-1, 4, 4)
                state.varies |= mesh_attributes_vary(mesh_prim)
                mirrored = np.linalg.det(worlds[:, :3, :3]) < 0
                for sign, part in (("", ~mirrored), ("-", mirrored)):
                    if part.any():
                        batch = f"{path}{{{mesh_prim.GetPath()}}}{sign}"
                        if self._read_batch(batch, mesh_prim, worlds[part], warnings, changes,
                                            rebuild):
                            state.batches.add(batch)
        for batch in old - state.batches:
            self._drop_instance(batch, changes)
        self._instancers[path] = state

    def _read_batch(self, batch, mesh_prim, worlds, warnings, changes, rebuild=False) -> bool:
        key = self._mesh_key(mesh_prim, batch, None, rebuild, warnings, changes,
                             instances=len(worlds))
        if key is None:
            return False
        mesh = self.scene.meshes[key]
        old = self.scene.instances.get(batch)
        if old is not None and old.mesh_key != key:
            self._unuse_mesh(old.mesh_key, batch, changes)
        self._users.setdefault(key, set()).add(batch)
        previous = self._inst.get(batch)
        dyn = Dynamic(world_prim=batch, materials=tuple(mesh.materials))
        for name in set(previous.materials if previous else ()) - set(dyn.materials):
            self._unuse_material(name, batch)
        for name in dyn.materials:
            self._material_users.setdefault(name, set()).add(batch)
        self._inst[batch] = dyn
        self.scene.instances[batch] = Instance(batch, key, np.eye(4), worlds=worlds,
                                               asset=asset_path(self.stage.GetPrimAtPath(
                                                   batch.split("{", 1)[0])))
        changes.instances.add(batch)
        return True

    def _read_points(self, prim, changes: Changes):
        path = str(prim.GetPath())
        self._read.add(path)
        warnings = self.scene.warnings[path] = []
        self._points[path] = self._xform_varies(prim) or any(
            a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()
            if not a.GetName().startswith(NOT_GEOMETRY))
        placed_by, skinned = path, None
        binding = self.skel.get(path) if is_curves(prim) else None
        if binding is not None:
            # Skinned tubes: points UsdSkel skinned on the CPU, in the skeleton's space.
            skinned = skinned_points(prim, binding, self._t, warnings)
            if skinned is not None:
                placed_by = str(binding[0].GetPrim().GetPath())
                self._points[path] = self._points[path] or pose_might_vary(binding[0]) or \
                    self._xform_varies(binding[0].GetPrim())
        world = self._world(placed_by)
        try:
            if not np.isfinite(world).all():
                raise ValueError(f"its world transform is {NOT_FINITE} ({self._bad_op(prim)})")
            segments = None
            if is_curves(prim):
                points, radii, colours, segments = tubes(prim, self._t, warnings, skinned)
            else:
                points, radii, colours = points_data(prim, self._t)
        except ValueError as exc:
            what = "curves" if is_curves(prim) else "points"
            warnings.append(f"{path}: malformed {what} ({exc}); skipped")
            self._drop_points(path, changes, keep_prim=True)
            return
        mats, _ = self._face_materials(prim, warnings)
        old = self.scene.points.get(path)
        if old is not None and old.material != mats[0].name:
            self._unuse_material(old.material, path)
        self._material_users.setdefault(mats[0].name, set()).add(path)
        self.scene.points[path] = PointCloud(path, points, radii, colours, mats[0].name, world,
                                             asset=asset_path(prim), segments=segments)
        changes.points.add(path)

    def _drop_points(self, path, changes: Changes, keep_prim=False):
        if not keep_prim:
            self._points.pop(path, None)
        cloud = self.scene.points.pop(path, None)
        if cloud is not None:
            self._unuse_material(cloud.material, path)
            changes.points.add(path)
