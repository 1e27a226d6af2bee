"""Public entry points: export a depsgraph into a stage, or a .blend into a file."""
import logging
import os
import time
from dataclasses import dataclass, field

import bpy
from pxr import Usd

from ..core.files import atomic_write
from ..core.subdivision_modes import FILE_DEFAULT, SUBDIVISION_MODES
from .errors import ExportError
from .gather.scene import gather_scene
from .usd.assets import asset_resolver
from .usd.scene import write_scene

log = logging.getLogger("lantern.export")
FORMATS = {".usda", ".usdc", ".usd"}


@dataclass
class ExportOptions:
    textures: str = "reference"     # "reference": relative paths; "copy": into <stem>_textures/
    texture_dir: str | None = None  # where packed/generated images go for in-memory stages
    animation: bool = True          # sample the frame range (rigs, shape keys, moving objects)
    max_influences: int | None = None  # trim skin influences per vertex (None: keep all)
    # A last Subdivision Surface: "cage", "apply" or "ignore" (core/subdivision_modes.py).
    subdivision: str = FILE_DEFAULT


@dataclass
class ExportReport:
    path: str | None
    warnings: list = field(default_factory=list)
    counts: dict = field(default_factory=dict)
    seconds: float = 0.0


def _texture_dir(layer_path, options):
    if options.texture_dir is not None:
        return options.texture_dir
    if layer_path is None:
        return None
    stem = os.path.splitext(os.path.abspath(layer_path))[0]
    return stem + "_textures"


def _export(depsgraph, stage, options, layer_path):
    start = time.perf_counter()
    if options.subdivision not in SUBDIVISION_MODES:
        raise ExportError(f"subdivision {options.subdivision!r}: expected one of "
                          f"{', '.join(SUBDIVISION_MODES)}")
    warnings = []

    def warn(message):
        if message not in warnings:
            warnings.append(message)
            log.warning(message)

    scene = gather_scene(depsgraph, warn, _texture_dir(layer_path, options), options.animation,
                         subdivision=options.subdivision)
    write_scene(stage, scene, asset_resolver(layer_path, options.textures),
                options.max_influences)
    kinds = [o.kind for o in scene.objects]
    counts = {"objects": len(scene.objects), "meshes": len(scene.meshes),
              "materials": len(scene.materials), "lights": kinds.count("light"),
              "cameras": kinds.count("camera"),
              "prototypes": len({o.mesh for o in scene.objects if o.shared}),
              "world": int(scene.world is not None),
              "skeletons": len(scene.skeletons),
              "skinned": sum(m.skin is not None for m in scene.meshes.values()),
              "baked": sum(m.point_samples is not None for m in scene.meshes.values())}
    return ExportReport(path=layer_path, warnings=warnings, counts=counts,
                        seconds=time.perf_counter() - start)


def export_depsgraph(depsgraph, stage, options=None):
    """Fills `stage` (e.g. in memory) from an evaluated depsgraph."""
    options = options or ExportOptions()
    real = stage.GetRootLayer().realPath or None
    return _export(depsgraph, stage, options, real)


def _check_blend(path):
    if not os.path.isfile(path):
        raise ExportError(f"{path}: no such .blend file")
    with open(path, "rb") as f:
        head = f.read(12)
    # Plain, gzip- or zstd-compressed .blend files.
    if not (head.startswith(b"BLENDER") or head.startswith(b"\x1f\x8b")
            or head.startswith(b"\x28\xb5\x2f\xfd")):
        raise ExportError(f"{path}: not a .blend file (bad header {head[:7]!r})")


def open_blend(blend_path):
    """Opens a .blend as the current file; ExportError names the file and the reason."""
    blend_path = os.path.abspath(blend_path)
    _check_blend(blend_path)
    try:
        bpy.ops.wm.open_mainfile(filepath=blend_path, load_ui=False)
    except RuntimeError as e:
        raise ExportError(f"{blend_path}: cannot be opened: {str(e).strip()}") from e
    return bpy.context.scene


def stage_from_depsgraph(depsgraph, options=None):
    """(in-memory stage, report); textures keep absolute paths."""
    stage = Usd.Stage.CreateInMemory()
    return stage, export_depsgraph(depsgraph, stage, options)


def stage_from_blend(blend_path, options=None):
    """Opens `blend_path` and exports it into an in-memory stage: (stage, report)."""
    open_blend(blend_path)
    return stage_from_depsgraph(bpy.context.evaluated_depsgraph_get(), options)


def _check_out_path(out_path):
    ext = os.path.splitext(out_path)[1].lower()
    if ext not in FORMATS:
        raise ExportError(f"{out_path}: unknown USD extension {ext!r} (use .usda, .usdc or .usd)")
    return ext


def export_depsgraph_to_file(depsgraph, out_path, options=None):
    """Exports `depsgraph` to `out_path` (.usda/.usdc/.usd), written atomically."""
    options = options or ExportOptions()
    out_path = os.path.abspath(out_path)
    ext = _check_out_path(out_path)
    stage = Usd.Stage.CreateInMemory()
    report = _export(depsgraph, stage, options, out_path)

    # A temp file beside the target, then a rename: readers never see half a file.
    os.makedirs(os.path.dirname(out_path), exist_ok=True)

    def write(tmp):
        if not stage.GetRootLayer().Export(tmp):
            raise ExportError(f"{out_path}: USD could not write the layer")
    atomic_write(out_path, write, suffix=ext)
    report.path = out_path
    return report


def export_blend(blend_path, out_path, options=None):
    """Opens `blend_path`, exports its scene, and writes `out_path` atomically."""
    _check_out_path(os.path.abspath(out_path))
    open_blend(blend_path)
    return export_depsgraph_to_file(bpy.context.evaluated_depsgraph_get(), out_path, options)
