"""Pattern-graph node kinds and their settings: the one table. The exporter writes
Blender's nodes as these kinds (ND_lantern_<kind>), the engine reads them and
generates GLSL from them; an operation's position in its list is its number in
shaders/pattern_lib.glsl."""
from __future__ import annotations

from .images import FILTERTYPES

# Blender's Math node operations, as shaders/pattern_lib.glsl pt_math numbers them.
MATH_OPS = (
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM", "SQRT",
    "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN", "GREATER_THAN",
    "SIGN", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "ROUND", "FLOOR", "CEIL", "TRUNC", "FRACT",
    "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG", "SINE", "COSINE", "TANGENT",
    "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH", "COSH", "TANH", "RADIANS",
    "DEGREES")
# Vector Math operations (pt_vector_math).
VECTOR_MATH_OPS = (
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT", "PROJECT",
    "REFLECT", "DOT_PRODUCT", "DISTANCE", "LENGTH", "SCALE", "NORMALIZE", "SNAP", "FLOOR",
    "CEIL", "MODULO", "WRAP", "FRACTION", "ABSOLUTE", "POWER", "SIGN", "MINIMUM", "MAXIMUM",
    "SINE", "COSINE", "TANGENT", "REFRACT", "FACEFORWARD")
# Mix (colour) blend types (pt_blend).
BLEND_TYPES = (
    "MIX", "ADD", "MULTIPLY", "SUBTRACT", "SCREEN", "DIVIDE", "DIFFERENCE", "EXCLUSION",
    "DARKEN", "LIGHTEN", "OVERLAY", "DODGE", "BURN", "HUE", "SATURATION", "VALUE", "COLOR",
    "SOFT_LIGHT", "LINEAR_LIGHT")
MAPPING_TYPES = ("POINT", "TEXTURE", "VECTOR", "NORMAL")
RAMP_INTERPOLATIONS = ("LINEAR", "CONSTANT", "EASE")
COLOR_MODES = ("RGB", "HSV")
VORONOI_METRICS = ("EUCLIDEAN", "MANHATTAN", "CHEBYCHEV", "MINKOWSKI")
WAVE_TYPES = ("BANDS", "RINGS")
# Bands X Y Z DIAGONAL, rings X Y Z SPHERICAL: one number each (pt_wave).
WAVE_DIRECTIONS = ("X", "Y", "Z", "DIAGONAL", "SPHERICAL")
WAVE_PROFILES = ("SIN", "SAW", "TRI")
GRADIENT_TYPES = ("LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "SPHERICAL", "QUADRATIC_SPHERE",
                  "RADIAL")

# kind -> {setting: allowed values}; a setting missing here is free (a count, a flag).
KINDS = {
    "uv": {}, "value": {}, "rgb": {},
    "mix": {"data_type": ("FLOAT", "VECTOR", "RGBA"), "blend_type": BLEND_TYPES},
    "math": {"operation": MATH_OPS},
    "vector_math": {"operation": VECTOR_MATH_OPS},
    "mapping": {"vector_type": MAPPING_TYPES},
    "invert": {}, "separate_xyz": {}, "combine_xyz": {},
    "separate_color": {"mode": COLOR_MODES}, "combine_color": {"mode": COLOR_MODES},
    "color_ramp": {"interpolation": RAMP_INTERPOLATIONS},
    "hue_saturation": {}, "checker": {}, "gradient": {"gradient_type": GRADIENT_TYPES},
    # Blender's Perlin fBm in 3D (shaders/pattern_lib.glsl pt_noise_fbm).
    "noise": {"dimensions": ("3D",), "noise_type": ("FBM",)},
    # An image inside a network (one directly on a surface input stays a UsdUVTexture).
    "image": {"wrap": ("repeat", "clamp", "black", "mirror"), "color_space": ("sRGB", "raw"),
              "filtertype": FILTERTYPES},
    "voronoi": {"dimensions": ("3D",), "feature": ("F1",), "distance": VORONOI_METRICS,
                "normalize": ("0",)},
    "wave": {"wave_type": WAVE_TYPES, "direction": WAVE_DIRECTIONS, "wave_profile": WAVE_PROFILES},
    # Shading normals (the surface input `normal`): Cycles' Bump node (svm_node_set_bump)
    # from the height's screen-space derivatives, and a tangent-space Normal Map whose
    # colour a network computes.
    "bump": {"invert": ("0", "1")},
    # A mesh's attribute, by the primvar it is written as (its setting `name`); its
    # alpha, where not all 1, by attribute_opacity(name).
    "attribute": {},
    "normal_map": {"space": ("TANGENT",)},
}


# The surface inputs (UsdPreviewSurface's names) a network can feed, and their types.
SURFACE_INPUTS = {"diffuseColor": "color", "metallic": "float", "roughness": "float",
                  "opacity": "float", "emissiveColor": "color", "normal": "vector",
                  "sheenColor": "color", "sheenRoughness": "float"}

MAX_IMAGES = 8   # images per network: texture units t_pattern0..7 (engine/gpu/programs.py)


def attribute_opacity(primvar: str) -> str:
    """The float primvar holding an attribute's alpha beside its colour3f one: USD's
    displayOpacity for displayColor, else `<primvar>_opacity`."""
    return "displayOpacity" if primvar == "displayColor" else f"{primvar}_opacity"


def unsupported_setting(kind: str, settings: dict) -> str | None:
    """'kind not supported' or 'operation X not supported', None when all is known."""
    allowed = KINDS.get(kind)
    if allowed is None:
        return f"kind {kind} is not supported"
    for name, values in allowed.items():
        if name in settings and settings[name] not in values:
            return f"{name} {settings[name]} is not supported"
    return None


def _final(a, b, c):
    """Bob Jenkins' lookup3 final mix on uint32, as Cycles' hash.h."""
    def rot(x, k):
        return ((x << k) | (x >> (32 - k))) & 0xFFFFFFFF
    m = 0xFFFFFFFF
    c ^= b; c = (c - rot(b, 14)) & m
    a ^= c; a = (a - rot(c, 11)) & m
    b ^= a; b = (b - rot(a, 25)) & m
    c ^= b; c = (c - rot(b, 16)) & m
    a ^= c; a = (a - rot(c, 4)) & m
    b ^= a; b = (b - rot(a, 14)) & m
    c ^= b; c = (c - rot(b, 24)) & m
    return c


def random_offset(seed: float) -> tuple:
    """Cycles' random_float3_offset(seed): the shifts between a Noise texture's
    distortion and colour channels (100 + hash_float2_to_float((seed, i)) * 100)."""
    import struct
    bits = struct.unpack("<I", struct.pack("<f", seed))[0]
    out = []
    for i in range(3):
        ky = struct.unpack("<I", struct.pack("<f", float(i)))[0]
        a = b = c = (0xdeadbeef + (2 << 2) + 13) & 0xFFFFFFFF
        b = (b + ky) & 0xFFFFFFFF
        a = (a + bits) & 0xFFFFFFFF
        out.append(100.0 + _final(a, b, c) / 4294967295.0 * 100.0)
    return tuple(out)
