"""Builds the overlay font atlas (dejavu_sans_mono.npz) from DejaVu Sans Mono.

Run once at build time, with Pillow and SciPy (the engine only loads the .npz, with
numpy): `python shaders/fonts/make_atlas.py [font.ttf]`. The font is found in
matplotlib's bundled fonts, else in /usr/share/fonts. Its licence is LICENSE-DejaVu.txt.

The .npz holds two kinds of glyph image for printable ASCII:
- `sdf`: a signed distance field, rendered at SUPER x EM px and measured there (exact
  Euclidean distance transform), then sampled down to EM px per em: 0.5 is the outline,
  one unit is 2 x SPREAD atlas pixels. Sharp at any size when drawn with smoothstep.
- `bitmap_<px>`: FreeType's own coverage at small pixel sizes, drawn texel for pixel
  (the mapped-texture path, pixel-exact).
Per glyph, `*_rect` is (x, y, w, h) in the atlas and `*_plane` (left, top, right,
bottom) the quad around the pen origin on the baseline, y down, in em (sdf) or px;
`advance`, `ascent` and `descent` are in em.
"""
import glob
import os
import sys

import numpy as np

CHARS = "".join(chr(c) for c in range(32, 127))
EM = 64            # sdf atlas pixels per em
SUPER = 4          # measured at EM * SUPER
SPREAD = 8         # atlas pixels of distance each side of the outline (also the padding)
BITMAP_SIZES = tuple(range(8, 17))
BITMAP_PAD = 2     # room for a 1 px shadow
COLUMNS = 16
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "dejavu_sans_mono.npz")


def find_font():
    try:
        import matplotlib
        path = os.path.join(os.path.dirname(matplotlib.__file__), "mpl-data", "fonts", "ttf",
                            "DejaVuSansMono.ttf")
        if os.path.isfile(path):
            return path
    except ImportError:
        pass
    found = glob.glob("/usr/share/fonts/**/DejaVuSansMono.ttf", recursive=True)
    if not found:
        raise SystemExit("DejaVuSansMono.ttf not found: pass its path")
    return found[0]


def _pack(images):
    """Shelf-packs glyph images into rows of COLUMNS; returns atlas, rects."""
    cell_w = max(im.shape[1] for im in images)
    cell_h = max(im.shape[0] for im in images)
    rows = -(-len(images) // COLUMNS)
    atlas = np.zeros((rows * cell_h, COLUMNS * cell_w), np.uint8)
    rects = []
    for i, im in enumerate(images):
        x, y = (i % COLUMNS) * cell_w, (i // COLUMNS) * cell_h
        atlas[y:y + im.shape[0], x:x + im.shape[1]] = im
        rects.append((x, y, im.shape[1], im.shape[0]))
    return atlas, np.array(rects, np.int32)


def sdf_glyphs(path):
    from PIL import Image, ImageDraw, ImageFont
    from scipy.ndimage import distance_transform_edt
    big = ImageFont.truetype(path, EM * SUPER)
    pad = SPREAD * SUPER
    images, planes, advances = [], [], []
    for ch in CHARS:
        advances.append(big.getlength(ch) / (EM * SUPER))
        left, top, right, bottom = big.getbbox(ch, anchor="ls")
        # Whole atlas pixels around the ink, padded by SPREAD.
        left, top = (left // SUPER) * SUPER - pad, (top // SUPER) * SUPER - pad
        right, bottom = -(-right // SUPER) * SUPER + pad, -(-bottom // SUPER) * SUPER + pad
        w, h = right - left, bottom - top
        canvas = Image.new("L", (w, h), 0)
        ImageDraw.Draw(canvas).text((-left, -top), ch, font=big, fill=255, anchor="ls")
        ink = np.asarray(canvas) >= 128
        inside = distance_transform_edt(ink) - 0.5
        outside = distance_transform_edt(~ink) - 0.5
        dist = np.where(ink, inside, -outside) / SUPER          # atlas pixels
        # Sample at atlas pixel centres: mean of each SUPER x SUPER block.
        dist = dist.reshape(h // SUPER, SUPER, w // SUPER, SUPER).mean(axis=(1, 3))
        images.append(np.clip(np.round((0.5 + dist / (2 * SPREAD)) * 255), 0, 255)
                      .astype(np.uint8))
        planes.append((left / (EM * SUPER), top / (EM * SUPER),
                       right / (EM * SUPER), bottom / (EM * SUPER)))
    atlas, rects = _pack(images)
    return atlas, rects, np.array(planes, np.float32), np.array(advances, np.float32)


def bitmap_glyphs(path, px):
    from PIL import Image, ImageDraw, ImageFont
    font = ImageFont.truetype(path, px)
    images, planes = [], []
    for ch in CHARS:
        left, top, right, bottom = font.getbbox(ch, anchor="ls")
        left, top = left - BITMAP_PAD, top - BITMAP_PAD
        right, bottom = right + BITMAP_PAD, bottom + BITMAP_PAD
        canvas = Image.new("L", (right - left, bottom - top), 0)
        ImageDraw.Draw(canvas).text((-left, -top), ch, font=font, fill=255, anchor="ls")
        images.append(np.asarray(canvas))
        planes.append((left, top, right, bottom))
    atlas, rects = _pack(images)
    return atlas, rects, np.array(planes, np.float32)


def main(argv):
    path = argv[1] if len(argv) > 1 else find_font()
    atlas, rects, planes, advances = sdf_glyphs(path)
    from PIL import ImageFont
    ascent, descent = ImageFont.truetype(path, EM * SUPER).getmetrics()
    arrays = dict(chars=np.array(CHARS), em=np.int32(EM), spread=np.int32(SPREAD),
                  ascent=np.float32(ascent / (EM * SUPER)), descent=np.float32(descent / (EM * SUPER)),
                  sdf=atlas, sdf_rect=rects, sdf_plane=planes, advance=advances,
                  bitmap_sizes=np.array(BITMAP_SIZES, np.int32))
    for px in BITMAP_SIZES:
        arrays[f"bitmap_{px}"], arrays[f"bitmap_{px}_rect"], arrays[f"bitmap_{px}_plane"] = \
            bitmap_glyphs(path, px)
    np.savez_compressed(OUT, **arrays)
    print(f"{path} -> {OUT} ({os.path.getsize(OUT) // 1024} KB; sdf {atlas.shape[1]}x{atlas.shape[0]})")


if __name__ == "__main__":
    main(sys.argv)
