"""A Usd.Stage kept as a Scene (engine/scene.py) for as long as a Session lives.

The first sync reads every prim. It also sorts what it read into static and dynamic
(seed 003): a record is read again at a new time only when something it depends on
may vary in time (UsdGeom's TransformMightBeTimeVarying up the ancestors, attributes'
ValueMightBeTimeVarying, UsdSkel's animation queries). Later syncs read only
  - the prims that Usd.Notice.ObjectsChanged reported (engine/usd/changes.py): a
    transform edit re-reads the world matrices under that prim, a mesh edit that mesh,
    a material edit that material (and the meshes whose layout depends on it), a light
    edit that light, a resync (prims added, removed or recomposed) that subtree;
  - at a new time, the dynamic records: transforms, time-sampled meshes, skeleton
    poses, blend-shape weights, lights, time-varying materials and visibility.
Each sync returns `Changes`, what it replaced, and counts the prims it read.

Traversal includes instance proxies and skips abstract (`class`) and invisible prims.
Meshes sharing their data (same strongest `points` spec, same materials) share one
MeshData. A malformed mesh is skipped with a warning naming it."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

from ..lighting import default_dome, headlight
from ..scene import Changes, Instance, PointCloud, Scene
from . import camera as cam
from . import lights as lt
from . import materials as mt
from . import instancers as ins
from . import skel as sk
from .changes import ChangeTracker
from .mesh import MeshError, build_mesh

PROTOTYPE_ROOT = "/__Prototype_"
HEADLIGHT = "<headlight>"


def open_stage(path) -> Usd.Stage:
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise OSError(f"cannot open USD file {path}")
    return stage


def under(path: str, root: str) -> bool:
    """Whether prim path `path` is `root` or below it (an instancer's batches,
    `<instancer>{<mesh>}`, are below the instancer)."""
    return root == "/" or path == root or path.startswith(root + "/") or \
        path.startswith(root + "{")


@dataclass
class _Dynamic:
    """What of one instance may change with time (and so is read again per frame)."""
    world_prim: str                 # the prim whose local-to-world places it
    world: bool = False
    mesh: bool = False
    shapes: bool = False
    skel: str | None = None         # the skeleton posing it
    materials: tuple = ()


@dataclass
class _Instancer:
    """A PointInstancer read: its batches (Instance paths), the prototypes it draws,
    whether anything of it may vary in time."""
    batches: set = field(default_factory=set)
    protos: tuple = ()
    varies: bool = False


@dataclass
class _Skeleton:
    query: object
    users: set = field(default_factory=set)
    dqs: bool = False
    varies: bool = False


class StageReader:
    def __init__(self, stage: Usd.Stage):
        self.stage = stage
        self.scene = Scene()
        self.tracker = ChangeTracker(stage)
        self.time = None              # the last sync's frame (None: Default)
        self.skel = None
        self._synced = False
        self._inst = {}               # instance path -> _Dynamic
        self._users = {}              # mesh key -> instance paths drawing it
        self._built = set()           # mesh keys built during this sync
        self._material_users = {}     # material name -> instance paths
        self._material_varies = {}    # Material prim path -> it may vary in time
        self._skels = {}              # skel key -> _Skeleton
        self._shape_queries = {}
        self._light_prims = {}        # every UsdLux prim -> may vary in time
        self._domes = {}              # dome prim path -> Dome
        self._cameras = []            # camera prim paths, traversal order
        self._visibility = {}         # prims whose own visibility may vary -> last value
        self._xform_memo = {}
        self._read = set()
        self._lights_moved = False    # lights added or removed: their order to restore
        self._retry = set()           # meshes skipped for a non-finite time-varying transform
        self._instancers = {}         # PointInstancer path -> _Instancer
        self._points = {}             # Points prim path -> it may vary in time
        self.settings_changed = False  # /Render/Settings edited since the last sync

    def close(self):
        self.tracker.close()

    # --- the one entry point ---------------------------------------------------------
    def sync(self, frame) -> Changes:
        """Brings the scene to `frame` (None: Default time) and the stage's current
        edits; returns what changed."""
        changes = Changes()
        self._read = set()
        self._built = set()
        t = cam.time_code(frame)
        self._xcache = UsdGeom.XformCache(t)
        self._op_memo = {}
        self._t = t
        if not self._synced:
            self.tracker.take()
            self._read_all(changes)
        else:
            resynced, changed = self.tracker.take()
            moved_in_time = frame != self.time
            if resynced or changed:
                self._xform_memo.clear()
                self._apply_edits(resynced, changed, changes)
            if moved_in_time:
                self._advance(changes)
        self.time = frame
        self._finish_lights(changes)
        changes.prims_read = len(self._read)
        return changes

    def cameras(self) -> list:
        """Camera prim paths in traversal order."""
        return list(self._cameras)

    # --- reading subtrees ------------------------------------------------------------
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
        self.skel = sk.SkelBindings(self.stage)
        self._read_subtree("/", changes, rebuild=False)
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
            if lt.is_light(p):
                self._read_light(p, changes)
            elif p.IsA(UsdGeom.PointInstancer):
                # Its prototypes are drawn per instance, never on their own.
                it.PruneChildren()
                self._read_instancer(p, changes)
            elif p.IsA(UsdGeom.Points):
                self._read_points(p, changes)
            elif p.IsA(UsdGeom.Mesh):
                purpose = UsdGeom.Imageable(p).ComputePurpose()
                if purpose not in (UsdGeom.Tokens.proxy, UsdGeom.Tokens.guide):
                    self._read_instance(p, changes, rebuild=rebuild)
            elif cam.is_camera(p):
                self._cameras.append(path)
                changes.cameras.add(path)

    def _invisible(self, prim, ancestors: bool) -> bool:
        """Invisible at this time (and remembered if its visibility may vary)."""
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
            order = _traversal_order(self.stage, set(self._cameras))
            self._cameras.sort(key=lambda p: order.get(p, -1))
        for path in dependants:
            prim = self.stage.GetPrimAtPath(path)
            if not under(path, root) and prim:
                self._read_instance(prim, changes, rebuild=True)

    # --- instances -------------------------------------------------------------------
    def _world(self, prim_path: str) -> np.ndarray:
        """The prim's local-to-world at this time; all NaN when an op of it or of an
        ancestor is not finite (USD composes a NaN quaternion as the identity, which
        would hide it)."""
        prim = self.stage.GetPrimAtPath(prim_path)
        if self._bad_op(prim) is not None:
            return np.full((4, 4), np.nan)
        return cam.gf_to_np(self._xcache.GetLocalToWorldTransform(prim))

    def _bad_op(self, prim):
        """'<prim path>.<op>' of the first non-finite xform op at or above `prim`, or
        None."""
        path = str(prim.GetPath())
        if path not in self._op_memo:
            bad = None
            xf = UsdGeom.Xformable(prim)
            for op in (xf.GetOrderedXformOps() if xf else []):
                v = op.Get(self._t)
                if v is not None and not _finite_value(v):
                    bad = f"{path}.{op.GetOpName()}"
                    break
            parent = prim.GetParent()
            if bad is None and parent and not parent.IsPseudoRoot():
                bad = self._bad_op(parent)
            self._op_memo[path] = bad
        return self._op_memo[path]

    def _xform_varies(self, prim) -> bool:
        """Whether the prim's local-to-world may change in time (any xformable
        ancestor's transform may)."""
        path = str(prim.GetPath())
        memo = self._xform_memo.get(path)
        if memo is None:
            xf = UsdGeom.Xformable(prim)
            own = bool(xf) and xf.TransformMightBeTimeVarying()
            parent = prim.GetParent()
            memo = own or (bool(parent) and not parent.IsPseudoRoot() and self._xform_varies(parent))
            self._xform_memo[path] = memo
        return memo

    def _read_instance(self, prim, changes: Changes, rebuild: bool):
        """(Re)reads a Mesh prim: its mesh data (built unless shared data was built
        already, or `rebuild`), materials, placement, blend shapes; classifies what
        of it varies in time."""
        path = str(prim.GetPath())
        self._read.add(path)
        warnings = self.scene.warnings[path] = []
        binding = self.skel.get(path)
        if binding is None:
            sk.check_unbound(prim, warnings)
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
        dyn = _Dynamic(world_prim=path, mesh=key[0] == "varying",
                       materials=tuple(mesh.materials))
        previous = self._inst.get(path)
        if previous is not None and previous.skel is not None and \
                (skin is None or previous.skel != skin.skel_key):
            self._unuse_skeleton(previous.skel, path, changes)
        shapes = []
        if skin is not None:
            skel_query, sq = binding
            if skin.shape_offsets is not None:
                shapes = sk.blend_weights(skel_query, sq, self._shape_queries, prim, self._t)
                dyn.shapes = sk.weights_might_vary(skel_query)
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
                                                  pass_index=index)
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

    def _mesh_key(self, prim, path, binding, rebuild, warnings, changes):
        """The key of the prim's MeshData, built unless shared data was built already
        (or `rebuild`); None (with a warning) for a malformed mesh."""
        try:
            mats, subsets = self._face_materials(prim, warnings)
            if binding is not None:
                key = ("skinned", path)
            elif _mesh_attributes_vary(prim):
                key = ("varying", str(prim.GetPath()))
            else:
                key = (_strongest_spec(UsdGeom.Mesh(prim).GetPointsAttr()),
                       tuple(m.name for m in mats),
                       tuple((m, tuple(f.tolist())) for m, f in subsets))
            if key not in self.scene.meshes or key not in self._built and \
                    (rebuild or key[0] in ("skinned", "varying")):
                mesh = build_mesh(prim, self._t, mats, [(i + 1, f) for i, (_, f) in
                                                        enumerate(subsets)], key, warnings)
                if binding is not None:
                    sk.attach_skin(mesh, prim, binding, self._t, warnings)
                self.scene.meshes[key] = mesh
                self._built.add(key)
                changes.meshes.add(key)
        except MeshError as exc:
            warnings.append(f"{prim.GetPath()}: malformed mesh ({exc}); skipped")
            return None
        return key

    # --- PointInstancers and Points ----------------------------------------------------
    def _read_instancer(self, prim, changes: Changes, rebuild: bool = False):
        """(Re)reads a PointInstancer: one batch (an Instance with `worlds`) per
        prototype mesh and mirroring, drawn with GPU instancing."""
        path = str(prim.GetPath())
        self._read.add(path)
        warnings = self.scene.warnings[path] = []
        state = self._instancers.get(path) or _Instancer()
        old = set(state.batches)
        state.batches = set()
        protos, indices, mats, keep = ins.instance_matrices(prim, self._t, warnings)
        state.protos = tuple(protos)
        world = self._world(path)
        state.varies = self._xform_varies(prim) or any(
            a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()
            if not a.GetName().startswith(_NOT_GEOMETRY))
        if not np.isfinite(world).all():
            warnings.append(f"{path}: its world transform is not finite "
                            f"({self._bad_op(prim) or path}); nothing drawn")
            keep = np.zeros(len(indices), bool)
        nested_warned = False
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
            meshes, nested = ins.prototype_meshes(self.stage, proto, self._t)
            if nested and not nested_warned:
                nested_warned = True
                warnings.append(f"{path}: nested PointInstancers ({nested[0]}) are not "
                                f"drawn")
            placed = world @ mats[sel]
            for mesh_prim, rel in meshes:
                worlds = placed @ rel
                state.varies |= _mesh_attributes_vary(mesh_prim)
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
        key = self._mesh_key(mesh_prim, batch, None, rebuild, warnings, changes)
        if key is None:
            return False
        mesh = self.scene.meshes[key]
        old = self.scene.instances.get(batch)
        if old is not None and old.mesh_key != key:
            self._unuse_mesh(old.mesh_key, batch, changes)
        self._users.setdefault(key, set()).add(batch)
        previous = self._inst.get(batch)
        dyn = _Dynamic(world_prim=batch, materials=tuple(mesh.materials))
        for name in set(previous.materials if previous else ()) - set(dyn.materials):
            self._unuse_material(name, batch)
        for name in dyn.materials:
            self._material_users.setdefault(name, set()).add(batch)
        self._inst[batch] = dyn
        self.scene.instances[batch] = Instance(batch, key, np.eye(4), worlds=worlds)
        changes.instances.add(batch)
        return True

    def _read_points(self, prim, changes: Changes):
        path = str(prim.GetPath())
        self._read.add(path)
        warnings = self.scene.warnings[path] = []
        self._points[path] = self._xform_varies(prim) or any(
            a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()
            if not a.GetName().startswith(_NOT_GEOMETRY))
        world = self._world(path)
        try:
            if not np.isfinite(world).all():
                raise ValueError(f"its world transform is not finite ({self._bad_op(prim)})")
            points, radii, colours = ins.points_data(prim, self._t)
        except ValueError as exc:
            warnings.append(f"{path}: malformed points ({exc}); skipped")
            self._drop_points(path, changes, keep_prim=True)
            return
        mats, _ = self._face_materials(prim, warnings)
        old = self.scene.points.get(path)
        if old is not None and old.material != mats[0].name:
            self._unuse_material(old.material, path)
        self._material_users.setdefault(mats[0].name, set()).add(path)
        self.scene.points[path] = PointCloud(path, points, radii, colours, mats[0].name, world)
        changes.points.add(path)

    def _drop_points(self, path, changes: Changes, keep_prim=False):
        if not keep_prim:
            self._points.pop(path, None)
        cloud = self.scene.points.pop(path, None)
        if cloud is not None:
            self._unuse_material(cloud.material, path)
            changes.points.add(path)

    def _non_finite_world(self, path, dyn, changes):
        """A mesh whose world transform is NaN or Inf at this time: skipped with a
        warning, and read again at the next time if its transform varies."""
        when = "" if self._t.IsDefault() else f" at time {self._t.GetValue():g}"
        prim = self.stage.GetPrimAtPath(dyn.world_prim)
        culprit = (self._bad_op(prim) if prim else None) or dyn.world_prim
        warning = f"{path}: its world transform is not finite{when} ({culprit}); skipped"
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
        key = sk.skel_key(skel_query)
        s = self._skels.get(key)
        if s is None:
            s = self._skels[key] = _Skeleton(skel_query, varies=sk.pose_might_vary(skel_query))
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
        warnings = sk.skeleton_warnings(s.query)
        self.scene.skeletons[key] = sk.pose(s.query, self._t, s.dqs, warnings)
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

    # --- materials -------------------------------------------------------------------
    def _face_materials(self, prim, warnings):
        """[Material] (the prim's, then one per bound GeomSubset) and [(Material name,
        face indices)] per subset. A binding to a prim that is not a Material is a
        warning, and the mesh gets the default material."""
        binding = UsdShade.MaterialBindingAPI(prim)
        base = binding.ComputeBoundMaterial()[0]
        if base:
            base_mat = self._material(base)
        else:
            _check_binding(prim, warnings)
            dc = UsdGeom.Gprim(prim).GetDisplayColorAttr().Get()
            base_mat = mt.default_material(dc[0] if dc else None)
            self.scene.materials.setdefault(base_mat.name, base_mat)
        mats, subsets = [base_mat], []
        for subset in binding.GetMaterialBindSubsets():
            m = UsdShade.MaterialBindingAPI(subset.GetPrim()).ComputeBoundMaterial()[0]
            if not m:
                _check_binding(subset.GetPrim(), warnings)
            if m:
                idx = subset.GetIndicesAttr().Get()
                mat = self._material(m)
                mats.append(mat)
                subsets.append((mat.name, np.array(idx if idx is not None else [], np.int64)))
        return mats, subsets

    def _material(self, mat: UsdShade.Material, force: bool = False):
        prim = mat.GetPrim()
        if prim.IsInstanceProxy():
            # Every instance of an instanceable reference binds the same material:
            # one record, named by the prototype's prim, so their meshes share data.
            prim = prim.GetPrimInPrototype()
            mat = UsdShade.Material(prim)
        name = str(prim.GetPath())
        if force or name not in self.scene.materials:
            warnings = self.scene.warnings[name] = []
            self.scene.materials[name] = mt.read_material(mat, self._t, warnings)
            self._material_varies[name] = mt.might_vary(mat)
            self._read.add(name)
        return self.scene.materials[name]

    def _unuse_material(self, name, path):
        users = self._material_users.get(name)
        if users is not None:
            users.discard(path)
            if not users:
                del self._material_users[name]
                self._forget_material(name)

    def _forget_material(self, name):
        self.scene.materials.pop(name, None)
        self._material_varies.pop(name, None)
        self.scene.warnings.pop(name, None)

    def _reread_material(self, name: str, changes: Changes):
        """A material edit: the record is replaced; meshes whose layout depends on it
        (its UV set, whether it needs tangents) are rebuilt."""
        prim = self.stage.GetPrimAtPath(name)
        old = self.scene.materials.get(name)
        users = set(self._material_users.get(name, ()))
        if not prim or not prim.IsA(UsdShade.Material):
            self._forget_material(name)
            relayout = users
        else:
            new = self._material(UsdShade.Material(prim), force=True)
            changes.materials.add(name)
            relayout = users if old is None or (old.uv_name, old.has_normal_map) != \
                (new.uv_name, new.has_normal_map) else set()
        for path in relayout:
            p = self.stage.GetPrimAtPath(path)
            if p:
                self._read_instance(p, changes, rebuild=True)

    # --- lights ----------------------------------------------------------------------
    def _read_light(self, prim, changes: Changes):
        path = str(prim.GetPath())
        self._read.add(path)
        warnings = self.scene.warnings[path] = []
        varies = lt.might_vary(prim) or self._xform_varies(prim)
        self._light_prims[path] = varies
        rec = lt.read_light(prim, self._world(path), self._t, warnings)
        if isinstance(rec, lt.Dome):
            self._domes[path] = rec
            changes.dome = True
        elif rec is not None:
            self._lights_moved |= path not in self.scene.lights
            self.scene.lights[path] = rec
            changes.lights.add(path)
        else:
            self._drop_light(path, changes, keep_prim=True)

    def _drop_light(self, path, changes: Changes, keep_prim: bool = False):
        if not keep_prim:
            self._light_prims.pop(path, None)
        if self.scene.lights.pop(path, None) is not None:
            changes.lights.add(path)
            self._lights_moved = True
        if self._domes.pop(path, None) is not None:
            changes.dome = True

    def _finish_lights(self, changes: Changes):
        """The one dome (the first in traversal order), and usdview's default rig when
        the stage has no UsdLux prim at all. Lights keep the stage's traversal order
        (they add up in a float16 target, where the order shows in the last bit)."""
        if self._lights_moved and len(self.scene.lights) > 1:
            order = _traversal_order(self.stage, set(self.scene.lights) - {HEADLIGHT})
            self.scene.lights = dict(sorted(self.scene.lights.items(),
                                            key=lambda kv: order.get(kv[0], -1)))
        self._lights_moved = False
        if changes.dome:
            domes = self._domes
            if len(domes) > 1:
                order = _traversal_order(self.stage, set(domes))
                domes = dict(sorted(domes.items(), key=lambda kv: order.get(kv[0], 0)))
            first = next(iter(domes), None)
            for path in domes:
                ws = self.scene.warnings.setdefault(path, [])
                skip = f"{path}: only one dome light is used; skipped"
                if path != first and skip not in ws:
                    ws.append(skip)
                elif path == first and skip in ws:
                    ws.remove(skip)
            self.scene.dome = domes[first] if first is not None else None
        rig = not self._light_prims
        if rig and HEADLIGHT not in self.scene.lights:
            self.scene.lights[HEADLIGHT] = headlight()
            self.scene.dome = default_dome()
            changes.lights.add(HEADLIGHT)
            changes.dome = True
        elif not rig and HEADLIGHT in self.scene.lights:
            del self.scene.lights[HEADLIGHT]
            changes.lights.add(HEADLIGHT)
            if not self._domes:
                self.scene.dome = None
                changes.dome = True

    # --- edits -----------------------------------------------------------------------
    def _apply_edits(self, resynced, changed, changes: Changes):
        roots, props = set(), []
        for p in resynced:
            (props.append(p) if "." in p.rsplit("/", 1)[-1] else roots.add(p))
        for p in changed:
            prim_path, _, name = p.partition(".")
            if name:
                props.append(p)
            else:
                roots.add(prim_path)         # prim metadata (active, instanceable, ...)
        # An edit of an instancer's values, or anything inside it or one of its
        # prototypes: that instancer is read again (its batches keep their meshes).
        # The instancer prim itself recomposed is a resync like any other.
        drawn_by = {}
        for p in list(roots) + [q.partition(".")[0] for q in props]:
            for pi in self._instancers_drawing(p):
                if not (p == pi and p in roots):
                    # Its own values: the same meshes; inside a prototype: rebuilt.
                    drawn_by.setdefault(p, set()).add(
                        ("instancer" if p == pi else "instancer_geometry", pi))
        roots = {r for r in roots if r not in drawn_by}
        props = [q for q in props if q.partition(".")[0] not in drawn_by]
        actions = sorted({a for users in drawn_by.values() for a in users})
        for p in props:
            prim_path, _, name = p.partition(".")
            actions += self._classify(prim_path, name, roots)
        roots = _map_prototypes(self.stage, roots)
        if "/" in roots:
            self._read_all(changes)
            return
        top = sorted(r for r in roots if not any(under(r, o) and r != o for o in roots))
        for root in top:
            self._resync(root, changes)
        done = set(top)
        for kind, path in actions:
            if any(under(path, r) for r in top) or (kind, path) in done:
                continue
            done.add((kind, path))
            getattr(self, "_edit_" + kind)(path, changes)

    def _instancers_drawing(self, path: str) -> set:
        """The PointInstancers whose drawing `path` (a prim path) is part of: at or
        below one of them, or inside one of their prototypes."""
        return {pi for pi, state in self._instancers.items()
                if under(path, pi) or any(under(path, proto) for proto in state.protos)}

    def _classify(self, prim_path: str, name: str, roots: set) -> list:
        """What a property edit asks for: [(action, path)], or a subtree added to
        `roots` when only reading it again is right."""
        out = []
        for path in _map_prototypes(self.stage, {prim_path}):
            prim = self.stage.GetPrimAtPath(path)
            if path == "/":
                roots.add("/")               # stage metadata: up axis, units
                continue
            if not prim:
                continue
            if under(path, "/Render"):
                self.settings_changed = True
                continue
            if name in ("visibility", "purpose", "proxyPrim"):
                roots.add(path)
            elif name == PASS_INDEX and not prim.IsA(UsdShade.Material):
                out.append(("binding", path))    # the instances under it read it again
            elif name.startswith("xformOp") or name == "xformOpOrder":
                out.append(("transform", path))
            elif name.startswith("material:binding"):
                out.append(("binding", path))
            elif lt.is_light(prim):
                out.append(("light", path))
            elif cam.is_camera(prim):
                out.append(("camera", path))
            elif name in ANIMATION_VALUES and _is_animation(prim):
                out.append(("pose", path))           # values only: pose again, no resync
            elif name.startswith(("skel:", "primvars:skel:")) or _is_skel(prim):
                roots.add(self.skel.root_of(path) or path)
            elif prim.IsA(UsdGeom.Points):
                roots.add(path)
            elif prim.IsA(UsdGeom.Mesh):
                out.append(("mesh", path))
            elif prim.IsA(UsdGeom.Subset) and prim.GetParent().IsA(UsdGeom.Mesh):
                out.append(("mesh", str(prim.GetParent().GetPath())))
            else:
                material = _enclosing_material(prim)
                if material is not None:
                    out.append(("material", material))
        return out

    def _edit_transform(self, root: str, changes: Changes):
        changes.cameras.update(p for p in self._cameras if under(p, root))
        for path in [p for p in self._retry if under(p, root)]:
            prim = self.stage.GetPrimAtPath(path)
            if prim:
                self._read_instance(prim, changes, rebuild=False)
        for path, dyn in list(self._inst.items()):
            if under(dyn.world_prim, root) and path not in self._read:
                world = self._world(dyn.world_prim)
                dyn.world = self._xform_varies(self.stage.GetPrimAtPath(dyn.world_prim))
                self._read.add(path)
                if not np.isfinite(world).all():
                    self._non_finite_world(path, dyn, changes)
                    continue
                self.scene.instances[path].world = world
                changes.instances.add(path)
        for path in [p for p in self._light_prims if under(p, root)]:
            self._read_light(self.stage.GetPrimAtPath(path), changes)
        for path in [p for p in self._instancers if under(p, root)]:
            self._read_instancer(self.stage.GetPrimAtPath(path), changes)
        for path in [p for p in self._points if under(p, root)]:
            self._read_points(self.stage.GetPrimAtPath(path), changes)

    def _edit_binding(self, root: str, changes: Changes):
        for path in [p for p in self._inst if under(p, root)]:
            self._read_instance(self.stage.GetPrimAtPath(path), changes, rebuild=True)

    def _edit_mesh(self, path: str, changes: Changes):
        prim = self.stage.GetPrimAtPath(path)
        if path in self._inst or path in self.scene.warnings:
            self._read_instance(prim, changes, rebuild=True)

    def _edit_instancer(self, path: str, changes: Changes, rebuild=False):
        prim = self.stage.GetPrimAtPath(path)
        if prim and prim.IsA(UsdGeom.PointInstancer):
            self._read_instancer(prim, changes, rebuild)
        else:
            self._resync(path, changes)

    def _edit_instancer_geometry(self, path: str, changes: Changes):
        self._edit_instancer(path, changes, rebuild=True)

    def _edit_light(self, path: str, changes: Changes):
        if path in self._light_prims:
            self._read_light(self.stage.GetPrimAtPath(path), changes)

    def _edit_camera(self, path: str, changes: Changes):
        changes.cameras.add(path)            # the session reads it again

    def _edit_pose(self, path: str, changes: Changes):
        """A SkelAnimation's values changed (a live pose): the skeletons it drives are
        posed again and their meshes' blend-shape weights read again; nothing else."""
        for key, s in self._skels.items():
            anim = s.query.GetAnimQuery()
            if not anim or str(anim.GetPrim().GetPath()) != path:
                continue
            self.scene.skeletons[key] = sk.pose(s.query, self._t, s.dqs)
            self._read.add(key)
            changes.skeletons.add(key)
            for inst_path in s.users:
                mesh = self.scene.meshes.get(self.scene.instances[inst_path].mesh_key)
                if mesh is not None and mesh.skin is not None and \
                        mesh.skin.shape_offsets is not None:
                    skel_query, sq = self.skel.get(inst_path)
                    prim = self.stage.GetPrimAtPath(inst_path)
                    self.scene.instances[inst_path].shapes = sk.blend_weights(
                        skel_query, sq, self._shape_queries, prim, self._t)
                    changes.shapes.add(inst_path)

    def _edit_material(self, name: str, changes: Changes):
        if name in self.scene.materials:
            self._reread_material(name, changes)

    # --- time ------------------------------------------------------------------------
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
                inst.shapes = sk.blend_weights(skel_query, sq, self._shape_queries, prim, self._t)
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
            if varies and path not in self._read:
                self._read_light(self.stage.GetPrimAtPath(path), changes)
        for name, varies in list(self._material_varies.items()):
            if varies and name not in self._read:
                self._reread_material(name, changes)


