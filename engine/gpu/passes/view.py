"""The view pass (no drawing): this frame's world box of every object (skinned ones
as posed this frame), the camera, its frustum, and its matrices in the depth
convention (engine/view.py: camera-relative positions, reversed float depth).

The camera is the session's (the stage's or an explicit view), or, without one, the
default view (engine/view.py) framing what is drawn at this time: boxes of the
meshes' vertices placed by their world matrices, skinned meshes measured on the
skinned vertices themselves, so a rig and its baked twin frame alike.

reads: skinned (posed boxes, optional)   writes: view"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...view import (boxes_outside, default_camera, frustum_planes, relative_view,
                     render_projection, split_double, window_matrix)
from ..framegraph import Pass
from ..programs import set_uniform


@dataclass
class View:
    camera: object
    origin: np.ndarray             # the eye, world, float64: what positions are relative to
    view_proj: np.ndarray          # camera-relative -> clip, reversed depth (what draws use)
    window: np.ndarray             # camera-relative -> (x, y in [0, 1], window depth, w)
    inv_view_proj: np.ndarray      # (x, y in [0, 1], window depth) -> camera-relative
    cull_view_proj: np.ndarray     # camera-relative -> clip with the camera's finite far
    planes: np.ndarray             # frustum planes of cull_view_proj, camera-relative
    boxes: tuple                   # (draws, lo, hi): every object's world box, posed
    bounds: tuple | None           # (lo, hi) of everything drawn, world

    def outside(self, lo, hi) -> np.ndarray:
        """Culled mask of world boxes (n, 3)."""
        return boxes_outside(self.planes, lo - self.origin, hi - self.origin)

    @property
    def far_clip(self) -> float:
        """Clip distance 0's plane: the camera's far plane (an orthographic
        projection clips at it already)."""
        return 1e30 if self.camera.ortho else float(self.camera.far)

    def set_origin(self, prog):
        """Positions relative to the eye (shaders/origin.glsl)."""
        set_origin(prog, self.origin)

    def set_camera(self, prog):
        """What a screen-space pass needs to rebuild positions from depth."""
        cam = self.camera
        set_uniform(prog, "inv_view_proj", self.inv_view_proj)
        set_uniform(prog, "cam_forward", cam.forward)
        set_uniform(prog, "cam_ortho", bool(cam.ortho))
        self.set_origin(prog)


def set_origin(prog, origin):
    hi, lo = split_double(origin)
    set_uniform(prog, "u_origin_hi", hi.astype(np.float64))
    set_uniform(prog, "u_origin_lo", lo.astype(np.float64))


def make_view(camera, zero_to_one, boxes=None, bounds=None) -> View:
    rel = relative_view(camera)
    cull = np.array(camera.proj, np.float64) @ rel
    window = window_matrix(camera)
    return View(camera, np.array(camera.position, np.float64),
                render_projection(camera, zero_to_one) @ rel, window,
                np.linalg.inv(window), cull, frustum_planes(cull), boxes, bounds)


class ViewPass(Pass):
    name = "view"
    reads = ("skinned",)
    writes = ("view",)

    def __init__(self, geometry, depth):
        self.geometry, self.depth = geometry, depth

    def execute(self, frame, board):
        posed = board.get("skinned")
        local_of = (lambda d: posed.boxes.get(d.path, d.local)) if posed else None
        boxes = self.geometry.world_boxes(local_of)
        bounds = _union(boxes, self.geometry.points.boxes())
        camera = frame.camera
        if camera is None:
            w, h = frame.size
            camera = default_camera(self._drawn_bounds(posed), frame.scene.up_axis, w / h)
        board["view"] = make_view(camera, self.depth.zero_to_one, boxes, bounds)

    def _drawn_bounds(self, posed):
        """The world box of what is drawn, skinned meshes by their skinned vertices."""
        local_of = (lambda d: posed.exact_box(d) if d.skinned else d.local) if posed else None
        return _union(self.geometry.world_boxes(local_of), self.geometry.points.boxes())


def _union(boxes, clouds):
    """(lo, hi) of the objects' world boxes and the point clouds', or None."""
    _, lo, hi = boxes
    lo = list(lo) + [c[1] for c in clouds]
    hi = list(hi) + [c[2] for c in clouds]
    return (np.min(lo, axis=0), np.max(hi, axis=0)) if lo else None
