"""Sprites and text drawn over the display-referred image (8-bit, after the view
transform), so a colour asked for is the colour written.

Plain records (Sprite, Text), the font atlas (shaders/fonts/dejavu_sans_mono.npz,
built by shaders/fonts/make_atlas.py), text layout into glyph quads, and BurnIn (what
the command line asks for; its template's fields are engine/overlay_options.py). The drawing itself is engine/gpu/overlays.py, on the GL thread.
Order, as the pipeline draws them: sprites, then text, each in list order.

Layout puts each glyph's pen origin on a whole pixel (unhinted advances summed in
float, then rounded), so small text keeps FreeType's pixel grid and the mapped-texture
path draws FreeType's own coverage texel for pixel.
"""
from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field, replace

import numpy as np

ATLAS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "shaders",
                     "fonts", "dejavu_sans_mono.npz")
from .overlay_options import ANCHORS, TEXT_MODES, OverlayError, expand  # noqa: F401


@dataclass(frozen=True)
class Sprite:
    """An image (H, W, 4) uint8, display-referred, straight alpha, placed with its top-left
    corner at (x, y) and drawn width x height: pixels, or fractions of the target's
    width and height when `normalised`."""
    pixels: np.ndarray
    x: float
    y: float
    width: float
    height: float
    normalised: bool = False
    opacity: float = 1.0

    def rect(self, target_w: int, target_h: int) -> tuple[float, float, float, float]:
        sx, sy = (target_w, target_h) if self.normalised else (1, 1)
        return self.x * sx, self.y * sy, self.width * sx, self.height * sy


@dataclass(frozen=True)
class Text:
    """One line of text, its box's top-left at (x, y) pixels, `size` pixels per em.
    Colours are display-referred RGBA in [0, 1]; the halo is the SDF outline or the
    bitmap path's 1 px shadow. mode: "sdf", "bitmap" (sizes the atlas holds, whole
    pixels) or "auto" (bitmap where it can, else sdf)."""
    text: str
    x: float
    y: float
    size: float
    color: tuple = (1.0, 1.0, 1.0, 1.0)
    halo_color: tuple = (0.0, 0.0, 0.0, 0.85)
    mode: str = "auto"


@functools.lru_cache(maxsize=1)
def font_atlas() -> dict:
    with np.load(ATLAS) as data:
        atlas = {key: data[key] for key in data.files}
    atlas["index"] = {ch: i for i, ch in enumerate(str(atlas["chars"]))}
    return atlas


def text_mode(text: Text) -> str:
    """The path a Text takes."""
    sizes = set(int(s) for s in font_atlas()["bitmap_sizes"])
    exact = float(text.size).is_integer() and int(text.size) in sizes
    if text.mode == "bitmap" and not exact:
        raise OverlayError(f"bitmap text comes in whole sizes {min(sizes)}-{max(sizes)} px, "
                           f"not {text.size:g}")
    if text.mode not in TEXT_MODES:
        raise OverlayError(f"unknown text mode {text.mode!r}; valid: {', '.join(TEXT_MODES)}")
    return "bitmap" if text.mode == "bitmap" or (text.mode == "auto" and exact) else "sdf"


def text_box(text: Text) -> tuple[int, int, int, int]:
    """(x, y, width, height) in whole pixels that holds every pixel the text may touch,
    its outline or shadow included."""
    quads = layout(text)[0]
    if len(quads) == 0:
        return int(text.x), int(text.y), 0, 0
    x0, y0 = np.floor(quads[:, :2].min(axis=0))
    x1, y1 = np.ceil(quads[:, 2:4].max(axis=0))
    return int(x0), int(y0), int(x1 - x0), int(y1 - y0)


def text_extent(text: str, size: float) -> tuple[float, float]:
    """(width, height) of a line's advance box, pixels, for anchoring."""
    atlas = font_atlas()
    width = float(np.sum([atlas["advance"][atlas["index"].get(c, 0)] for c in text])) * size
    return width, float(atlas["ascent"] + atlas["descent"]) * size


