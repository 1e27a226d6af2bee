"""The overlay options' vocabulary, with no numpy or GL: anchors, text paths and the
burn-in template's fields, checked and expanded (so the command line can build its
parser and reject a bad template without loading the engine)."""
from __future__ import annotations

import datetime
import string

ANCHORS = ("top-left", "top", "top-right", "bottom-left", "bottom", "bottom-right")
TEXT_MODES = ("auto", "sdf", "bitmap")


class OverlayError(ValueError):
    """A burn-in template or overlay placement that cannot be drawn."""


BURN_IN_FIELDS = {
    "scene": "the scene file's name without its folder and extension",
    "camera": "the camera prim's name (its last path element)",
    "frame": "the frame number (an integer for whole frames): {frame:04d} pads it",
    "date": "today's date, YYYY-MM-DD (local time)",
    "time": "the time the frame was written, HH:MM:SS (local time)",
    "preset": "the quality preset (low, medium, high, ultra)",
}


def check_template(template: str) -> None:
    """Raises OverlayError for an unknown field or a format the field's value rejects."""
    try:
        fields = [f for _, f, _, _ in string.Formatter().parse(template) if f is not None]
    except ValueError as error:
        raise OverlayError(f"--burn-in {template!r}: {error}")
    for name in fields:
        if name not in BURN_IN_FIELDS:
            raise OverlayError(f"--burn-in {template!r}: unknown field {{{name}}}; known: "
                               + ", ".join("{" + f + "}" for f in BURN_IN_FIELDS))
    try:
        expand(template, dict(scene="s", camera="c", frame=1, preset="medium"))
    except (ValueError, TypeError, IndexError, KeyError) as error:
        raise OverlayError(f"--burn-in {template!r}: {error}")


def expand(template: str, values: dict) -> str:
    now = datetime.datetime.now()
    frame = values.get("frame")
    if isinstance(frame, float) and frame.is_integer():
        frame = int(frame)
    return template.format(**{**dict(date=now.strftime("%Y-%m-%d"),
                                     time=now.strftime("%H:%M:%S")),
                              **values, "frame": frame if frame is not None else 0})


def halo_width(size: float) -> float:
    """The SDF outline's width in pixels: one pixel, growing with the size (the layout
    leaves room for it, the text shader draws it)."""
    return max(1.0, size / 16.0)
