"""`lantern render`'s outputs: what each file holds and where it goes.

- `-o` is the one output, whatever products the stage names: the plain RGBA image
  (Combined), or with `--passes depth,normal,...` (or `all`) those render passes, a
  multi-layer EXR under Blender's layer names (engine/image_io.py write_layers), at
  the resolution and through the camera of the RenderSettings (`--settings PRIM`,
  else the stage's `renderSettingsPrimPath`).
- Without -o, the stage's RenderSettings (`--settings PRIM`, else its
  `renderSettingsPrimPath`) names the outputs, as `husk` renders them: each
  RenderProduct is one file, `productName` (relative to the working folder, with
  `$F4`-style frame tokens), at its resolution, through its camera, its RenderVars
  the file's layers. A RenderVar Lantern cannot make is one warning; the rest are
  written. --size and --camera override every product's.
"""
import argparse
import os
import re

from ..core import passes as table
from ..farm.options import Product
from .common import CommandError, usage

# Houdini's frame variables, as husk expands them in a productName: $F (the frame),
# $F4 (zero-padded to 4), ${F4}, $FF (the frame with its fraction).
FRAME_TOKEN = re.compile(r"\$\{?F(F|\d*)\}?")


class PassesHelp(argparse.Action):
    """--passes help: the table, then exit (no scene needed)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if values != "help":
            setattr(namespace, self.dest, values)
            return
        print(passes_help())
        parser.exit()


def add_options(render):
    render.add_argument("--passes", action=PassesHelp, default=None, metavar="NAME,...",
                        help="render passes into -o, a multi-layer EXR: comma-separated "
                             "names, 'all', or 'help' to list them")
    render.add_argument("--settings", default=None, metavar="PRIM",
                        help="the RenderSettings prim whose RenderProducts name the outputs "
                             "(default: the stage's renderSettingsPrimPath)")


def passes_help() -> str:
    lines = ["render passes (--passes NAME,...; a RenderVar's sourceName may also be "
             "one of these, a Hydra name: color, depth, normal, primId, or Blender's "
             "pass name):", f"  {'name':<20}{'layers in the EXR':<50}"]
    for option, names in table.options().items():
        layers = ", ".join(f"{table.PASSES[n].title}."
                           f"{'/'.join(table.PASSES[n].file_channels)}" for n in names)
        lines.append(f"  {option:<20}{layers}")
    lines.append("every file also holds Combined.R/G/B/A; layers are named "
                 "'<view layer>.<pass>.<channel>', the view layer ViewLayer unless the "
                 "product names one")
    return "\n".join(lines)


def parse_passes(text) -> tuple:
    """--passes' names -> the engine's pass names (core/passes.py), in table order."""
    if text is None:
        return None
    found = []
    for name in filter(None, (part.strip() for part in text.split(","))):
        resolved = [p.name for p in table.provided()] if name == "all" else \
            table.resolve(name)
        if resolved is None:
            raise usage(f"--passes {name}: unknown render pass; valid names: all, "
                        f"{', '.join(table.options())} (--passes help lists them)")
        found += resolved
    if not found:
        raise usage("--passes: name at least one render pass (--passes help lists them)")
    order = list(table.PASSES)
    return tuple(sorted(set(found), key=order.index))


def frame_pattern(name: str) -> str:
    """A productName's frame tokens as Lantern's '#' runs ($F4 -> ####; $F and $FF ->
    #, the frame unpadded, with its fraction if it has one: core/text.py frame_path)."""
    return FRAME_TOKEN.sub(lambda m: "#" * (int(m.group(1)) if m.group(1).isdigit() else 1),
                           name)


def plan(args, stage, warn) -> list:
    """The outputs of a render of `stage`, as farm/options.py Products: names still
    with their frame patterns ('#'), products' names made absolute. The stage's
    products only when there is no -o."""
    from ..engine.usd.render_products import (RenderSettingsError, read_settings,
                                              settings_path)
    try:
        path = settings_path(stage, args.settings)
    except RenderSettingsError as error:
        raise (usage if args.settings else CommandError)(f"{args.scene}: {error}")
    record, warnings = read_settings(stage, path) if path else (None, [])
    warn([f"{args.scene}: {w}" for w in warnings])
    if args.output is not None:     # the image, and --passes' passes
        if record is None:          # the engine reads /Render/Settings, if any
            return [Product(args.output, args.size, args.camera, args.passes or ())]
        return [Product(args.output, args.size or record.resolution,
                        args.camera or _camera(stage, record.camera, path, warn),
                        args.passes or ())]
    products = []
    for p in record.products if record else ():
        if p.product_type != "raster":
            warn([f"{p.path}: productType {p.product_type!r} is not made (only raster "
                  "images); skipped"])
        elif not p.name:
            warn([f"{p.path}: no productName; skipped"])
        else:
            products.append(p)
    if not products:
        raise usage(f"{args.scene}: no -o, and the stage names no RenderProducts "
                    f"({'RenderSettings ' + path if path else 'no RenderSettings'})")
    outputs = []
    for p in products:
        name = os.path.abspath(frame_pattern(p.name))
        passes = []
        for var in p.vars:
            made = table.resolve(var.source) if var.source_type in ("raw", "intrinsic") \
                else None
            if made is None:
                warn([f"{var.path}: Lantern cannot make {var.source_type} "
                      f"{var.source!r}; {os.path.basename(name)} is written without it"])
            else:
                passes += made
        exr = name.lower().endswith(".exr")
        if passes and not exr:
            warn([f"{name}: render passes need an .exr; it holds the Combined image only"])
            passes = []
        outputs.append(Product(name, args.size or p.resolution,
                               args.camera or _camera(stage, p.camera, p.path, warn),
                               tuple(sorted(set(passes), key=list(table.PASSES).index)),
                               p.view_layer, multilayer=exr, product=p.path))
    return outputs


def _camera(stage, path, owner, warn):
    """A RenderSettings' or RenderProduct's camera, when it is one; else a warning
    naming it, and None (the engine's own choice: the first camera, or the default
    view)."""
    from ..engine.usd.camera import camera_path_problem
    if path is None:
        return None
    problem = camera_path_problem(stage, path, "the stage")
    if problem is None:
        return path
    warn([f"{owner}: its camera {path}: {problem}; using the first camera, or the "
          "default view"])
    return None


def check(output: Product, sequence: bool, from_command_line: bool, kinds):
    """A product's file name, before any render: of a kind Lantern writes, with a
    frame in a sequence's name, in a folder that can be made and written (exit 1 names
    it). -o was checked as the command line's."""
    from .common import check_folder
    if from_command_line:
        return
    name = output.output
    if not name.lower().endswith(kinds):
        raise CommandError(f"{name}: a product's file must be {' or '.join(kinds)}")
    if sequence and "#" not in name:
        raise CommandError(f"{name}: a sequence needs a frame token ($F4) in its "
                           "productName")
    if os.path.isdir(name):
        raise CommandError(f"{name}: is a directory, not a file name")
    check_folder(os.path.dirname(os.path.abspath(name)))


def write(output: Product, path: str, result, colour: dict, overlay):
    """One rendered frame into `path`: a multi-layer EXR of its passes, else the
    image."""
    from ..engine.image_io import write_image, write_layers
    if output.layered:
        write_layers(path, result.rgba, result.passes, output.layer, result.cryptomatte)
    else:
        write_image(path, result.rgba, **colour, overlay=overlay)
