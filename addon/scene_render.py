"""Depsgraph to pixels, shared by F12 and the viewport (no `gpu` here, so it is testable).

The depsgraph is exported into an in-memory USD stage, the same stage a file export
writes, so F12 and `lantern render` on the exported file give the same pixels.
"""
import numpy as np

from ..engine import RenderSettings, render_stage
from ..exporters import stage_from_depsgraph


def _settings(scene, width, height, **extra):
    return RenderSettings(width=width, height=height, frame=float(scene.frame_current),
                          preset=scene.lantern.preset, **extra)


def render_final(depsgraph, width, height):
    """F12: returns (rgba float32 (H, W, 4) scene linear, top row first; warnings)."""
    stage, report = stage_from_depsgraph(depsgraph)
    result = render_stage(stage, _settings(depsgraph.scene, width, height))
    return result.rgba, report.warnings + result.warnings


class ViewportSession:
    """Holds the exported stage between redraws.

    A redraw that only moves the view re-renders the stage it has; the scene is
    exported again only when the depsgraph reports changed data.
    """

    def __init__(self):
        self.stage = None
        self.scene = None
        self.exports = 0

    def sync(self, depsgraph):
        changed = any(update.is_updated_geometry or update.is_updated_shading
                      or update.is_updated_transform for update in depsgraph.updates)
        if self.stage is None or changed:
            self.stage, _ = stage_from_depsgraph(depsgraph)
            self.exports += 1
        self.scene = depsgraph.scene

    def draw_pixels(self, view_matrix, window_matrix, width, height):
        """Renders the held stage from the viewport's view, at the region's size."""
        settings = _settings(self.scene, width, height,
                             view_matrix=np.array(view_matrix, dtype=np.float64),
                             projection_matrix=np.array(window_matrix, dtype=np.float64))
        return render_stage(self.stage, settings).rgba
