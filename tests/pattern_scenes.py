"""The node-network scenes (docs/materials.md), one per node family, shared by the
Cycles reference script (references/make_pattern_references.py) and by
tests/test_patterns.py. Nothing here is copied elsewhere.

Every scene is a grid of unit quads seen straight down by an orthographic camera, one
material per quad, lit by a sun of strength pi straight down with a black world, so
that (Principled BSDF, Specular IOR Level 0) each pixel is the base colour the
network computes. Cycles renders direct light only (as references/looks/)."""
import math

from reference_scenes import _camera, _mesh_object, _sun, _world

SIZE = (128, 128)
SAMPLES = 64
# Scenes whose quads are images of sharp texels under a pixel filter: fewer samples
# leave Cycles' own noise in the reference (the interpolation families).
SAMPLES_OF = {f"image_{i}": 1024 for i in ("linear", "closest", "cubic", "smart")}
COLUMNS = 5


def _principled(name):
    import bpy
    mat = bpy.data.materials.new(name)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return mat, mat.node_tree, bsdf


def _uv_xyz(tree):
    """(Separate XYZ of the UV coordinates) -> its node."""
    coord = tree.nodes.new("ShaderNodeTexCoord")
    sep = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(coord.outputs["UV"], sep.inputs[0])
    return coord, sep


