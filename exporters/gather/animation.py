"""Samples the frame range: object transforms, armature poses, shape key values, and
the evaluated points of meshes UsdSkel cannot deform exactly (baked).

Every frame is evaluated by Blender (`frame_set`), so constraints, IK and drivers are
baked into what is written; nothing re-implements them.
"""
from contextlib import contextmanager

import numpy as np

from ..errors import require_finite
from ..ir import PointSamples, SkinRecord
from .shapes import gather_blend_shapes, shape_weights
from .mesh import _get
from .skeleton import (HALF_TOLERANCE, SHEAR_TOLERANCE, TRS_TOLERANCE, bone_scale_error,
                       decompose, gather_skeleton, local_matrices, pose_index,
                       pose_matrices, recompose, relative_matrix, shape_host)
from .skin import skin_weights

# Matrices that move less than this (relative to their size) over the range are static.
STATIC_TOLERANCE = 1e-6
# Blender's DQS treats bone scale apart from rotation, differently from UsdSkel.
DQS_SCALE_TOLERANCE = 1e-5


@contextmanager
def modifiers_disabled(modifiers, depsgraph):
    """Switches the given modifiers off for the block (for the depsgraph's mode: viewport
    or render), then restores them."""
    flag = "show_render" if depsgraph.mode == "RENDER" else "show_viewport"
    modifiers = [m for m in modifiers if getattr(m, flag)]
    for m in modifiers:
        setattr(m, flag, False)
    if modifiers:
        depsgraph.update()
    try:
        yield
    finally:
        for m in modifiers:
            setattr(m, flag, True)
        if modifiers:
            depsgraph.update()


def evaluated_at(scene, times):
    """Yields each time with the scene evaluated there, and restores the frame. The
    current frame alone is read as it is: no frame change (none may happen inside a
    depsgraph update, where the live viewport exports)."""
    if list(times) == [scene.frame_current] and scene.frame_subframe == 0:
        yield times[0]
        return
    frame, subframe = scene.frame_current, scene.frame_subframe
    try:
        for f in times:
            scene.frame_set(f)
            yield f
    finally:
        scene.frame_set(frame, subframe=subframe)


def _relative_error(a, b):
    scale = max(1.0, float(np.abs(b).max(initial=0.0)))
    return float(np.abs(a - b).max(initial=0.0)) / scale


