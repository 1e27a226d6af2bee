"""Scene-linear RGBA -> 8-bit display values, as Blender saves a render.

Blender's colour management is an exposure (a scale by 2^exposure in scene linear),
an optional look, then a view transform to the display (sRGB here), all through
OpenColorIO with Blender's own config.ocio. This module does the same with the same
config, so a PNG from `lantern render --view AgX` matches the PNG Blender saves from the
same linear image with AgX.

- view "Standard" with no look and exposure 0 (the default) is the sRGB OETF of the
  values clamped to [0, 1], computed here in closed form: no OCIO config is needed,
  and a test checks it against OCIO's own Standard view.
- Anything else goes through PyOpenColorIO. The config is found from $OCIO, else from
  the Blender in this process (bpy already imported), else from the installed `bpy`
  package's `<version>/datafiles/colormanagement/config.ocio`, located without
  importing bpy (a process that renders USD never loads Blender).
- Alpha is never colour-managed: it is clamped to [0, 1] and stored straight.
- Quantisation rounds to nearest, with no dither (Blender's default dither adds noise
  of about 1/255; set Dither to 0 in Blender for byte-exact comparisons).
"""
from __future__ import annotations

import functools
import glob
import importlib.util
import os
import sys
import threading

import numpy as np

from . import color_cache

DISPLAY = "sRGB"
STANDARD = "Standard"


class ColorManagementError(ValueError):
    """Unknown view or look, or no OpenColorIO config to apply them with."""


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def to_srgb8(rgba: np.ndarray) -> np.ndarray:
    """Scene-linear RGBA -> 8-bit through Blender's Standard view (sRGB), alpha kept."""
    out = np.empty(rgba.shape, dtype=np.uint8)
    out[..., :3] = np.round(linear_to_srgb(rgba[..., :3]) * 255.0)
    out[..., 3] = np.round(np.clip(rgba[..., 3], 0.0, 1.0) * 255.0)
    return out


def to_display8(rgba: np.ndarray, view: str = STANDARD, look: str | None = None,
                exposure: float = 0.0) -> np.ndarray:
    """(H, W, 4) float scene-linear -> (H, W, 4) uint8 display-referred RGBA."""
    rgba = np.asarray(rgba, dtype=np.float32)
    if view == STANDARD and not look and exposure == 0.0:
        return to_srgb8(rgba)
    rgb = display_rgb(rgba[..., :3], view=view, look=look, exposure=exposure)
    out = np.empty(rgba.shape, dtype=np.uint8)
    out[..., :3] = np.round(np.clip(rgb, 0.0, 1.0) * 255.0)
    out[..., 3] = np.round(np.clip(rgba[..., 3], 0.0, 1.0) * 255.0)
    return out


def check(view: str = STANDARD, look: str | None = None, exposure: float = 0.0) -> None:
    """Raise ColorManagementError now for settings to_display8 could not apply (no
    config, an unknown view or look). Their transform is then built on a thread of its
    own, for the image written later. OpenColorIO holds Python's lock while it builds
    (AgX: 120 ms, parsing its LUT), so the thread overlaps little: what spares a new
    process the build is the transform kept in the cache folder (color_cache.py)."""
    if view != STANDARD or look or exposure != 0.0:
        _check_names(_config(), view, look)
        # Not a daemon: a process that ends meanwhile waits for it (at most the build)
        # rather than tearing OpenColorIO down under it.
        key = (view, look or "", float(exposure))
        _ahead[key] = thread = threading.Thread(target=_build_ahead, args=key,
                                                name="lantern-colour")
        thread.start()


def _build_ahead(view, look, exposure):
    try:
        _processor(view, look, exposure)
    except Exception:       # noqa: BLE001  (raised again where the image asks for it)
        pass


def display_rgb(rgb: np.ndarray, view: str = STANDARD, look: str | None = None,
                exposure: float = 0.0) -> np.ndarray:
    """Float display-referred RGB through OpenColorIO (no clamp, no quantisation)."""
    processor = _processor(view, look or "", float(exposure))
    pixels = np.ascontiguousarray(rgb, dtype=np.float32).reshape(-1, 3).copy()
    processor.applyRGB(pixels)
    return pixels.reshape(rgb.shape)