def _grid(name, builders, columns=COLUMNS, size=SIZE):
    """One quad per (label, build(tree, bsdf)) in a grid of `columns`, rows downwards."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    _world(scene, color=(0.0, 0.0, 0.0), strength=0.0)
    _sun(scene, math.pi)
    rows = (len(builders) + columns - 1) // columns
    for i, (label, build) in enumerate(builders):
        mat, tree, bsdf = _principled(f"{name}_{label}")
        build(tree, bsdf)
        x, y = i % columns, -(i // columns)
        corners = [(x, y - 1, 0), (x + 1, y - 1, 0), (x + 1, y, 0), (x, y, 0)]
        ob = _mesh_object(scene, f"{name}_{label}", corners, [(0, 1, 2, 3)], mat,
                          [(0, 0), (1, 0), (1, 1), (0, 1)])
        if hasattr(build, "mesh"):             # what the network reads off the mesh
            build.mesh(ob.data)
    extent = max(columns, rows)
    centre = (columns / 2.0, -rows / 2.0)
    _camera(scene, (centre[0], centre[1], 10.0), (centre[0], centre[1], 0.0),
            ortho_scale=extent)
    bpy.context.view_layer.update()
    return scene


def _to_base(tree, bsdf, socket):
    tree.links.new(socket, bsdf.inputs["Base Color"])


def _mix_blend(blend):
    def build(tree, bsdf):
        _, sep = _uv_xyz(tree)
        comb = tree.nodes.new("ShaderNodeCombineColor")
        tree.links.new(sep.outputs["X"], comb.inputs[0])
        tree.links.new(sep.outputs["Y"], comb.inputs[1])
        comb.inputs[2].default_value = 0.5
        mix = tree.nodes.new("ShaderNodeMix")
        mix.data_type, mix.blend_type = "RGBA", blend
        mix.inputs["Factor"].default_value = 0.7
        tree.links.new(comb.outputs[0], mix.inputs[6])          # A_Color
        mix.inputs[7].default_value = (0.8, 0.3, 0.1, 1.0)     # B_Color
        _to_base(tree, bsdf, mix.outputs[2])                    # Result_Color
    return build


def _mix_float(tree, bsdf):
    _, sep = _uv_xyz(tree)
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "FLOAT"
    tree.links.new(sep.outputs["X"], mix.inputs[0])             # Factor_Float
    mix.inputs[2].default_value = 0.1                           # A_Float
    mix.inputs[3].default_value = 0.9                           # B_Float
    _to_base(tree, bsdf, mix.outputs[0])


def _mix_vector(tree, bsdf):
    coord, sep = _uv_xyz(tree)
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.factor_mode = "VECTOR", "NON_UNIFORM"
    mix.inputs[1].default_value = (0.2, 0.8, 0.5)               # Factor_Vector
    tree.links.new(coord.outputs["UV"], mix.inputs[4])          # A_Vector
    mix.inputs[5].default_value = (0.9, 0.1, 0.4)               # B_Vector
    _to_base(tree, bsdf, mix.outputs[1])


def build_mix(workdir=None):
    from lantern.core.pattern_nodes import BLEND_TYPES
    return _grid("mix", [(b.lower(), _mix_blend(b)) for b in BLEND_TYPES] +
                 [("float", _mix_float), ("vector", _mix_vector)])


def _math(op, b=0.5, c=0.3):
    def build(tree, bsdf):
        _, sep = _uv_xyz(tree)
        pre = tree.nodes.new("ShaderNodeMath")          # u * 4 - 2 spans [-2, 2]
        pre.operation = "MULTIPLY_ADD"
        tree.links.new(sep.outputs["X"], pre.inputs[0])
        pre.inputs[1].default_value, pre.inputs[2].default_value = 4.0, -2.0
        node = tree.nodes.new("ShaderNodeMath")
        node.operation = op
        tree.links.new(pre.outputs[0], node.inputs[0])
        if b is None:
            tree.links.new(sep.outputs["Y"], node.inputs[1])
        else:
            node.inputs[1].default_value = b
        node.inputs[2].default_value = c
        post = tree.nodes.new("ShaderNodeMath")         # [-2, 2] -> [0, 1]
        post.operation, post.use_clamp = "MULTIPLY_ADD", False
        tree.links.new(node.outputs[0], post.inputs[0])
        post.inputs[1].default_value, post.inputs[2].default_value = 0.25, 0.5
        _to_base(tree, bsdf, post.outputs[0])
    return build


MATH_SHOWN = ["ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "POWER", "LOGARITHM", "SQRT",
              "ABSOLUTE", "MINIMUM", "GREATER_THAN", "SMOOTH_MIN", "ROUND", "FRACT",
              "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG", "SINE", "ARCTAN2",
              "TANH", "COMPARE", "SIGN", "EXPONENT", "INVERSE_SQRT"]


def build_math(workdir=None):
    return _grid("math", [(op.lower(), _math(op, None if op in ("ARCTAN2", "POWER") else 0.7))
                          for op in MATH_SHOWN])


def _vector_math(op):
    def build(tree, bsdf):
        coord, _ = _uv_xyz(tree)
        pre = tree.nodes.new("ShaderNodeVectorMath")    # uv * 2 - 1
        pre.operation = "MULTIPLY_ADD"
        tree.links.new(coord.outputs["UV"], pre.inputs[0])
        pre.inputs[1].default_value, pre.inputs[2].default_value = (2, 2, 2), (-1, -1, 0.5)
        node = tree.nodes.new("ShaderNodeVectorMath")
        node.operation = op
        tree.links.new(pre.outputs[0], node.inputs[0])
        node.inputs[1].default_value = (0.3, -0.6, 0.9)
        node.inputs[2].default_value = (0.5, 0.5, 0.5)
        node.inputs[3].default_value = 0.7
        out = node.outputs[1] if op in ("DOT_PRODUCT", "DISTANCE", "LENGTH") else node.outputs[0]
        post = tree.nodes.new("ShaderNodeVectorMath")
        post.operation = "MULTIPLY_ADD"
        tree.links.new(out, post.inputs[0])
        post.inputs[1].default_value, post.inputs[2].default_value = (0.4,) * 3, (0.5,) * 3
        _to_base(tree, bsdf, post.outputs[0])
    return build


VECTOR_MATH_SHOWN = ["ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "CROSS_PRODUCT", "PROJECT",
                     "REFLECT", "DOT_PRODUCT", "DISTANCE", "LENGTH", "SCALE", "NORMALIZE",
                     "SNAP", "FLOOR", "MODULO", "WRAP", "FRACTION", "ABSOLUTE", "MINIMUM",
                     "MAXIMUM", "SINE", "COSINE", "CEIL", "SIGN", "MULTIPLY_ADD", "REFRACT",
                     "FACEFORWARD", "POWER", "TANGENT"]


def build_vector_math(workdir=None):
    return _grid("vector_math", [(op.lower(), _vector_math(op)) for op in VECTOR_MATH_SHOWN])


def _uv_mapping(tree, vector_type, location, rotation, scale):
    """Texture Coordinate UV through a Mapping node (Location only where the type has it)."""
    coord = tree.nodes.new("ShaderNodeTexCoord")
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.vector_type = vector_type
    tree.links.new(coord.outputs["UV"], mapping.inputs["Vector"])
    if vector_type in ("POINT", "TEXTURE"):
        mapping.inputs["Location"].default_value = location
    mapping.inputs["Rotation"].default_value = rotation
    mapping.inputs["Scale"].default_value = scale
    return mapping


def _mapped_checker(vector_type, scale=4.0):
    def build(tree, bsdf):
        mapping = _uv_mapping(tree, vector_type, (0.13, 0.27, 0.0), (0.0, 0.0, 0.5),
                              (1.3, 0.8, 1.0))
        checker = tree.nodes.new("ShaderNodeTexChecker")
        checker.inputs["Scale"].default_value = scale
        checker.inputs["Color1"].default_value = (0.9, 0.8, 0.2, 1.0)
        checker.inputs["Color2"].default_value = (0.1, 0.2, 0.6, 1.0)
        tree.links.new(mapping.outputs[0], checker.inputs["Vector"])
        _to_base(tree, bsdf, checker.outputs["Color"])
    return build


def _plain_checker(scale):
    def build(tree, bsdf):
        coord = tree.nodes.new("ShaderNodeTexCoord")
        checker = tree.nodes.new("ShaderNodeTexChecker")
        checker.inputs["Scale"].default_value = scale
        tree.links.new(coord.outputs["UV"], checker.inputs["Vector"])
        _to_base(tree, bsdf, checker.outputs["Color"])
    return build


def _mapped_gradient(vector_type):
    """The mapped coordinates themselves as colour (fract), where a checker would hide
    a small offset."""
    def build(tree, bsdf):
        mapping = _uv_mapping(tree, vector_type, (0.13, 0.27, 0.1), (0.2, 0.3, 0.5),
                              (1.3, 0.8, 1.2))
        frac = tree.nodes.new("ShaderNodeVectorMath")
        frac.operation = "FRACTION"
        tree.links.new(mapping.outputs[0], frac.inputs[0])
        _to_base(tree, bsdf, frac.outputs[0])
    return build


def build_mapping(workdir=None):
    types = ("POINT", "TEXTURE", "VECTOR", "NORMAL")
    return _grid("mapping", [(f"checker_{t.lower()}", _mapped_checker(t)) for t in types] +
                 [(f"coords_{t.lower()}", _mapped_gradient(t)) for t in types] +
                 [("checker_3", _plain_checker(3.0)), ("checker_7", _plain_checker(7.0))])


def _ramp(interpolation):
    def build(tree, bsdf):
        _, sep = _uv_xyz(tree)
        ramp = tree.nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.interpolation = interpolation
        els = ramp.color_ramp.elements
        els[0].position, els[0].color = 0.1, (0.9, 0.1, 0.1, 1.0)
        els[1].position, els[1].color = 0.9, (0.1, 0.2, 0.9, 1.0)
        mid = els.new(0.45)
        mid.color = (0.2, 0.9, 0.3, 1.0)
        tree.links.new(sep.outputs["X"], ramp.inputs["Fac"])
        _to_base(tree, bsdf, ramp.outputs["Color"])
    return build


def _ramp_alpha_to_roughness(tree, bsdf):
    _, sep = _uv_xyz(tree)
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    els = ramp.color_ramp.elements
    els[0].color, els[1].color = (0.2, 0.2, 0.2, 0.2), (0.8, 0.8, 0.8, 0.9)
    tree.links.new(sep.outputs["Y"], ramp.inputs["Fac"])
    tree.links.new(ramp.outputs["Alpha"], bsdf.inputs["Base Color"])


def build_color_ramp(workdir=None):
    return _grid("color_ramp", [(i.lower(), _ramp(i)) for i in ("LINEAR", "CONSTANT", "EASE")] +
                 [("alpha", _ramp_alpha_to_roughness)])


def _uv_color(tree):
    _, sep = _uv_xyz(tree)
    comb = tree.nodes.new("ShaderNodeCombineColor")
    tree.links.new(sep.outputs["X"], comb.inputs[0])
    tree.links.new(sep.outputs["Y"], comb.inputs[1])
    comb.inputs[2].default_value = 0.4
    return comb.outputs[0]


def _rgb_value(tree, bsdf):
    rgb = tree.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (0.7, 0.35, 0.1, 1.0)
    value = tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 0.6
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
    tree.links.new(_uv_color(tree), mix.inputs[0])   # colour -> float factor (luminance)
    tree.links.new(rgb.outputs[0], mix.inputs[6])
    tree.links.new(value.outputs[0], mix.inputs[7])
    _to_base(tree, bsdf, mix.outputs[2])


def _invert(tree, bsdf):
    inv = tree.nodes.new("ShaderNodeInvert")
    inv.inputs["Fac"].default_value = 0.8
    tree.links.new(_uv_color(tree), inv.inputs["Color"])
    _to_base(tree, bsdf, inv.outputs[0])


def _hsv(hue, sat, val):
    def build(tree, bsdf):
        node = tree.nodes.new("ShaderNodeHueSaturation")
        node.inputs["Hue"].default_value = hue
        node.inputs["Saturation"].default_value = sat
        node.inputs["Value"].default_value = val
        tree.links.new(_uv_color(tree), node.inputs["Color"])
        _to_base(tree, bsdf, node.outputs[0])
    return build


def _separate_combine(mode):
    def build(tree, bsdf):
        sep = tree.nodes.new("ShaderNodeSeparateColor")
        sep.mode = mode
        tree.links.new(_uv_color(tree), sep.inputs[0])
        comb = tree.nodes.new("ShaderNodeCombineColor")
        comb.mode = mode
        tree.links.new(sep.outputs[2], comb.inputs[0])     # rotate the channels
        tree.links.new(sep.outputs[0], comb.inputs[1])
        tree.links.new(sep.outputs[1], comb.inputs[2])
        _to_base(tree, bsdf, comb.outputs[0])
    return build


def _xyz_to_float(tree, bsdf):
    """Combine XYZ into a float socket (Blender's vector -> float average)."""
    _, sep = _uv_xyz(tree)
    comb = tree.nodes.new("ShaderNodeCombineXYZ")
    tree.links.new(sep.outputs["Y"], comb.inputs[0])
    tree.links.new(sep.outputs["X"], comb.inputs[1])
    comb.inputs[2].default_value = 0.9
    math_node = tree.nodes.new("ShaderNodeMath")
    math_node.operation = "MULTIPLY"
    tree.links.new(comb.outputs[0], math_node.inputs[0])
    math_node.inputs[1].default_value = 1.0
    _to_base(tree, bsdf, math_node.outputs[0])


def build_color(workdir=None):
    return _grid("color", [
        ("rgb_value", _rgb_value), ("invert", _invert),
        ("hsv_hue", _hsv(0.3, 1.0, 1.0)), ("hsv_sat", _hsv(0.5, 1.8, 0.9)),
        ("hsv_val", _hsv(0.5, 0.4, 1.3)), ("sep_comb_rgb", _separate_combine("RGB")),
        ("sep_comb_hsv", _separate_combine("HSV")), ("xyz_float", _xyz_to_float)])


def family_builders():
    """Every quad builder of the six family scenes: (label, build)."""
    from lantern.core.pattern_nodes import BLEND_TYPES
    return ([(b.lower(), _mix_blend(b)) for b in BLEND_TYPES] +
            [("float", _mix_float), ("vector", _mix_vector)] +
            [(op.lower(), _math(op, None if op in ("ARCTAN2", "POWER") else 0.7))
             for op in MATH_SHOWN] +
            [(op.lower(), _vector_math(op)) for op in VECTOR_MATH_SHOWN] +
            [(t.lower(), _mapped_checker(t)) for t in ("POINT", "TEXTURE", "VECTOR", "NORMAL")] +
            [(i.lower(), _ramp(i)) for i in ("LINEAR", "CONSTANT", "EASE")] +
            [("invert", _invert), ("rgb_value", _rgb_value), ("hsv", _hsv(0.3, 1.2, 0.9)),
             ("sep_comb_hsv", _separate_combine("HSV"))])


def _gradient(gradient_type, centred=True):
    def build(tree, bsdf):
        node = tree.nodes.new("ShaderNodeTexGradient")
        node.gradient_type = gradient_type
        if centred:                                   # UV to [-1, 1]
            mapping = _uv_mapping(tree, "POINT", (-1.0, -1.0, 0.0), (0.0, 0.0, 0.0),
                                  (2.0, 2.0, 1.0))
            tree.links.new(mapping.outputs[0], node.inputs["Vector"])
        _to_base(tree, bsdf, node.outputs["Color"])
    return build


def build_gradient(workdir=None):
    """Every gradient type on centred UVs, and Linear with its Vector unlinked (Blender's
    Generated coordinates, which on these quads equal the UVs)."""
    from lantern.core.pattern_nodes import GRADIENT_TYPES
    return _grid("gradient", [(t.lower(), _gradient(t)) for t in GRADIENT_TYPES] +
                 [("linear_generated", _gradient("LINEAR", centred=False))])


def _emission_shader(tree, bsdf):
    """An Emission shader (strength 2) whose colour is a network."""
    out = tree.nodes["Material Output"]
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 2.0
    tree.links.new(_uv_color(tree), emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])