class Sampler:
    """Holds what gather_scene found, samples the range, and fills the SceneRecord."""

    def __init__(self, depsgraph, rec, originals, rigs, warn):
        self.depsgraph, self.rec, self.warn = depsgraph, rec, warn
        self.originals = originals            # object key -> original object
        self.rigs = rigs                      # mesh object key -> MeshRig
        self.objects = {o.key: o for o in rec.objects}
        self.armatures = sorted(k for k, ob in originals.items() if ob.type == "ARMATURE")

    # -- static part, at the export's frame ---------------------------------------------
    def build_skeletons(self):
        for key in self.armatures:
            ob = self.originals[key]
            world = self._world(key)
            self.rec.skeletons[key] = gather_skeleton(ob, key, world)
            self.objects[key].rig = key
        for key, rig in sorted(self.rigs.items()):
            if rig.reason is None and rig.armature is None:
                obj = self.objects[key]
                self.rec.skeletons[key] = shape_host(key, "Skeleton", self._world(key))
                obj.rig = key

    def _world(self, key):
        return np.array(self.originals[key].evaluated_get(self.depsgraph).matrix_world,
                        dtype=np.float64)

    def build_skins(self, group_entries):
        """Skin records for the meshes still expressible; group_entries: key -> the rest
        mesh's vertex group assignments (see skin.group_entries)."""
        for key, rig in sorted(self.rigs.items()):
            obj = self.objects.get(key)
            if rig.reason is not None or obj is None or obj.mesh is None:
                continue
            mesh = self.rec.meshes[obj.mesh]
            rig_key = rig.armature.name_full if rig.armature is not None else key
            skel = self.rec.skeletons[rig_key]
            n = len(mesh.points)
            if rig.armature is not None:
                deform = {b.name for b in rig.armature.data.bones if b.use_deform}
                joint_of = {name: j for j, name in enumerate(skel.joint_names) if name in deform}
                indices, weights = skin_weights(self.originals[key], group_entries[key], n,
                                                joint_of, len(skel.joint_names))
                require_finite(weights, f"object '{obj.name}'", "vertex group weights")
                geom_bind = self._world(key)
            else:
                indices = np.zeros((n, 1), dtype=np.int32)
                weights = np.ones((n, 1), dtype=np.float32)
                geom_bind = skel.static_world
            skin = SkinRecord(rig=rig_key, joint_indices=indices, joint_weights=weights,
                              geom_bind=geom_bind, object=key,
                              dual_quaternion=bool(rig.modifier is not None
                                                   and rig.modifier.use_deform_preserve_volume))
            if rig.shape_keys:
                for block in self.originals[key].data.shape_keys.key_blocks:
                    require_finite(_get(block.data, "co", np.float32, 3),
                                   f"object '{obj.name}'", f"shape key '{block.name}'")
                skin.blend_shapes = gather_blend_shapes(self.originals[key])
            mesh.skin = skin

    # -- sampling ---------------------------------------------------------------------
    def sample(self, times):
        scene = self.depsgraph.scene
        keys = [o.key for o in self.rec.objects]
        skinned = [k for k in sorted(self.rigs) if self._skin(k) is not None]
        order = {k: pose_index(self.originals[k], self.rec.skeletons[k].joint_names)
                 for k in self.armatures}
        worlds = np.empty((len(times), len(keys), 4, 4))
        poses = {k: [] for k in self.armatures}
        weights = {k: [] for k in skinned if self._skin(k).blend_shapes}
        names = {k: [s.name for s in self._skin(k).blend_shapes] for k in weights}
        for t, _ in enumerate(evaluated_at(scene, times)):
            for i, k in enumerate(keys):
                worlds[t, i] = self.originals[k].evaluated_get(self.depsgraph).matrix_world
            for k in self.armatures:
                ev = self.originals[k].evaluated_get(self.depsgraph)
                poses[k].append(pose_matrices(ev, order[k]))
            for k in weights:
                ev = self.originals[k].evaluated_get(self.depsgraph)
                weights[k].append(shape_weights(ev, names[k]))
        for i, k in enumerate(keys):
            require_finite(worlds[:, i], f"object '{self.objects[k].name}'", "animated transform")
        for k, v in poses.items():
            require_finite(v, f"armature '{self.objects[k].name}'", "bone poses")
        for k, v in weights.items():
            require_finite(v, f"object '{self.objects[k].name}'", "shape key values")
        self.times = list(times)
        self.worlds = {k: worlds[:, i] for i, k in enumerate(keys)}
        self.poses = {k: np.array(v) for k, v in poses.items()}
        self.weights = {k: np.array(v, dtype=np.float64).reshape(len(times), -1)
                        for k, v in weights.items()}

    def _skin(self, key):
        obj = self.objects.get(key)
        return self.rec.meshes[obj.mesh].skin if obj is not None and obj.mesh else None

    # -- what the samples mean -----------------------------------------------------------
    def write_transforms(self):
        for obj in self.rec.objects:
            world = self.worlds[obj.key]
            if obj.parent is not None:
                local = relative_matrix(self.worlds[obj.parent], world)
            else:
                local = world
            if _relative_error(local, local[:1]) > STATIC_TOLERANCE:
                obj.matrix_samples = local

    def write_skeletons(self):
        for key in self.armatures:
            skel = self.rec.skeletons[key]
            poses = self.poses[key]
            t, q, s, shear, half = decompose(local_matrices(poses, skel.parents))
            self._warn_degenerate(key, skel, s)
            reason = None
            if _composed_error(t, q, s, poses, skel.parents) > TRS_TOLERANCE:
                reason = "a bone with zero scale has children that do not collapse with it"
            elif shear > SHEAR_TOLERANCE:
                reason = "sheared bone transforms (Inherit Scale under non-uniform scale)"
            elif half > HALF_TOLERANCE:
                reason = "bone scales that half precision (SkelAnimation scales) rounds"
            self._channels(skel, t, q, s)
            deform = np.array([self.originals[key].data.bones[n].use_deform
                               for n in skel.joint_names], dtype=bool)
            scaled = bone_scale_error(poses, skel.rest_armature, deform) > DQS_SCALE_TOLERANCE
            for mkey in sorted(self.rigs):
                skin = self._skin(mkey)
                if skin is None or skin.rig != key:
                    continue
                if reason is None and skin.dual_quaternion and scaled:
                    self._fall_back(mkey, "Preserve Volume with scaled bones")
                elif reason is not None:
                    self._fall_back(mkey, reason)
        for mkey in sorted(self.rigs):
            skin = self._skin(mkey)
            if skin is not None and self.objects[mkey].matrix_samples is not None \
                    and skin.rig != mkey:
                self._fall_back(mkey, "the mesh moves relative to its armature")
        self._static_joints()
        self._blend_weights()

    def _warn_degenerate(self, key, skel, scales):
        """One warning per bone that reaches a zero scale on some axis."""
        zero = (scales == 0).any(axis=2)
        for j in np.flatnonzero(zero.any(axis=0)):
            frames = [self.times[f] for f in np.flatnonzero(zero[:, j])]
            span = f"frame {frames[0]}" if len(frames) == 1 else \
                f"{len(frames)} frames from {frames[0]} to {frames[-1]}"
            self.warn(f"armature '{self.objects[key].name}': bone '{skel.joint_names[j]}' "
                      f"has zero scale ({span}); its joint is written with scale 0 and "
                      "an identity rotation about the collapsed axes")

    def _channels(self, skel, t, q, s):
        skel.times = self.times
        for name, values in (("translations", t), ("rotations", q), ("scales", s)):
            if _relative_error(values, values[:1]) <= 1e-7:
                values = values[:1]
            setattr(skel, name, values)

    def _static_joints(self):
        """Adds the never-moving joint to rigs whose meshes have undeformed vertices."""
        for key, skel in self.rec.skeletons.items():
            users = [self._skin(k) for k in sorted(self.rigs) if self._skin(k) is not None
                     and self._skin(k).rig == key]
            needed = skel.static_world is not None or any(
                (u.joint_indices == len(skel.joint_names)).any() for u in users)
            if needed and skel.static_world is None:
                skel.static_world = self._world(key)
            if skel.static_world is not None and not skel.times:
                skel.times = self.times

    def _blend_weights(self):
        for key, skel in self.rec.skeletons.items():
            columns = []
            for mkey in sorted(self.rigs):
                skin = self._skin(mkey)
                if skin is None or skin.rig != key or not skin.blend_shapes:
                    continue
                for i, shape in enumerate(skin.blend_shapes):
                    skel.blend_shapes.append((mkey, shape.name))
                    columns.append(self.weights[mkey][:, i])
            if columns:
                w = np.stack(columns, axis=1)
                skel.blend_weights = w[:1] if _relative_error(w, w[:1]) <= 1e-7 else w
                skel.times = self.times

    def _fall_back(self, key, reason):
        rig = self.rigs[key]
        if rig.reason is None:
            rig.reason = reason
            self.rec.meshes[self.objects[key].mesh].skin = None

    # -- baking -------------------------------------------------------------------------
    def bake(self, times):
        """Evaluated points per frame for every mesh that has a reason; modifiers on."""
        baked = [k for k in sorted(self.rigs) if self.rigs[k].reason is not None
                 and k in self.objects and self.objects[k].mesh is not None]
        for k in baked:
            self.warn(f"object '{self.objects[k].name}': deformation baked to points per "
                      f"frame ({self.rigs[k].reason})")
        if not baked:
            return
        scene = self.depsgraph.scene
        samples = {k: PointSamples(times=list(times), points=[], normals=[]) for k in baked}
        for _ in evaluated_at(scene, times):
            for k in baked:
                ev = self.originals[k].evaluated_get(self.depsgraph)
                mesh = ev.to_mesh()
                try:
                    _append_points(samples[k], mesh, self.rec.meshes[self.objects[k].mesh],
                                   f"object '{self.objects[k].name}'")
                finally:
                    ev.to_mesh_clear()
        for k in baked:
            rec = self.rec.meshes[self.objects[k].mesh]
            if len(samples[k].points) == len(times):
                rec.point_samples = samples[k]
            else:
                self.warn(f"object '{self.objects[k].name}': its topology changes over the "
                          f"frame range; only the current frame is written")


def _composed_error(t, q, s, poses, parents):
    """Largest difference (relative to the pose's size) between the armature-space poses
    and the channels composed parent by parent, as UsdSkel composes them; only where a
    parent is singular can they differ (a child that does not collapse with it)."""
    if not (s == 0).any():
        return 0.0
    local = recompose(t, q, s)
    composed = np.empty_like(local)
    for j, p in enumerate(parents):
        composed[:, j] = local[:, j] if p < 0 else composed[:, p] @ local[:, j]
    size = np.maximum(np.abs(poses).max(), 1.0)
    return float(np.abs(composed - poses).max()) / size


def _append_points(samples, mesh, rec, owner):
    points = _get(mesh.vertices, "co", np.float32, 3)
    if len(points) != len(rec.points) or len(mesh.loops) != len(rec.face_indices):
        return
    if rec.normals_interpolation == "vertex":
        normals = _get(mesh.vertex_normals, "vector", np.float32, 3)
    else:
        normals = _get(mesh.corner_normals, "vector", np.float32, 3)
    require_finite(points, owner, "animated vertex positions")
    samples.points.append(points)
    samples.normals.append(normals)

