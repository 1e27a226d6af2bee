"""The viewport in Rendered shading: a live scene in the engine host, views asked for,
the latest frame drawn. Everything but the `gpu` drawing (render_engine.py) is here,
with the view maths as functions of plain matrices, so tests drive it all without a
window.

- view_update: the depsgraph's updates become stage edits (addon/live.py).
- view_draw: the region's view becomes a render request when it changed; the host
  renders it progressively (the interactive preset while the view moves, the scene's
  preset once it has been still SETTLE_SECONDS); the latest frame that arrived is
  drawn. Nothing waits: a redraw timer tags the region when a new frame arrives.
  (engine/host/protocol.py: the interactive preset is `low`, at half resolution past
  320x180 pixels, drawn stretched.)
- Views: perspective, orthographic and the camera view, as the region's view and
  window matrices say (Blender's camera zoom and offset are in them). A render border
  (the camera's border in camera view, or the viewport's render region otherwise)
  renders only that rectangle: its projection is the window matrix narrowed to it.
  The resolution scale renders fewer pixels, drawn stretched over the same rectangle.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from . import host as host_module
from .live import LiveScene

_names = itertools.count(1)


@dataclass
class ViewRequest:
    view: np.ndarray            # world -> view, OpenGL, column vectors
    projection: np.ndarray      # for the rectangle drawn (the window matrix, narrowed)
    size: tuple                 # (width, height) rendered pixels
    rect: tuple                 # (x, y, width, height) region pixels it is drawn over

    @property
    def key(self) -> tuple:
        return (self.view.tobytes(), self.projection.tobytes(), self.size, self.rect)


def narrowed(projection, fractions) -> np.ndarray:
    """The projection that shows only `fractions` (x0, y0, x1, y1 of the region, y up)
    of what `projection` shows, filling the whole image with it."""
    x0, y0, x1, y1 = (2.0 * np.asarray(fractions, np.float64) - 1.0)
    crop = np.array([[2 / (x1 - x0), 0, 0, -(x1 + x0) / (x1 - x0)],
                     [0, 2 / (y1 - y0), 0, -(y1 + y0) / (y1 - y0)],
                     [0, 0, 1, 0], [0, 0, 0, 1]])
    return crop @ np.asarray(projection, np.float64)


def camera_frame(window_matrix, camera_projection) -> tuple:
    """The camera's frame in the camera view, as fractions (x0, y0, x1, y1) of the
    region: the camera projection's image corners, seen through the viewport's
    window matrix (which holds Blender's camera zoom and offset). This is what
    Blender's view3d camera border computes."""
    corners = np.array([[x, y, 0.0, 1.0] for x in (-1, 1) for y in (-1, 1)])
    in_view = corners @ np.linalg.inv(np.asarray(camera_projection, np.float64)).T
    clip = in_view @ np.asarray(window_matrix, np.float64).T
    ndc = clip[:, :2] / clip[:, 3:4]
    lo, hi = (ndc.min(axis=0) + 1) / 2, (ndc.max(axis=0) + 1) / 2
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def border_in_frame(frame, border) -> tuple:
    """A render border (fractions of the camera frame) as fractions of the region."""
    fx0, fy0, fx1, fy1 = frame
    bx0, by0, bx1, by1 = border
    return (fx0 + bx0 * (fx1 - fx0), fy0 + by0 * (fy1 - fy0),
            fx0 + bx1 * (fx1 - fx0), fy0 + by1 * (fy1 - fy0))


def view_request(region_size, view_matrix, window_matrix, scale=1.0, border=None):
    """What to render for a region: `border` (fractions of the region, or None for
    all of it) narrowed to whole pixels, at `scale` times the pixels it covers."""
    width, height = (int(s) for s in region_size)
    x0, y0, x1, y1 = 0, 0, width, height
    if border is not None:
        bx0, by0, bx1, by1 = (min(max(b, 0.0), 1.0) for b in border)
        x0, y0 = int(np.floor(bx0 * width)), int(np.floor(by0 * height))
        x1, y1 = int(np.ceil(bx1 * width)), int(np.ceil(by1 * height))
        if x1 <= x0 or y1 <= y0:
            return None
    projection = np.asarray(window_matrix, np.float64)
    if (x0, y0, x1, y1) != (0, 0, width, height):
        projection = narrowed(projection, (x0 / width, y0 / height, x1 / width, y1 / height))
    size = (max(1, round((x1 - x0) * scale)), max(1, round((y1 - y0) * scale)))
    return ViewRequest(np.asarray(view_matrix, np.float64), projection, size,
                       (x0, y0, x1 - x0, y1 - y0))


def region_border(context, depsgraph):
    """The border to render, as fractions of the region, or None: the scene's render
    border in the camera view, the viewport's render region elsewhere."""
    rv3d, space, scene = context.region_data, context.space_data, depsgraph.scene
    render = scene.render
    if rv3d.view_perspective == 'CAMERA':
        if not render.use_border or scene.camera is None:
            return None
        camera = scene.camera.evaluated_get(depsgraph)
        projection = camera.calc_matrix_camera(
            depsgraph, x=render.resolution_x, y=render.resolution_y,
            scale_x=render.pixel_aspect_x, scale_y=render.pixel_aspect_y)
        return border_in_frame(camera_frame(rv3d.window_matrix, projection),
                               (render.border_min_x, render.border_min_y,
                                render.border_max_x, render.border_max_y))
    if getattr(space, "use_render_border", False):
        return (space.render_border_min_x, space.render_border_min_y,
                space.render_border_max_x, space.render_border_max_y)
    return None


class ViewportRender:
    """One viewport's scene in the engine host, its view and its frames."""

    def __init__(self):
        self.name = f"viewport:{next(_names)}"
        self.live = None
        self.generation = None
        self.asked = None           # the last request's key
        self.status = ""            # what the viewport's header says
        self.notices = []           # errors to report once (RenderEngine.report)

    @property
    def host(self):
        return host_module.get()

    def update(self, depsgraph) -> bool:
        """view_update: the depsgraph's edits to the host. False when the engine
        process cannot run now (self.status says why)."""
        host = self.host
        if not host.ensure():
            self.status = f"Lantern: {host.why()}"
            return False
        if self.live is None or self.generation != host.generation:
            if self.live is not None:
                self.live.close()
            self.live, self.generation, self.asked = LiveScene(), host.generation, None
        fragment = self.live.sync(depsgraph)
        if fragment is not None:
            host.edit(self.name, fragment)
        return True

    def draw(self, depsgraph, view, paint, preset, transparent=False):
        """view_draw without the `gpu` call: asks for `view` (a ViewRequest, or None:
        nothing to render) when it changed, then calls
        paint(frame number, float32 (H, W, 4) bottom-up pixels, (x, y, w, h)) with the
        latest frame, inside the host's lock (the pixels are its shared memory)."""
        host = self.host
        try:
            if self.generation != host.generation or not host.running():
                failure = host.why() if self.generation == host.generation else host.failure
                if failure is not None:
                    self.notices.append(f"Lantern: {failure}; it starts again")
                if not self.update(depsgraph):
                    return
            if view is not None:
                self._draw(view, paint, preset, transparent)
        except host_module.HostError as error:
            self.status = f"Lantern: {error}"
            self.notices.append(self.status)

    def _draw(self, view, paint, preset, transparent):
        host = self.host
        key = (view.key, preset, bool(transparent))
        if key != self.asked:
            host.render(self.name, width=view.size[0], height=view.size[1], preset=preset,
                        transparent=transparent, view=view.view, projection=view.projection,
                        progressive=True, tag=view.rect)
            self.asked = key
        channel = host.channel(self.name)
        if channel.error is not None:
            self.status = f"Lantern: {channel.error[1]}"
        with host.frame(self.name) as shown:
            if shown is not None:
                frame, views = shown
                paint(frame.number, views["Combined"], frame.tag)
                self.shown = frame
                if channel.error is None:
                    self.status = "" if frame.final else "Lantern: refining"

    shown = None        # the latest frame drawn (addon/viewport_stats.py reads it)

    def waiting(self) -> bool:
        """Whether a frame is still to come (the redraw timer keeps polling)."""
        host = self.host
        channel = host.channels.get(self.name)
        if channel is None or not host.running() or channel.error is not None:
            return False
        latest = channel.latest
        return latest is None or latest.request != channel.requested or not latest.final

    def close(self):
        if self.live is not None:
            self.live.close()
        if self.generation == self.host.generation:
            self.host.drop(self.name)