def _principled_emission(tree, bsdf):
    """A Principled BSDF's Emission Color from a network, strength 1.5, over a dark base."""
    bsdf.inputs["Base Color"].default_value = (0.1, 0.1, 0.1, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 1.5
    inv = tree.nodes.new("ShaderNodeInvert")
    tree.links.new(_uv_color(tree), inv.inputs["Color"])
    tree.links.new(inv.outputs[0], bsdf.inputs["Emission Color"])


def _emission_from_float(tree, bsdf):
    """A float output (Math) into Emission Color: Blender's float -> colour splat."""
    _, sep = _uv_xyz(tree)
    node = tree.nodes.new("ShaderNodeMath")
    node.operation = "MULTIPLY"
    tree.links.new(sep.outputs["X"], node.inputs[0])
    node.inputs[1].default_value = 0.5
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 1.0
    tree.links.new(node.outputs[0], bsdf.inputs["Emission Color"])


def build_emission(workdir=None):
    return _grid("emission", [("shader", _emission_shader), ("principled", _principled_emission),
                              ("float", _emission_from_float)])


def _noise(output="Fac", scale=5.0, detail=2.0, roughness=0.5, distortion=0.0,
           normalize=True):
    def build(tree, bsdf):
        coord = tree.nodes.new("ShaderNodeTexCoord")
        node = tree.nodes.new("ShaderNodeTexNoise")
        node.normalize = normalize
        node.inputs["Scale"].default_value = scale
        node.inputs["Detail"].default_value = detail
        node.inputs["Roughness"].default_value = roughness
        node.inputs["Distortion"].default_value = distortion
        tree.links.new(coord.outputs["UV"], node.inputs["Vector"])
        _to_base(tree, bsdf, node.outputs[output])
    return build


def build_noise(workdir=None):
    """Blender's Perlin fBm: the defaults, its colour, fractional and zero detail,
    distortion, and unnormalised (scaled into range by the base colour's clamp)."""
    return _grid("noise", [("default", _noise()), ("color", _noise("Color")),
                           ("detail_0", _noise(detail=0.0, scale=3.0)),
                           ("detail_3_7", _noise(detail=3.7, roughness=0.6)),
                           ("distortion", _noise("Color", distortion=1.5, scale=2.0)),
                           ("coarse", _noise(scale=1.5, detail=0.0))])


def _wave(wave_type="BANDS", direction="X", profile="SIN", distortion=0.0, scale=2.0):
    def build(tree, bsdf):
        coord = tree.nodes.new("ShaderNodeTexCoord")
        node = tree.nodes.new("ShaderNodeTexWave")
        node.wave_type, node.wave_profile = wave_type, profile
        if wave_type == "BANDS":
            node.bands_direction = direction
        else:
            node.rings_direction = direction
        node.inputs["Scale"].default_value = scale
        node.inputs["Distortion"].default_value = distortion
        node.inputs["Phase Offset"].default_value = 0.7
        tree.links.new(coord.outputs["UV"], node.inputs["Vector"])
        _to_base(tree, bsdf, node.outputs["Color"])
    return build


def build_wave(workdir=None):
    return _grid("wave", [("bands_x", _wave()), ("bands_y_saw", _wave(direction="Y", profile="SAW")),
                          ("bands_diagonal_tri", _wave(direction="DIAGONAL", profile="TRI")),
                          ("rings_spherical", _wave("RINGS", "SPHERICAL")),
                          ("rings_z_saw", _wave("RINGS", "Z", "SAW", scale=1.0)),
                          ("bands_distorted", _wave(distortion=3.0, scale=1.0))])


def _voronoi(output="Distance", metric="EUCLIDEAN", detail=0.0, scale=4.0, randomness=1.0):
    def build(tree, bsdf):
        coord = tree.nodes.new("ShaderNodeTexCoord")
        node = tree.nodes.new("ShaderNodeTexVoronoi")
        node.distance = metric
        node.inputs["Scale"].default_value = scale
        node.inputs["Detail"].default_value = detail
        node.inputs["Randomness"].default_value = randomness
        tree.links.new(coord.outputs["UV"], node.inputs["Vector"])
        out = node.outputs[output]
        if output == "Position":                    # into [0, 1)
            frac = tree.nodes.new("ShaderNodeVectorMath")
            frac.operation = "FRACTION"
            tree.links.new(out, frac.inputs[0])
            out = frac.outputs[0]
        _to_base(tree, bsdf, out)
    return build


def build_voronoi(workdir=None):
    return _grid("voronoi", [("distance", _voronoi()), ("color", _voronoi("Color")),
                             ("position", _voronoi("Position", scale=2.0)),
                             ("manhattan", _voronoi(metric="MANHATTAN")),
                             ("chebychev", _voronoi(metric="CHEBYCHEV", randomness=0.6)),
                             ("minkowski", _voronoi(metric="MINKOWSKI")),
                             ("detail_1_5", _voronoi("Color", detail=1.5, scale=2.0))])


def _alpha(method, source):
    """Alpha from a network, over the black world: Blended or Dithered render method."""
    def build(tree, bsdf):
        bsdf.inputs["Base Color"].default_value = (0.8, 0.5, 0.2, 1.0)
        tree.links.new(source(tree), bsdf.inputs["Alpha"])
        import bpy
        next(m for m in bpy.data.materials if m.node_tree == tree).surface_render_method = method
    return build


def _alpha_gradient(tree):
    node = tree.nodes.new("ShaderNodeTexGradient")
    return node.outputs["Fac"]


def _alpha_checker(tree):
    coord = tree.nodes.new("ShaderNodeTexCoord")
    node = tree.nodes.new("ShaderNodeTexChecker")
    node.inputs["Scale"].default_value = 3.0
    node.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1.0)
    node.inputs["Color2"].default_value = (0.3, 0.3, 0.3, 1.0)
    tree.links.new(coord.outputs["UV"], node.inputs["Vector"])
    return node.outputs["Fac"]