def config_path() -> str:
    """Blender's config.ocio: $OCIO, the running Blender's, or the installed bpy's."""
    env = os.environ.get("OCIO")
    if env:
        return env
    bpy = sys.modules.get("bpy")
    if bpy is not None and hasattr(bpy, "utils"):
        path = os.path.join(bpy.utils.resource_path("LOCAL"), "datafiles", "colormanagement",
                            "config.ocio")
        if os.path.isfile(path):
            return path
    spec = importlib.util.find_spec("bpy")
    for folder in (spec.submodule_search_locations or []) if spec else []:
        found = sorted(glob.glob(os.path.join(folder, "*", "datafiles", "colormanagement",
                                              "config.ocio")))
        if found:
            return found[-1]
    raise ColorManagementError(
        "no OpenColorIO config: set $OCIO to Blender's config.ocio, or install bpy "
        "(its datafiles/colormanagement/config.ocio is used)")


def views() -> list[str]:
    return list(_config().getViews(DISPLAY))


def looks_for(view: str) -> list[str]:
    """The looks Blender lists for `view`: "<view> - <name>" looks, and the shared
    contrast looks for views that have none of their own (Filmic, Standard)."""
    names = [look.getName() for look in _config().getLooks()]
    own = [n for n in names if n.startswith(view + " - ")]
    if own:
        return own
    return [n for n in names if " - " not in n]


@functools.lru_cache(maxsize=1)
def _config():
    import PyOpenColorIO as ocio
    path = config_path()
    try:
        return ocio.Config.CreateFromFile(path)
    except Exception as error:  # OCIO raises its own Exception type
        raise ColorManagementError(f"{path}: cannot load the OpenColorIO config ({error})")


def _look_name(config, view, look):
    """Blender's UI names a look without its view prefix ("Punchy" for "AgX - Punchy")."""
    names = [l.getName() for l in config.getLooks()]
    for candidate in (look, f"{view} - {look}"):
        if candidate in names:
            return candidate
    raise ColorManagementError(f"unknown look {look!r} for view {view!r}; "
                               f"known: {', '.join(looks_for(view)) or 'none'}")


def _check_names(config, view, look):
    if view not in config.getViews(DISPLAY):
        raise ColorManagementError(f"unknown view {view!r}; known: "
                                   f"{', '.join(config.getViews(DISPLAY))}")
    if look:
        _look_name(config, view, look)


_building = threading.Lock()        # one build of a transform, whoever asks first
_ahead = {}                          # (view, look, exposure) -> the thread check() started


def _processor(view, look, exposure):
    # A transform check() is building is waited for, not raced for the lock: the
    # image that asks gets the thread's build, whichever thread starts first.
    ahead = _ahead.get((view, look, exposure))
    if ahead is not None and ahead is not threading.current_thread():
        ahead.join()
        _ahead.pop((view, look, exposure), None)
    with _building:
        return _built_processor(view, look, exposure)


@functools.lru_cache(maxsize=16)
def _built_processor(view, look, exposure):
    config = _config()
    _check_names(config, view, look)
    return color_cache.kept(config, config_path(), (view, look, exposure),
                            lambda: _transform(config, view, look, exposure)
                            ).getDefaultCPUProcessor()


def _transform(config, view, look, exposure):
    """Blender's display transform: exposure, look, then the view."""
    import PyOpenColorIO as ocio
    group = ocio.GroupTransform()
    source = ocio.ROLE_SCENE_LINEAR
    if exposure != 0.0:
        scale = 2.0 ** exposure
        group.appendTransform(ocio.MatrixTransform(
            [scale, 0, 0, 0, 0, scale, 0, 0, 0, 0, scale, 0, 0, 0, 0, 1]))
    if look:
        # As Blender: the look runs from scene linear to its own result space, then the
        # view transform takes over from there with the view's own looks bypassed.
        name = _look_name(config, view, look)
        result = config.getLook(name).getProcessSpace()  # a single look's result space
        group.appendTransform(ocio.LookTransform(src=source, dst=result, looks=name))
        source = result
    group.appendTransform(ocio.DisplayViewTransform(src=source, display=DISPLAY, view=view,
                                                    looksBypass=True))
    return group