def _finite_value(v) -> bool:
    """Whether an xform op's value (a number, vector, matrix or quaternion) is finite."""
    if hasattr(v, "GetReal"):
        return np.isfinite([v.GetReal(), *v.GetImaginary()]).all()
    return bool(np.isfinite(np.asarray(v, np.float64)).all())


def _check_binding(prim, warnings):
    """A direct binding whose target is not a Material: say so."""
    rel = UsdShade.MaterialBindingAPI(prim).GetDirectBindingRel()
    for target in (rel.GetTargets() if rel else []):
        p = prim.GetStage().GetPrimAtPath(target)
        if not p or not p.IsA(UsdShade.Material):
            what = "does not exist" if not p else f"is a {p.GetTypeName() or 'typeless prim'}"
            warnings.append(f"{prim.GetPath()}: its material binding {target} {what}; "
                            f"using the default material")


PASS_INDEX = "lantern:passIndex"


def pass_index(prim) -> int:
    """The render-pass index (IndexOB) of a Mesh prim: `lantern:passIndex` on it or on
    the nearest ancestor that has one (the object's Xform), else 0."""
    while prim and not prim.IsPseudoRoot():
        attr = prim.GetAttribute(PASS_INDEX)
        if attr and attr.HasAuthoredValue():
            return int(attr.Get())
        prim = prim.GetParent()
    return 0