def _transparent_mix(slot, factor, alpha=1.0):
    """A Mix Shader of a Transparent BSDF (in shader slot `slot`) and the Principled BSDF
    (base 0.8, 0.5, 0.2; its own Alpha `alpha`), Blended; `factor` a constant or a
    function(tree) giving the socket feeding the Mix's factor."""
    def build(tree, bsdf):
        import bpy
        bsdf.inputs["Base Color"].default_value = (0.8, 0.5, 0.2, 1.0)
        bsdf.inputs["Alpha"].default_value = alpha
        output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
        mix = tree.nodes.new("ShaderNodeMixShader")
        transparent = tree.nodes.new("ShaderNodeBsdfTransparent")
        shaders = [transparent.outputs[0], bsdf.outputs["BSDF"]]
        if slot == 1:
            shaders.reverse()
        tree.links.new(shaders[0], mix.inputs[1])
        tree.links.new(shaders[1], mix.inputs[2])
        tree.links.new(mix.outputs[0], output.inputs["Surface"])
        if callable(factor):
            tree.links.new(factor(tree), mix.inputs[0])
        else:
            mix.inputs[0].default_value = factor
        next(m for m in bpy.data.materials if m.node_tree == tree).surface_render_method = "BLENDED"
    return build


def _shader_pair(kind, second, first_color, factor=None, specular=None):
    """A Mix Shader (by `factor`: a constant, or function(tree) -> socket) or an Add
    Shader (`kind`) of the Principled BSDF (base `first_color`, its Specular IOR Level
    `specular` where given) and a second BSDF made by `second(tree)`."""
    def build(tree, bsdf):
        bsdf.inputs["Base Color"].default_value = first_color
        if specular is not None:
            bsdf.inputs["Specular IOR Level"].default_value = specular
        output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
        node = tree.nodes.new(kind)
        slots = [socket for socket in node.inputs if socket.type == "SHADER"]
        tree.links.new(bsdf.outputs["BSDF"], slots[0])
        tree.links.new(second(tree), slots[1])
        tree.links.new(node.outputs[0], output.inputs["Surface"])
        if callable(factor):
            tree.links.new(factor(tree), node.inputs[0])
        elif factor is not None:
            node.inputs[0].default_value = factor
    return build


