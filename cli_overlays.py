"""`lantern render`'s overlay options (--burn-in, --watermark) and the BurnIn they make.

Kept apart from cli.py so the command line only wires them: add_options() to the
render parser, check() before any work (a bad template is a usage error), and
from_args() once the stage is open (the camera's name is read from it)."""
from __future__ import annotations

import os
import sys

from .engine.overlay_options import ANCHORS, BURN_IN_FIELDS, TEXT_MODES, OverlayError, \
    check_template

FIELDS_HELP = "fields: " + "; ".join(f"{{{name}}} {text}" for name, text in
                                     BURN_IN_FIELDS.items())


def add_options(render):
    group = render.add_argument_group(
        "overlays", "drawn on the display-referred .png (after --view/--look/--exposure); "
        "an .exr stays scene linear and clean")
    group.add_argument("--burn-in", default=None, metavar="TEMPLATE",
                       help="a line of text over each frame, e.g. "
                            "'{scene} {camera} f{frame:04d} {date}'; " + FIELDS_HELP
                            + "; an unknown field is a usage error (exit 2)")
    group.add_argument("--burn-in-position", default="bottom-left", choices=ANCHORS,
                       help="where the burn-in sits (default bottom-left)")
    group.add_argument("--burn-in-size", type=float, default=24.0, metavar="PX",
                       help="burn-in text size in pixels per em, 8 to 200 (default 24)")
    group.add_argument("--burn-in-text", default="auto", choices=TEXT_MODES,
                       help="sdf (distance field, any size, outlined), bitmap (FreeType's "
                            "pixels, whole sizes 8-16, shadowed) or auto (bitmap where it "
                            "can; default)")
    group.add_argument("--watermark", default=None, metavar="IMAGE",
                       help="an image (.png with alpha) drawn over each frame")
    group.add_argument("--watermark-position", default="bottom-right", choices=ANCHORS)
    group.add_argument("--watermark-scale", type=float, default=0.2, metavar="FRACTION",
                       help="the watermark's width as a fraction of the image's (default 0.2)")


def check(args, usage, failed):
    """Before any work: the template's fields, the size, the watermark's file."""
    if args.burn_in is not None:
        try:
            check_template(args.burn_in)
        except OverlayError as error:
            raise usage(str(error))
        if not 8.0 <= args.burn_in_size <= 200.0:
            raise usage(f"--burn-in-size {args.burn_in_size:g}: must be 8 to 200 pixels")
        if args.burn_in_text == "bitmap" and not (args.burn_in_size.is_integer()
                                                  and 8 <= args.burn_in_size <= 16):
            raise usage("--burn-in-text bitmap needs a whole --burn-in-size from 8 to 16")
    if args.watermark is not None:
        if not 0.0 < args.watermark_scale <= 1.0:
            raise usage("--watermark-scale must be above 0 and at most 1")
        if not os.path.isfile(args.watermark):
            raise failed(f"{args.watermark}: no such file")


def from_args(args, stage, failed):
    """The BurnIn for args (None when there is no overlay)."""
    if args.burn_in is None and args.watermark is None:
        return None
    if not args.output.lower().endswith(".png"):
        print(f"warning: {args.output}: overlays are drawn on .png outputs only (an .exr "
              "stays scene linear; a .gif preview has none)", file=sys.stderr, flush=True)
        return None
    from .engine.overlays import BurnIn
    watermark = _watermark(args.watermark, failed) if args.watermark else None
    values = dict(scene=os.path.splitext(os.path.basename(args.scene))[0],
                  camera=_camera_name(stage, args.camera), preset=args.preset)
    return BurnIn(template=args.burn_in, anchor=args.burn_in_position, size=args.burn_in_size,
                  mode=args.burn_in_text, values=values, watermark=watermark,
                  watermark_anchor=args.watermark_position, watermark_scale=args.watermark_scale)


def _camera_name(stage, camera):
    """The camera the engine renders through: --camera, the render settings', else the
    first camera; 'default' when there is none (the engine frames the scene)."""
    from .engine.usd.camera import rendered_camera_path
    path = rendered_camera_path(stage, camera)
    return path.rsplit("/", 1)[-1] if path else "default"


def _watermark(path, failed):
    """(H, W, 4) uint8 straight alpha; grey and RGB images get an opaque alpha."""
    import numpy as np
    from .engine.image_io import ImageError, read_image
    try:
        pixels = read_image(path)
    except (ImageError, OSError) as error:
        raise failed(str(error))
    if pixels.dtype == np.uint16:
        pixels = np.round(pixels / 257.0).astype(np.uint8)
    elif pixels.dtype != np.uint8:
        raise failed(f"{path}: the watermark must be an 8- or 16-bit image (.png), "
                     f"not {pixels.dtype}")
    channels = pixels.shape[2]
    if channels in (1, 2):
        pixels = np.concatenate([pixels[..., :1]] * 3 + [pixels[..., 1:]], axis=2)
    if pixels.shape[2] == 3:
        pixels = np.concatenate([pixels, np.full(pixels.shape[:2] + (1,), 255, np.uint8)], 2)
    return np.ascontiguousarray(pixels[..., :4])
