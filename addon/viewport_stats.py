"""The viewport's statistics overlay: the latest frame's time, GPU time and draw calls,
drawn with Blender's own font module over the viewport (its GL context is Blender's,
which ModernGL never touches), when the Quality panel's Statistics is on."""
from __future__ import annotations

MARGIN_PX = 10
SIZE_PT = 11


def stats_line(frame) -> str:
    """One line for a host Frame (addon/host.py): size, frame time (the engine's total,
    stage read included), GPU time (the passes' GL timestamps summed; absent when the
    driver gave none) and draw calls."""
    timings, stats = frame.timings or {}, frame.stats or {}
    parts = [f"{frame.width}x{frame.height}", f"frame {timings.get('total', 0.0) * 1000:.1f} ms"]
    if frame.gpu_timings:
        parts.append(f"GPU {sum(frame.gpu_timings.values()) * 1000:.1f} ms")
    parts.append(f"{int(stats.get('draw_calls', 0))} draw calls")
    if not frame.final:
        parts.append(f"{frame.preset}, refining")
    return "Lantern  " + "  ".join(parts)


def draw_stats(frame, region_height: int, ui_scale: float = 1.0) -> None:
    """The line in the viewport's top-left corner, white with a shadow."""
    import blf
    font = 0
    blf.size(font, SIZE_PT * ui_scale)
    blf.color(font, 1.0, 1.0, 1.0, 1.0)
    blf.enable(font, blf.SHADOW)
    blf.shadow(font, 3, 0.0, 0.0, 0.0, 0.9)
    blf.shadow_offset(font, 1, -1)
    line = stats_line(frame)
    height = blf.dimensions(font, line)[1]
    blf.position(font, MARGIN_PX * ui_scale, region_height - MARGIN_PX * ui_scale - height, 0)
    blf.draw(font, line)
    blf.disable(font, blf.SHADOW)