def _bsdf_mix(factor, second, first_color=(0.8, 0.2, 0.1, 1.0)):
    return _shader_pair("ShaderNodeMixShader", second, first_color, factor=factor)


def _bsdf_add(second, first_color=(0.4, 0.1, 0.05, 1.0), specular=0.0):
    return _shader_pair("ShaderNodeAddShader", second, first_color, specular=specular)


def _second_principled(color=(0.1, 0.3, 0.9, 1.0), metallic=0.0, textured=False):
    def second(tree):
        node = tree.nodes.new("ShaderNodeBsdfPrincipled")
        node.inputs["Roughness"].default_value = 1.0
        node.inputs["Specular IOR Level"].default_value = 0.0
        node.inputs["Base Color"].default_value = color
        node.inputs["Metallic"].default_value = metallic
        if textured:
            tree.links.new(_image(tree).outputs["Color"], node.inputs["Base Color"])
        return node.outputs["BSDF"]
    return second


def _second_diffuse(tree):
    node = tree.nodes.new("ShaderNodeBsdfDiffuse")
    node.inputs["Color"].default_value = (0.2, 0.8, 0.3, 1.0)
    return node.outputs["BSDF"]


def build_mix_shader(workdir=None):
    """Mix Shaders of two BSDFs, input by input: base colours by a constant and by a
    network, metal against dielectric, an image against a colour, a Diffuse BSDF; and
    Add Shaders of two BSDFs (twice their even mix)."""
    return _grid("mix_shader", [
        ("colors", _bsdf_mix(0.3, _second_principled())),
        ("network", _bsdf_mix(_alpha_gradient, _second_principled())),
        ("metal", _bsdf_mix(0.5, _second_principled((0.9, 0.7, 0.3, 1.0), metallic=1.0),
                            (0.9, 0.7, 0.3, 1.0))),
        ("image", _bsdf_mix(0.4, _second_principled(textured=True))),
        ("diffuse", _bsdf_mix(0.6, _second_diffuse)),
        ("add_colors", _bsdf_add(_second_principled((0.1, 0.2, 0.4, 1.0)))),
        ("add_diffuse", _bsdf_add(_second_diffuse)),
        ("add_image", _bsdf_add(_second_principled(textured=True))),
        ("add_metal", _bsdf_add(_second_principled((0.4, 0.3, 0.1, 1.0), metallic=1.0),
                                (0.4, 0.3, 0.1, 1.0)))])


def build_transparent(workdir=None):
    """The Transparent BSDF mixed with another shader: the surface's opacity (as the
    Principled BSDF's Alpha), constant or from a network, in either shader slot."""
    return _grid("transparent", [("constant_first", _transparent_mix(0, 0.35)),
                                 ("constant_second", _transparent_mix(1, 0.35)),
                                 ("network_first", _transparent_mix(0, _alpha_gradient)),
                                 ("network_second", _transparent_mix(1, _alpha_gradient)),
                                 ("over_alpha", _transparent_mix(0, 0.5, alpha=0.6))])


def build_alpha(workdir=None):
    return _grid("alpha", [("gradient_blended", _alpha("BLENDED", _alpha_gradient)),
                           ("gradient_dithered", _alpha("DITHERED", _alpha_gradient)),
                           ("checker_blended", _alpha("BLENDED", _alpha_checker))])


