"""Change tracking: edits to a stage, collected between renders through
Usd.Notice.ObjectsChanged (the notice Hydra and usdview listen to), and what each edit
asks the stage reader to read again.

ChangeTracker collects resynced paths (prims added, removed or recomposed, properties
created or removed) and info-only paths (values changed); notices arrive on the thread
that edits the stage, and `take` hands them to the reader. EditTracking sorts them: a
transform edit re-reads the world matrices under that prim, a mesh edit that mesh, a
material edit that material (and the meshes whose layout depends on it), a light edit
that light, a resync that subtree."""
from __future__ import annotations

import threading

import numpy as np
from pxr import Tf, Usd, UsdGeom, UsdShade

from ..scene import Changes
from .camera import is_camera
from .gprims import is_curves, kind_of
from .lights import is_light
from .paths import map_prototypes, under
from .read import PASS_INDEX
from .skel import blend_weights
from .skel import pose as skeleton_pose


class ChangeTracker:
    def __init__(self, stage: Usd.Stage):
        self._lock = threading.Lock()
        self._resynced: set = set()
        self._changed: set = set()
        self._listener = Tf.Notice.Register(Usd.Notice.ObjectsChanged, self._on_change, stage)

    def _on_change(self, notice, stage):
        resynced = notice.GetResyncedPaths()
        changed = notice.GetChangedInfoOnlyPaths()
        with self._lock:
            self._resynced.update(str(p) for p in resynced)
            self._changed.update(str(p) for p in changed)

    def take(self):
        """(resynced, changed) path strings since the last take."""
        with self._lock:
            out = self._resynced, self._changed
            self._resynced, self._changed = set(), set()
        return out

    def close(self):
        if self._listener is not None:
            self._listener.Revoke()
            self._listener = None


ANIMATION_VALUES = ("translations", "rotations", "scales", "blendShapeWeights")


def is_animation(prim) -> bool:
    from pxr import UsdSkel
    return prim.IsA(UsdSkel.Animation)


def is_skel(prim) -> bool:
    from pxr import UsdSkel
    return prim.IsA(UsdSkel.Root) or prim.IsA(UsdSkel.Skeleton) or \
        prim.IsA(UsdSkel.Animation) or prim.IsA(UsdSkel.BlendShape)


def enclosing_material(prim):
    while prim and not prim.IsPseudoRoot():
        if prim.IsA(UsdShade.Material):
            return str(prim.GetPath())
        prim = prim.GetParent()
    return None



class EditTracking:
    """StageReader's edit job: the tracker's paths turned into re-reads (state:
    stage.py)."""

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
        roots = map_prototypes(self.stage, roots)
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
        for path in map_prototypes(self.stage, {prim_path}):
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
            elif is_light(prim):
                out.append(("light", path))
            elif is_camera(prim):
                out.append(("camera", path))
            elif name in ANIMATION_VALUES and is_animation(prim):
                out.append(("pose", path))           # values only: pose again, no resync
            elif name.startswith(("skel:", "primvars:skel:")) or is_skel(prim):
                roots.add(self.skel.root_of(path) or path)
            elif is_curves(prim) or kind_of(prim) == "points":
                roots.add(path)              # curves: normals authored or not change the kind
            elif kind_of(prim) == "mesh":
                out.append(("mesh", path))
            elif prim.IsA(UsdGeom.Subset) and prim.GetParent().IsA(UsdGeom.Mesh):
                out.append(("mesh", str(prim.GetParent().GetPath())))
            else:
                material = enclosing_material(prim)
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
            self.scene.skeletons[key] = skeleton_pose(s.query, self._t, s.dqs)
            self._read.add(key)
            changes.skeletons.add(key)
            for inst_path in s.users:
                mesh = self.scene.meshes.get(self.scene.instances[inst_path].mesh_key)
                if mesh is not None and mesh.skin is not None and \
                        mesh.skin.shape_offsets is not None:
                    skel_query, sq = self.skel.get(inst_path)
                    prim = self.stage.GetPrimAtPath(inst_path)
                    self.scene.instances[inst_path].shapes = blend_weights(
                        skel_query, sq, self._shape_queries, prim, self._t)
                    changes.shapes.add(inst_path)

    def _edit_material(self, name: str, changes: Changes):
        if name in self.scene.materials:
            self._reread_material(name, changes)