def _strongest_spec(attr):
    stack = attr.GetPropertyStack(Usd.TimeCode.Default())
    if stack:
        return (stack[0].layer.identifier, str(stack[0].path))
    return ("", str(attr.GetPath()))


_NOT_GEOMETRY = ("xformOp", "visibility", "purpose", "proxyPrim", "material:", "skel:",
                 "primvars:skel:")


def _mesh_attributes_vary(prim) -> bool:
    """Points, normals, primvars or topology with time samples: the mesh is rebuilt at
    every new time (and never shared)."""
    return any(a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()
               if not a.GetName().startswith(_NOT_GEOMETRY))


ANIMATION_VALUES = ("translations", "rotations", "scales", "blendShapeWeights")


def _is_animation(prim) -> bool:
    from pxr import UsdSkel
    return prim.IsA(UsdSkel.Animation)


def _is_skel(prim) -> bool:
    from pxr import UsdSkel
    return prim.IsA(UsdSkel.Root) or prim.IsA(UsdSkel.Skeleton) or \
        prim.IsA(UsdSkel.Animation) or prim.IsA(UsdSkel.BlendShape)


def _enclosing_material(prim):
    while prim and not prim.IsPseudoRoot():
        if prim.IsA(UsdShade.Material):
            return str(prim.GetPath())
        prim = prim.GetParent()
    return None


def _map_prototypes(stage, paths) -> set:
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


def _traversal_order(stage, paths: set) -> dict:
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
