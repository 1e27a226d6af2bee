"""An Image Texture node's settings as the stage says them, the one table of each: the
exporters write Blender's settings in these words, the engine reads them, and
shaders/material.glsl numbers the filter types by their place in FILTERTYPES."""
from __future__ import annotations

# Blender's extension -> a UsdUVTexture's wrapS/wrapT (and a network image's `wrap`).
WRAP = {"REPEAT": "repeat", "EXTEND": "clamp", "CLIP": "black", "MIRROR": "mirror"}

# Blender's interpolation -> the stage's filter type: MaterialX's image `filtertype`
# words, and Blender's Smart, which MaterialX has no word for (Cubic where the image
# is magnified, Linear where not). A UsdUVTexture carries it as `lantern:filtertype`
# (UsdUVTexture has no such input), a network's image as its `filtertype` setting.
FILTERTYPES = ("linear", "closest", "cubic", "smart")
BLENDER_INTERPOLATIONS = {"Linear": "linear", "Closest": "closest", "Cubic": "cubic",
                          "Smart": "smart"}
DEFAULT_FILTERTYPE = "linear"


def filtertype_of(value, owner: str, warn) -> str:
    """`value` if it is one of FILTERTYPES, else Linear, after `warn(line)` naming
    `owner` (a material's node, a stage's prim) and the value."""
    if value in FILTERTYPES:
        return value
    warn(f"{owner}: interpolation {value!r} is not one of {', '.join(FILTERTYPES)}; "
         f"Linear used")
    return DEFAULT_FILTERTYPE
