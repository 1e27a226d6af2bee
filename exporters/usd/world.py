"""WorldRecord -> the /root/_world DomeLight."""
from pxr import UsdLux

from .light import write_common
from .names import set_blender_name


def write_world(stage, path, rec, asset_path):
    dome = UsdLux.DomeLight.Define(stage, path)
    write_common(dome, rec.color, rec.intensity, True)
    if rec.texture:
        dome.CreateTextureFileAttr(asset_path(rec.texture))
        dome.CreateTextureFormatAttr(UsdLux.Tokens.latlong)
    set_blender_name(dome.GetPrim(), rec.name)
    return dome
