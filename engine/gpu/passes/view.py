"""The view pass (no drawing): this frame's world box of every object (skinned ones
as posed this frame), the camera, and its frustum. Culling, shadow fitting and the
default view all use these boxes.

The camera is the session's (the stage's or an explicit view), or, without one, the
default view (engine/view.py) framing what is drawn at this time: boxes of the
meshes' vertices placed by their world matrices, skinned meshes measured on the
skinned vertices themselves, so a rig and its baked twin frame alike.

reads: skinned (posed boxes, optional)   writes: view"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...view import boxes_outside, default_camera, frustum_planes
from ..framegraph import Pass


@dataclass
class View:
    camera: object
    view_proj: np.ndarray
    inv_view_proj: np.ndarray
    planes: np.ndarray
    boxes: tuple                   # (draws, lo, hi): every object's world box, posed
    bounds: tuple | None           # (lo, hi) of everything drawn, world

    def outside(self, lo, hi) -> np.ndarray:
        return boxes_outside(self.planes, lo, hi)


class ViewPass(Pass):
    name = "view"
    reads = ("skinned",)
    writes = ("view",)

    def __init__(self, geometry):
        self.geometry = geometry

    def execute(self, frame, board):
        posed = board.get("skinned")
        local_of = (lambda d: posed.boxes.get(d.path, d.local)) if posed else None
        boxes = self.geometry.world_boxes(local_of)
        _, lo, hi = boxes
        bounds = (lo.min(axis=0), hi.max(axis=0)) if len(lo) else None
        camera = frame.camera
        if camera is None:
            w, h = frame.size
            camera = default_camera(self._drawn_bounds(posed), frame.scene.up_axis, w / h)
        view_proj = camera.proj @ camera.view
        board["view"] = View(camera, view_proj, np.linalg.inv(view_proj),
                             frustum_planes(view_proj), boxes, bounds)

    def _drawn_bounds(self, posed):
        """The world box of what is drawn, skinned meshes by their skinned vertices."""
        local_of = (lambda d: posed.exact_box(d) if d.skinned else d.local) if posed else None
        _, lo, hi = self.geometry.world_boxes(local_of)
        return (lo.min(axis=0), hi.max(axis=0)) if len(lo) else None
