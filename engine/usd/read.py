"""The first read of a stage into scene records (engine/scene.py), and the same reading
of one subtree again: traversal, Mesh prims as instances of shared MeshData, and the
skeletons that pose them."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pxr import Sdf, Usd, UsdGeom

from ..scene import Changes, Instance
from .camera import gf_to_np, is_camera
from .gprims import is_curves, kind_of, made_surface, source_key, undrawn_type
from .lights import is_light
from .mesh import MeshError, build_mesh
from .paths import traversal_order, under
from .skel import (SkelBindings, attach_skin, blend_weights, check_unbound, pose_might_vary,
                   skel_key, skeleton_warnings, skinned_points, weights_might_vary)
from .skel import pose as skeleton_pose
from .timeline import Dynamic, mesh_attributes_vary
from .validate import NOT_FINITE, ORIENT_OP, first_bad_op, fits


@dataclass
class SkeletonState:
    """A skeleton in use: its query, the instances it poses, whether any of them skins
    with dual quaternions, and whether its pose may vary in time."""
    query: object
    users: set = field(default_factory=set)
    dqs: bool = False
    varies: bool = False


PASS_INDEX = "lantern:passIndex"
VISIBILITY = UsdGeom.Tokens.visibility


def pass_index(prim) -> int:
    """The render-pass index (IndexOB) of a Mesh prim: `lantern:passIndex` on it or on
    the nearest ancestor that has one (the object's Xform), else 0."""
    while prim and not prim.IsPseudoRoot():
        attr = prim.GetAttribute(PASS_INDEX)
        if attr and attr.HasAuthoredValue():
            return int(attr.Get())
        prim = prim.GetParent()
    return 0


def asset_path(prim) -> str:
    """The asset a drawn prim belongs to (the Cryptomatte asset matte): the component
    model it is in (USD's kind), else its ancestor just below the stage's default prim
    (a Blender export's top-level object, as Blender's asset matte takes the topmost
    parent), else its top-level prim."""
    path = prim.GetPath()
    p = prim
    while p and not p.IsPseudoRoot():
        if p.IsComponent():
            return str(p.GetPath())
        p = p.GetParent()
    default = prim.GetStage().GetDefaultPrim()
    root = default.GetPath() if default and path.HasPrefix(default.GetPath()) and \
        path != default.GetPath() else Sdf.Path.absoluteRootPath
    return str(path.GetPrefixes()[root.pathElementCount])


class FirstRead:
    """StageReader's reading job: the whole stage, or one subtree, into records.
    The state it shares with the other jobs is set up in StageReader.__init__
    (stage.py)."""

    def _read_all(self, changes: Changes):
        """The whole stage, from nothing (the first sync, or after the stage's own
        metadata changed): everything read before is dropped."""
        self._drop_subtree("/", changes)
        self.scene.materials.clear()
        self._material_users.clear()
        self._material_varies.clear()
        self._domes.clear()
        self.scene.warnings.clear()
        self.scene.meters_per_unit = float(UsdGeom.GetStageMetersPerUnit(self.stage))
        self.scene.up_axis = str(UsdGeom.GetStageUpAxis(self.stage))
        self.skel = SkelBindings(self.stage)
        self._read_subtree("/", changes, rebuild=False)
        self._lights_moved = False    # read in traversal order: no order to restore
        self._synced = True

    def _read_subtree(self, root: str, changes: Changes, rebuild: bool = True):
        prim = self.stage.GetPrimAtPath(root)
        if not prim or (not prim.IsPseudoRoot() and
                        (not prim.IsActive() or not prim.IsDefined() or prim.IsAbstract())):
            return
        if not prim.IsPseudoRoot() and self._invisible(prim, ancestors=True):
            return
        it = iter(Usd.PrimRange(prim, Usd.TraverseInstanceProxies()))
        for p in it:
            if p.IsAbstract():
                it.PruneChildren()
                continue
            if p != prim and self._invisible(p, ancestors=False):
                it.PruneChildren()
                continue
            path = str(p.GetPath())
            kind = kind_of(p)
            if kind is not None:
                self._gprims[path] = str(p.GetTypeName())
            if is_light(p):
                self._read_light(p, changes, path)
            elif p.IsA(UsdGeom.PointInstancer):
                # Its prototypes are drawn per instance, never on their own.
                it.PruneChildren()
                self._read_instancer(p, changes)
            elif kind is not None and UsdGeom.Imageable(p).ComputePurpose() in (
                    UsdGeom.Tokens.proxy, UsdGeom.Tokens.guide):
                del self._gprims[path]
            elif kind == "points":
                self._read_points(p, changes)
            elif kind == "mesh":
                self._read_instance(p, changes, rebuild=rebuild)
            elif is_camera(p):
                self._cameras.append(path)
                changes.cameras.add(path)
            elif undrawn_type(p) is not None:
                self._undrawn[path] = self._gprims[path] = undrawn_type(p)

    def _invisible(self, prim, ancestors: bool) -> bool:
        """Invisible at this time (and remembered if its visibility may vary)."""
        if not ancestors and not prim.GetAttribute(VISIBILITY).HasAuthoredValue():
            return False                       # most prims: two calls
        img = UsdGeom.Imageable(prim)
        if not img:
            return False
        attr = img.GetVisibilityAttr()
        if attr and attr.ValueMightBeTimeVarying():
            self._visibility[str(prim.GetPath())] = attr.Get(self._t)
        if ancestors:
            return img.ComputeVisibility(self._t) == UsdGeom.Tokens.invisible
        return attr.Get(self._t) == UsdGeom.Tokens.invisible if attr else False

    def _drop_subtree(self, root: str, changes: Changes):
        for path in [p for p in self._inst if under(p, root)]:
            self._drop_instance(path, changes)
        for path in [p for p in self._instancers if under(p, root)]:
            self._instancers.pop(path)
        for path in [p for p in self._points if under(p, root)]:
            self._drop_points(path, changes)
        for path in [p for p in self._light_prims if under(p, root)]:
            self._drop_light(path, changes)
        for path in [p for p in self._cameras if under(p, root)]:
            self._cameras.remove(path)
            changes.cameras.add(path)
        for path in [p for p in self._visibility if under(p, root)]:
            del self._visibility[path]
        for table in (self._gprims, self._undrawn):
            for path in [p for p in table if under(p, root)]:
                del table[path]
        for path in [p for p in self.scene.warnings if under(p, root)]:
            del self.scene.warnings[path]
        self._retry = {p for p in self._retry if not under(p, root)}

    def _resync(self, root: str, changes: Changes):
        """Reads `root`'s subtree again from scratch; meshes elsewhere that use a
        material under it are read again too."""
        dependants = set()
        for name in [n for n in self.scene.materials if under(n, root)]:
            dependants |= self._material_users.get(name, set())
            self._forget_material(name)
        self._drop_subtree(root, changes)
        self.skel.refresh(root)
        self._read_subtree(root, changes)
        if any(under(p, root) for p in self._cameras):   # re-read ones went last
            order = traversal_order(self.stage, set(self._cameras))
            self._cameras.sort(key=lambda p: order.get(p, -1))
        for path in dependants:
            prim = self.stage.GetPrimAtPath(path)
            if not under(path, root) and prim:
                self._read_instance(prim, changes, rebuild=True)

    def _world(self, prim_path: str, prim=None, ops=None) -> np.ndarray:
        """The prim's local-to-world at this time; all NaN when it is not finite in
        float32 (validate.py), or an op of it or of an ancestor is not. Composition
        makes every such op's matrix non-finite but a quaternion's (it takes that as
        the identity), so only quaternions are read op by op; the culprit is named
        where a transform is refused (_bad_op). `prim`: the prim, where the caller has
        it; `ops`: its authored xform op names, where the caller has them (its own ops
        are then read only if one is a quaternion; its ancestors' are read)."""
        prim = prim or self.stage.GetPrimAtPath(prim_path)
        world = gf_to_np(self._xcache.GetLocalToWorldTransform(prim))
        if not fits(float(np.abs(world).max())):             # NaN, Inf or too large
            return np.full((4, 4), np.nan)
        if ops is not None and not any(op.startswith(ORIENT_OP) for op in ops):
            prim = prim.GetParent()
        if prim and not prim.IsPseudoRoot() and \
                first_bad_op(prim, self._t, self._orient_memo, orient_only=True) is not None:
            return np.full((4, 4), np.nan)
        return world

    def _bad_op(self, prim):
        return first_bad_op(prim, self._t, self._op_memo)

    def _read_instance(self, prim, changes: Changes, rebuild: bool):
        """(Re)reads a Mesh prim: its mesh data (built unless shared data was built
        already, or `rebuild`), materials, placement, blend shapes; classifies what
        of it varies in time."""
        path = str(prim.GetPath())
        self._read.add(path)
        warnings = self.scene.warnings[path] = []
        binding = self.skel.get(path)
        if binding is None:
            check_unbound(prim, warnings)
        self._shape_queries.pop(path, None)    # its blend shapes may have been edited
        key = self._mesh_key(prim, path, binding, rebuild, warnings, changes)
        if key is None:
            if path in self._inst:
                self._drop_instance(path, changes)
            return
        mesh = self.scene.meshes[key]
        old = self.scene.instances.get(path)
        if old is not None and old.mesh_key != key:
            self._unuse_mesh(old.mesh_key, path, changes)
        self._users.setdefault(key, set()).add(path)

        skin = mesh.skin
        dyn = Dynamic(world_prim=path, mesh=key[0] == "varying",
                       materials=tuple(mesh.materials))
        if binding is not None and is_curves(prim):
            # Ribbons are made from points UsdSkel skinned on the CPU (skel space):
            # made again whenever the pose may change.
            skel_query = binding[0]
            dyn.mesh = pose_might_vary(skel_query)
            dyn.world_prim = str(skel_query.GetPrim().GetPath())
        previous = self._inst.get(path)
        if previous is not None and previous.skel is not None and \
                (skin is None or previous.skel != skin.skel_key):
            self._unuse_skeleton(previous.skel, path, changes)
        shapes = []
        if skin is not None:
            skel_query, sq = binding
            if skin.shape_offsets is not None:
                shapes = blend_weights(skel_query, sq, self._shape_queries, prim, self._t)
                dyn.shapes = weights_might_vary(skel_query)
            if skin.has_joints:
                dyn.skel = skin.skel_key
                # UsdSkel skins into skeleton space: the mesh's own transform is ignored.
                dyn.world_prim = str(skel_query.GetPrim().GetPath())
                self._use_skeleton(skel_query, path, skin.method == "dqs", changes)
        dyn.world = self._xform_varies(self.stage.GetPrimAtPath(dyn.world_prim))
        world = self._world(dyn.world_prim)
        finite = bool(np.isfinite(world).all())
        if finite:
            self._retry.discard(path)
        else:
            world = np.eye(4)         # registered, then dropped below
        index = pass_index(prim)
        if old is not None and old.mesh_key == key:
            old.world = world
            old.shapes = shapes
            old.pass_index = index
        else:
            self.scene.instances[path] = Instance(path, key, world, shapes=shapes,
                                                  pass_index=index, asset=asset_path(prim))
        for name in set(previous.materials if previous else ()) - set(dyn.materials):
            self._unuse_material(name, path)
        for name in dyn.materials:
            self._material_users.setdefault(name, set()).add(path)
        self._inst[path] = dyn
        changes.instances.add(path)
        if shapes or skin is not None and skin.shape_offsets is not None:
            changes.shapes.add(path)
        if not finite:
            self._non_finite_world(path, dyn, changes)

    def _mesh_key(self, prim, path, binding, rebuild, warnings, changes, instances=1):
        """The key of the prim's MeshData, built unless shared data was built already
        (or `rebuild`); None (with a warning) for a malformed mesh. `instances`: how
        many times a PointInstancer draws it (an implicit surface's detail)."""
        try:
            mats, subsets = self._face_materials(prim, warnings)
            if not prim.IsA(UsdGeom.Mesh):
                subsets = []             # faces the engine makes have no subsets
            if binding is not None:
                key = ("skinned", path)
            elif mesh_attributes_vary(prim):
                key = ("varying", str(prim.GetPath()))
            else:
                key = (source_key(prim, self._t, instances), tuple(m.name for m in mats),
                       tuple((m, tuple(f.tolist())) for m, f in subsets))
            if key not in self.scene.meshes or key not in self._built and \
                    (rebuild or key[0] in ("skinned", "varying")):
                skinned = None
                if binding is not None and is_curves(prim):
                    skinned = skinned_points(prim, binding, self._t, warnings)
                    warnings.append(f"{path}: skinned curves with normals: the ribbons face "
                                    f"their rest-pose normals (normals are not skinned)")
                surface = made_surface(prim, self._t, warnings, instances, skinned)
                mesh = build_mesh(prim, self._t, mats, [(i + 1, f) for i, (_, f) in
                                                        enumerate(subsets)], key, warnings,
                                  tessellate=self.tessellate, surface=surface)
                if binding is not None and not is_curves(prim):
                    attach_skin(mesh, prim, binding, self._t, warnings,
                                None if surface is None else surface.points)
                self.scene.meshes[key] = mesh
                self._built.add(key)
                changes.meshes.add(key)
        except MeshError as exc:
            warnings.append(f"{prim.GetPath()}: malformed mesh ({exc}); skipped")
            return None
        return key

    def _non_finite_world(self, path, dyn, changes):
        """A mesh whose world transform is not finite in float32 at this time: skipped
        with a warning, and read again at the next time if its transform varies."""
        when = "" if self._t.IsDefault() else f" at time {self._t.GetValue():g}"
        prim = self.stage.GetPrimAtPath(dyn.world_prim)
        culprit = (self._bad_op(prim) if prim else None) or dyn.world_prim
        warning = f"{path}: its world transform is {NOT_FINITE}{when} ({culprit}); skipped"
        warnings = self.scene.warnings.setdefault(path, [])
        if warning not in warnings:
            warnings.append(warning)
        if path in self.scene.instances or path in self._inst:
            self._drop_instance(path, changes)
        if dyn.world:
            self._retry.add(path)

    def _drop_instance(self, path: str, changes: Changes):
        self._shape_queries.pop(path, None)
        inst = self.scene.instances.pop(path, None)
        dyn = self._inst.pop(path, None)
        if inst is not None:
            self._unuse_mesh(inst.mesh_key, path, changes)
            changes.dropped_instances.add(path)
        if dyn is not None:
            for name in dyn.materials:
                self._unuse_material(name, path)
            if dyn.skel is not None:
                self._unuse_skeleton(dyn.skel, path, changes)

    def _unuse_mesh(self, key, path, changes: Changes):
        users = self._users.get(key, set())
        users.discard(path)
        if not users:
            self._users.pop(key, None)
            if self.scene.meshes.pop(key, None) is not None:
                changes.dropped_meshes.add(key)
                changes.meshes.discard(key)

    def _use_skeleton(self, skel_query, path, dqs, changes: Changes):
        key = skel_key(skel_query)
        s = self._skels.get(key)
        if s is None:
            s = self._skels[key] = SkeletonState(skel_query, varies=pose_might_vary(skel_query))
        s.query = skel_query
        s.users.add(path)
        pose = self.scene.skeletons.get(key)
        if pose is None or (dqs and not pose.dqs) or key not in changes.skeletons:
            s.dqs = s.dqs or dqs
            self._pose(key, s)
            changes.skeletons.add(key)

    def _pose(self, key, s):
        """A skeleton's pose at this time; its warnings (counts that do not match,
        non-finite poses) under its own path."""
        warnings = skeleton_warnings(s.query)
        self.scene.skeletons[key] = skeleton_pose(s.query, self._t, s.dqs, warnings)
        if warnings:
            self.scene.warnings[key] = warnings
        else:
            self.scene.warnings.pop(key, None)
        self._read.add(key)

    def _unuse_skeleton(self, key, path, changes: Changes):
        s = self._skels.get(key)
        if s is None:
            return
        s.users.discard(path)
        if not s.users:
            del self._skels[key]
            self.scene.skeletons.pop(key, None)
            self.scene.warnings.pop(key, None)