def _image_file(second=False):
    """A 16 x 16 8-bit sRGB PNG: a colour gradient with a dark checker, or (`second`)
    green and magenta stripes (one file each a process, in the temporary folder)."""
    import os
    import tempfile
    import numpy as np
    from reference_scenes import _write_image
    name = "stripes" if second else "image"
    path = os.path.join(tempfile.gettempdir(), f"lantern-pattern-{name}-{os.getpid()}.png")
    if not os.path.exists(path):
        y, x = np.mgrid[0:16, 0:16]
        if second:
            stripe = (y // 2) % 2 == 1
            rgba = np.stack([np.where(stripe, 220, 30), np.where(stripe, 40, 200),
                             np.where(stripe, 200, 60), np.full_like(x, 255)], -1)
        else:
            rgba = np.stack([x * 16, y * 16, 255 - x * 8, np.full_like(x, 255)], -1)
            rgba[((x // 4 + y // 4) % 2) == 1, :3] //= 3
        _write_image(path, rgba.astype(np.uint8))
    return path


def _image(tree, extension="REPEAT", second=False):
    import bpy
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = bpy.data.images.load(_image_file(second), check_existing=True)
    node.extension = extension
    return node


def _image_multiplied(tree, bsdf):
    """Image x colour (Mix Multiply): the glTF importer's vertex-colour-free tint."""
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
    mix.inputs[0].default_value = 1.0
    tree.links.new(_image(tree).outputs["Color"], mix.inputs[6])
    mix.inputs[7].default_value = (1.0, 0.6, 0.3, 1.0)
    _to_base(tree, bsdf, mix.outputs[2])


def _image_mapped(tree, bsdf):
    """A mapped, rotated image, mirrored, through Hue/Saturation/Value."""
    mapping = _uv_mapping(tree, "POINT", (0.1, 0.2, 0.0), (0.0, 0.0, 0.4), (2.0, 1.5, 1.0))
    image = _image(tree, "MIRROR")
    tree.links.new(mapping.outputs[0], image.inputs["Vector"])
    hsv = tree.nodes.new("ShaderNodeHueSaturation")
    hsv.inputs["Hue"].default_value = 0.7
    tree.links.new(image.outputs["Color"], hsv.inputs["Color"])
    _to_base(tree, bsdf, hsv.outputs[0])


def _image_mapping_only(tree, bsdf):
    """Image <- Mapping straight on Base Color (the corpus's "Mapping is ignored" case)."""
    mapping = _uv_mapping(tree, "TEXTURE", (0.25, 0.0, 0.0), (0.0, 0.0, 0.3), (0.5, 0.7, 1.0))
    image = _image(tree)
    tree.links.new(mapping.outputs[0], image.inputs["Vector"])
    _to_base(tree, bsdf, image.outputs["Color"])


def _two_images(tree, bsdf):
    """Two images in one network (Mix, factor 0.4): each reads its own file."""
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.inputs[0].default_value = 0.4
    tree.links.new(_image(tree).outputs["Color"], mix.inputs[6])
    tree.links.new(_image(tree, second=True).outputs["Color"], mix.inputs[7])
    _to_base(tree, bsdf, mix.outputs[2])


def build_image(workdir=None):
    return _grid("image", [("multiplied", _image_multiplied), ("mapped", _image_mapped),
                           ("mapping_only", _image_mapping_only), ("two_images", _two_images)])


def _pixel_art_file():
    """A 16 x 16 8-bit sRGB PNG of pixel art: each texel its own colour (a hash of its
    position), so that every interpolation shows (in the temporary folder, one a
    process)."""
    import os
    import tempfile
    import numpy as np
    from reference_scenes import _write_image
    path = os.path.join(tempfile.gettempdir(), f"lantern-pattern-pixels-{os.getpid()}.png")
    if not os.path.exists(path):
        y, x = np.mgrid[0:16, 0:16]
        h = (x * 73 + y * 151 + (x * y) % 7 * 37) % 256
        rgba = np.stack([h, (h * 5 + 80) % 256, (255 - h + x * 9) % 256,
                         np.full_like(h, 255)], -1)
        _write_image(path, rgba.astype(np.uint8))
    return path


def _pixel_art(tree, interpolation, extension="REPEAT"):
    import bpy
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = bpy.data.images.load(_pixel_art_file(), check_existing=True)
    node.interpolation, node.extension = interpolation, extension
    return node


def _uv_square(u0, v0, size):
    """Mesh hook: the quad's UVs a square of `size` at (u0, v0)."""
    def mesh(me):
        corners = [(u0, v0), (u0 + size, v0), (u0 + size, v0 + size), (u0, v0 + size)]
        for loop, uv in zip(me.uv_layers.active.data, corners):
            loop.uv = uv
    return mesh


def _straight_image(interpolation, u0, v0, size):
    """The image straight on Base Color (a UsdUVTexture), the quad's UVs a square of
    `size` texel-widths of the image / 16 at (u0, v0)."""
    def build(tree, bsdf):
        _to_base(tree, bsdf, _pixel_art(tree, interpolation).outputs["Color"])
    build.mesh = _uv_square(u0, v0, size)
    return build


def _network_image(interpolation, scale, extension="REPEAT"):
    """The image through a Mapping node (rotated 30 degrees, scaled) and a Hue/Saturation
    and an Invert node: a network's image (the issue's "through a Mapping node")."""
    def build(tree, bsdf):
        mapping = _uv_mapping(tree, "POINT", (0.13, 0.27, 0.0), (0.0, 0.0, 0.5236),
                              (scale, scale, 1.0))
        image = _pixel_art(tree, interpolation, extension)
        tree.links.new(mapping.outputs[0], image.inputs["Vector"])
        hsv = tree.nodes.new("ShaderNodeHueSaturation")
        hsv.inputs["Hue"].default_value = 0.8
        tree.links.new(image.outputs["Color"], hsv.inputs["Color"])
        invert = tree.nodes.new("ShaderNodeInvert")
        invert.inputs["Fac"].default_value = 0.25
        tree.links.new(hsv.outputs[0], invert.inputs["Color"])
        _to_base(tree, bsdf, invert.outputs[0])
    return build


def build_interpolation(interpolation):
    """One Image Texture interpolation (Blender's Linear, Closest, Cubic, Smart) on a
    16 x 16 image of pixel art: straight on Base Color magnified 6.4 times and minified
    1.9 times, and in a network (Mapping, Hue/Saturation, Invert) magnified 5.3 times
    (mirrored) and minified 1.9 times."""
    def build(workdir=None):
        return _grid(f"image_{interpolation.lower()}", [
            ("magnified", _straight_image(interpolation, 0.3, 0.45, 0.25)),
            ("minified", _straight_image(interpolation, 0.1, 0.2, 3.0)),
            ("network_magnified", _network_image(interpolation, 0.3, "MIRROR")),
            ("network_minified", _network_image(interpolation, 3.0))])
    return build


INTERPOLATIONS = ("Linear", "Closest", "Cubic", "Smart")


def _mapped_image(interpolation, u0, v0, size):
    """The image through a Mapping node that changes nothing (the exporter writes a
    network for it, as for any Mapping), the quad's UVs as _straight_image's."""
    def build(tree, bsdf):
        mapping = _uv_mapping(tree, "POINT", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
        image = _pixel_art(tree, interpolation)
        tree.links.new(mapping.outputs[0], image.inputs["Vector"])
        _to_base(tree, bsdf, image.outputs["Color"])
    build.mesh = _uv_square(u0, v0, size)
    return build


def build_interpolation_paths(interpolation):
    """One interpolation both ways, side by side: the image straight on Base Color (a
    UsdUVTexture) and in a network (behind a Mapping node that changes nothing), the
    same UVs, magnified (top row) and minified (bottom row). No Cycles reference: the
    two columns should be the same picture."""
    def build(workdir=None):
        return _grid(f"paths_{interpolation.lower()}", [
            ("straight_magnified", _straight_image(interpolation, 0.3, 0.45, 0.25)),
            ("network_magnified", _mapped_image(interpolation, 0.3, 0.45, 0.25)),
            ("straight_minified", _straight_image(interpolation, 0.1, 0.2, 3.0)),
            ("network_minified", _mapped_image(interpolation, 0.1, 0.2, 3.0))], columns=2)
    return build


def _height(kind, scale):
    """A height for the Bump node: Noise's Fac, Wave bands' Fac or a linear Gradient, on
    the UV coordinates."""
    def height(tree):
        coord = tree.nodes.new("ShaderNodeTexCoord")
        node = tree.nodes.new({"noise": "ShaderNodeTexNoise", "wave": "ShaderNodeTexWave",
                               "gradient": "ShaderNodeTexGradient"}[kind])
        if kind != "gradient":
            node.inputs["Scale"].default_value = scale
        tree.links.new(coord.outputs["UV"], node.inputs["Vector"])
        return node.outputs["Fac"]
    return height


def _bump(height, distance, strength=1.0, invert=False):
    """Height -> Bump -> the Principled BSDF's Normal, base colour 0.8: under the sun
    overhead a pixel is 0.8 x the cosine of the bumped normal's tilt."""
    def build(tree, bsdf):
        bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
        bump = tree.nodes.new("ShaderNodeBump")
        bump.invert = invert
        bump.inputs["Distance"].default_value = distance
        bump.inputs["Strength"].default_value = strength
        tree.links.new(height(tree), bump.inputs["Height"])
        tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    return build


def _chained_bump(tree, bsdf):
    """Wave bands bumped, on a noise bump (the outer Bump's Normal is the inner's)."""
    bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    inner, outer = tree.nodes.new("ShaderNodeBump"), tree.nodes.new("ShaderNodeBump")
    inner.inputs["Distance"].default_value = 0.05
    outer.inputs["Distance"].default_value = 0.02
    tree.links.new(_height("noise", 5.0)(tree), inner.inputs["Height"])
    tree.links.new(_height("wave", 2.0)(tree), outer.inputs["Height"])
    tree.links.new(inner.outputs["Normal"], outer.inputs["Normal"])
    tree.links.new(outer.outputs["Normal"], bsdf.inputs["Normal"])


def _network_normal_map(strength):
    """The image through a Mapping node, as a tangent-space normal map (Non-Color)."""
    def build(tree, bsdf):
        bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
        mapping = _uv_mapping(tree, "POINT", (0.1, 0.2, 0.0), (0.0, 0.0, 0.3), (0.5, 0.5, 1.0))
        image = _image(tree)
        image.image.colorspace_settings.name = "Non-Color"
        tree.links.new(mapping.outputs[0], image.inputs["Vector"])
        normal_map = tree.nodes.new("ShaderNodeNormalMap")
        normal_map.inputs["Strength"].default_value = strength
        tree.links.new(image.outputs["Color"], normal_map.inputs["Color"])
        tree.links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    return build


def _colors(mesh):
    """Two colour attributes on a quad: "Col" per corner (8-bit, the render one, with
    its own alpha) and "Paint" per point (float); each corner or point its own colour."""
    col = mesh.color_attributes.new("Col", "BYTE_COLOR", "CORNER")
    for i, c in enumerate([(0.9, 0.1, 0.1, 0.2), (0.1, 0.8, 0.2, 0.5), (0.2, 0.3, 0.9, 0.8),
                           (0.9, 0.8, 0.1, 1)]):
        col.data[i].color = c
    paint = mesh.color_attributes.new("Paint", "FLOAT_COLOR", "POINT")
    for i, c in enumerate([(0.05, 0.6, 0.9, 1), (0.8, 0.05, 0.7, 1), (0.3, 0.9, 0.1, 1),
                           (1.5, 1.2, 0.2, 1)]):
        paint.data[i].color = c
    mesh.color_attributes.render_color_index = mesh.color_attributes.find("Col")
    # Attributes of other types an Attribute node reads: a float per face, a vector per
    # point (and the quad's UV map, a 2D vector per corner).
    mesh.attributes.new("weight", "FLOAT", "FACE").data[0].value = 0.35
    offset = mesh.attributes.new("offset", "FLOAT_VECTOR", "POINT")
    for i, v in enumerate([(0.1, 0.5, 0.9), (0.9, 0.2, 0.1), (0.4, 0.9, 0.3), (0.7, 0.7, 0.2)]):
        offset.data[i].vector = v


def _attribute(node_type, name, output="Color"):
    """A Color Attribute (or Attribute) node's output on Base Color."""
    def build(tree, bsdf):
        node = tree.nodes.new(node_type)
        if node_type == "ShaderNodeVertexColor":
            node.layer_name = name
        else:
            node.attribute_name = name
        _to_base(tree, bsdf, node.outputs[output])
    build.mesh = _colors
    return build


def build_attribute(workdir=None):
    """Attributes read by networks: the render colour one and a named one, per corner
    and per point, 8-bit and float, through the Color Attribute and Attribute nodes; a
    UV map, a float per face and a vector per point through the Attribute node."""
    return _grid("attribute", [
        ("render", _attribute("ShaderNodeVertexColor", "")),
        ("named_point", _attribute("ShaderNodeVertexColor", "Paint")),
        ("attribute_color", _attribute("ShaderNodeAttribute", "Col")),
        ("attribute_fac", _attribute("ShaderNodeAttribute", "Paint", "Fac")),
        ("uv_map", _attribute("ShaderNodeAttribute", "UVMap")),
        ("float_face", _attribute("ShaderNodeAttribute", "weight", "Fac")),
        ("vector_point", _attribute("ShaderNodeAttribute", "offset", "Vector")),
        ("render_alpha", _attribute("ShaderNodeVertexColor", "", "Alpha"))])


def _unlinked(node_type, output="Color", **inputs):
    """A texture whose Vector is unlinked: Blender's Generated coordinates."""
    def build(tree, bsdf):
        node = tree.nodes.new(node_type)
        if node_type == "ShaderNodeTexGradient":
            node.gradient_type = inputs.pop("gradient_type", "LINEAR")
        for name, value in inputs.items():
            node.inputs[name].default_value = value
        _to_base(tree, bsdf, node.outputs[output])
    return build


def _generated_z(tree, bsdf):
    """Texture Coordinate's Generated, its Z (0.5 on a flat quad) into the blue."""
    coord = tree.nodes.new("ShaderNodeTexCoord")
    _to_base(tree, bsdf, coord.outputs["Generated"])


def build_generated(workdir=None):
    """Generated coordinates (the textures' default, and Texture Coordinate's output):
    on a flat quad they differ from UV in Z (0.5, where UV has 0)."""
    return _grid("generated", [
        ("spherical", _unlinked("ShaderNodeTexGradient", "Fac", gradient_type="SPHERICAL")),
        ("noise", _unlinked("ShaderNodeTexNoise", "Color", Scale=3.0)),
        ("checker", _unlinked("ShaderNodeTexChecker", "Color", Scale=3.0)),
        ("wave_rings", _unlinked("ShaderNodeTexWave", "Color")),
        ("coordinates", _generated_z)])


def build_bump(workdir=None):
    """Networks that bend the shading normal: Bump on procedural heights (Cycles'
    surface gradient), and a Normal Map whose image goes through a Mapping node."""
    return _grid("bump", [("noise", _bump(_height("noise", 5.0), 0.05)),
                          ("noise_half", _bump(_height("noise", 5.0), 0.05, strength=0.5)),
                          ("wave_invert", _bump(_height("wave", 2.0), 0.03, invert=True)),
                          ("gradient", _bump(_height("gradient", 1.0), 0.5)),
                          ("chained", _chained_bump),
                          ("normal_map", _network_normal_map(1.0)),
                          ("normal_map_half", _network_normal_map(0.5))])


UDIM_TILES = (1001, 1002, 1011)


def _udim_image():
    """A UDIM image of three 16 x 16 8-bit sRGB tiles (1001, 1002, 1011), each its own
    gradient and checker, as files `lantern-udim-<pid>.<tile>.png` in the temporary
    folder, loaded as Blender does (source Tiled: it finds the tiles on disk)."""
    import os
    import tempfile
    import bpy
    import numpy as np
    from reference_scenes import _write_image
    stem = os.path.join(tempfile.gettempdir(), f"lantern-udim-{os.getpid()}")
    for k, tile in enumerate(UDIM_TILES):
        path = f"{stem}.{tile}.png"
        if not os.path.exists(path):
            y, x = np.mgrid[0:16, 0:16]
            channels = [x * 16, y * 16, 255 - x * 8]
            rgba = np.stack(channels[k:] + channels[:k] + [np.full_like(x, 255)], -1)
            rgba[((x // (2 + 2 * k) + y // 4) % 2) == 1, :3] //= 3
            _write_image(path, rgba.astype(np.uint8))
    image = bpy.data.images.load(f"{stem}.1001.png", check_existing=True)
    image.source = "TILED"
    return image


def _udim(u0, v0, size=1.0):
    """The UDIM image straight on Base Color, the quad's UVs a square of `size` at
    (u0, v0): inside tile 1001 + floor(u0) + 10 floor(v0)."""
    def build(tree, bsdf):
        node = tree.nodes.new("ShaderNodeTexImage")
        node.image = _udim_image()
        _to_base(tree, bsdf, node.outputs["Color"])

    def mesh(me):
        corners = [(u0, v0), (u0 + size, v0), (u0 + size, v0 + size), (u0, v0 + size)]
        for loop, uv in zip(me.uv_layers.active.data, corners):
            loop.uv = uv
    build.mesh = mesh
    return build


def build_udim(workdir=None):
    """An image of UDIM tiles on Base Color: each quad's UVs in another tile."""
    return _grid("udim", [("tile_1001", _udim(0.0, 0.0)), ("tile_1002", _udim(1.0, 0.0)),
                          ("tile_1011", _udim(0.0, 1.0)),
                          ("tile_1002_zoomed", _udim(1.25, 0.25, 0.5))])


SCENES = {**{f"image_{i.lower()}": build_interpolation(i) for i in INTERPOLATIONS},
          "udim": build_udim,
          "attribute": build_attribute,
          "mix_shader": build_mix_shader,
          "generated": build_generated,
          "bump": build_bump,
          "transparent": build_transparent,
          "image": build_image,
          "alpha": build_alpha,
          "voronoi": build_voronoi,
          "wave": build_wave,
          "noise": build_noise,
          "emission": build_emission,
          "gradient": build_gradient,
          "mix": build_mix,
          "math": build_math,
          "vector_math": build_vector_math,
          "mapping": build_mapping,
          "color_ramp": build_color_ramp,
          "color": build_color}