def layout(text: Text):
    """(quads (N, 8): x0, y0, x1, y1 pixels and u0, v0, u1, v1 atlas texels; the mode).
    A character the atlas lacks (outside printable ASCII) draws as '?'."""
    atlas = font_atlas()
    mode = text_mode(text)
    key = "sdf" if mode == "sdf" else f"bitmap_{int(text.size)}"
    rects, planes = atlas[f"{key}_rect"], atlas[f"{key}_plane"]
    scale = text.size if mode == "sdf" else 1.0
    baseline = _whole(text.y + float(atlas["ascent"]) * text.size)
    pen, quads = float(text.x), []
    for ch in text.text:
        i = atlas["index"].get(ch, atlas["index"]["?"])
        if ch != " ":
            ox = _whole(pen)
            left, top, right, bottom = planes[i] * scale
            x, y, w, h = rects[i]
            quads.append((ox + left, baseline + top, ox + right, baseline + bottom,
                          x, y, x + w, y + h))
        pen += float(atlas["advance"][i]) * text.size
    return np.array(quads, np.float32).reshape(-1, 8), mode


def _whole(value: float) -> int:
    """The nearest whole pixel, halves up (round() would send them to even, and a
    layout shifted by whole pixels would then round differently)."""
    return math.floor(value + 0.5)


def draw(display8: np.ndarray, sprites=(), texts=()) -> np.ndarray:
    """(H, W, 4) uint8 display-referred RGBA with the sprites, then the texts, drawn over
    it (a new array; the input is left as it is). Each overlay goes to the GPU with only
    the pixels under it, so the cost follows the overlays' area, not the image's."""
    if not sprites and not texts:
        return display8
    from .gpu.context import run_gl
    from .gpu.overlays import draw_overlays
    height, width = display8.shape[:2]
    out = display8.copy()
    atlas = font_atlas()
    for item in list(sprites) + list(texts):
        if isinstance(item, Sprite):
            x, y, w, h = item.rect(width, height)
            box = int(np.floor(x)), int(np.floor(y)), int(np.ceil(x + w)), int(np.ceil(y + h))
        else:
            x, y, w, h = text_box(item)
            box = x, y, x + w, y + h
        x0, y0 = max(box[0], 0), max(box[1], 0)
        x1, y1 = min(box[2], width), min(box[3], height)
        if x1 <= x0 or y1 <= y0:
            continue
        if isinstance(item, Sprite):
            moved = Sprite(item.pixels, x - x0, y - y0, w, h, opacity=item.opacity)
            job = ([moved], [])
        else:   # whole-pixel shifts keep the layout's rounding
            moved = replace(item, x=item.x - x0, y=item.y - y0)
            job = ([], [(layout(moved), moved)])
        crop = np.ascontiguousarray(out[y0:y1, x0:x1])
        out[y0:y1, x0:x1] = run_gl(lambda gl: draw_overlays(gl, crop, *job, atlas))
    return out


# --- burn-in ------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)     # holds an array: hashed by identity
class BurnIn:
    """The command line's overlays, picklable for farm workers: a burn-in template
    (or None), its anchor and size, and a watermark image (or None)."""
    template: str | None = None
    anchor: str = "bottom-left"
    size: float = 24.0
    mode: str = "auto"
    values: dict = field(default_factory=dict)     # scene, camera, preset
    watermark: np.ndarray | None = None
    watermark_anchor: str = "bottom-right"
    watermark_scale: float = 0.2                     # of the image's width

    def sprites(self, width: int, height: int) -> list:
        if self.watermark is None:
            return []
        h, w = self.watermark.shape[:2]
        sw = self.watermark_scale * width
        sh = sw * h / w
        x, y = _anchored(self.watermark_anchor, sw, sh, width, height, margin=0.02 * width)
        return [Sprite(self.watermark, x, y, sw, sh)]

    def texts(self, width: int, height: int, frame) -> list:
        if not self.template:
            return []
        line = expand(self.template, {**self.values, "frame": frame})
        tw, th = text_extent(line, self.size)
        x, y = _anchored(self.anchor, tw, th, width, height, margin=self.size / 2)
        return [Text(line, x, y, self.size, mode=self.mode)]

    def apply(self, display8: np.ndarray, frame=None) -> np.ndarray:
        height, width = display8.shape[:2]
        return draw(display8, self.sprites(width, height), self.texts(width, height, frame))


def _anchored(anchor, w, h, width, height, margin):
    if anchor not in ANCHORS:
        raise OverlayError(f"unknown position {anchor!r}; valid: {', '.join(ANCHORS)}")
    vertical, _, horizontal = anchor.partition("-") if "-" in anchor else (anchor, "", "")
    x = {"left": margin, "right": width - margin - w, "": (width - w) / 2}[horizontal]
    y = margin if vertical == "top" else height - margin - h
    return round(x), round(y)
