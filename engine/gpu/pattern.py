"""GLSL for a material's pattern graph (engine/scene.py PatternGraph): one function,
`pattern_eval`, computing the surface inputs the graph feeds, from Blender's node
formulas in shaders/pattern_lib.glsl.

The code depends only on the graph's shape (kinds, settings, links, which inputs are
values): materials with equal shapes share one generated source, so one program
variant. Every value is a parameter, a slot of `uniform vec4 u_pattern[]`, set per
material from `parameters(graph)`."""
from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from ...core.pattern_nodes import (BLEND_TYPES, GRADIENT_TYPES, MAPPING_TYPES, MATH_OPS,
                                   RAMP_INTERPOLATIONS, SURFACE_INPUTS, VECTOR_MATH_OPS,
                                   VORONOI_METRICS, WAVE_DIRECTIONS, WAVE_PROFILES, WAVE_TYPES,
                                   random_offset)
from ..scene import TextureRef
from .programs import set_uniform_array

# pattern_eval's out parameters, one per surface input, in material.glsl's call order.
SURFACE = {target: (f"pt_{target}", typ) for target, typ in SURFACE_INPUTS.items()}


@dataclass(frozen=True)
class PatternCode:
    source: str        # the generated pattern.glsl
    key: str           # hash of the shape: the program variant's name
    slots: int         # vec4 parameters


def _slots(typ, value) -> int:
    if typ == "float[]":
        return (len(value) + 3) // 4
    if typ == "color4[]":
        return len(value)
    return 1


def parameters(graph) -> np.ndarray:
    """(slots, 4) float32: every node value, in the generated code's order."""
    rows = []
    for node in graph.nodes:
        for _, typ, value in node.values:
            if typ == "asset":
                continue
            if typ == "float":
                rows.append((value, 0.0, 0.0, 0.0))
            elif typ in ("vector", "color"):
                rows.append((*value, 0.0))
            elif typ == "float[]":
                flat = list(value) + [0.0] * (-len(value) % 4)
                rows.extend(tuple(flat[i:i + 4]) for i in range(0, len(flat), 4))
            else:
                rows.extend(tuple(c) for c in value)
    return np.asarray(rows, np.float32).reshape(-1, 4)


def _clamped(expr, clamp: str) -> str:
    """A node's output clamped to [0, 1] when its clamp setting is on ("1")."""
    return f"clamp({expr}, 0.0, 1.0)" if clamp == "1" else expr


def _convert(expr, have, want):
    if have == want or (have != "float" and want != "float"):
        return expr
    if want == "float":
        return f"pt_color_to_float({expr})" if have == "color" else f"pt_vector_to_float({expr})"
    return f"vec3({expr})"


class _Writer:
    def __init__(self, graph):
        self.lines, self.slot = [], 0
        self.images = 0                    # t_pattern<k> samplers declared
        self.vars = {}                     # (node name, output) -> (GLSL name, type)
        self.graph = graph

    def node(self, index, node):
        ins, values = {}, {}               # input -> (GLSL expression, type)
        for name, typ, value in node.values:
            if typ == "asset":             # an image: a texture unit, not a parameter
                continue
            values[name] = (self.slot, typ, value)
            swizzle = "x" if typ == "float" else "xyz"
            ins[name] = (f"u_pattern[{self.slot}].{swizzle}", typ)
            self.slot += _slots(typ, value)
        for name, typ, src, out, src_type in node.links:
            var, have = self.vars[(src, out)]
            ins[name] = (_convert(var, have, typ), typ)
        settings = dict(node.settings)
        p = f"p{index}"
        emit = self.lines.append

        def arg(name, want, default="0.0"):
            if name not in ins:
                return default if want == "float" else f"vec3({default})"
            expr, typ = ins[name]
            return _convert(expr, typ, want)

        def out(name, typ, expr):
            emit(f"    {'float' if typ == 'float' else 'vec3'} {p}_{name} = {expr};")
            self.vars[(node.name, name)] = (f"{p}_{name}", typ)

        kind = node.kind
        self.current = node.name
        if kind == "uv":
            out("uv", "vector", "vec3(uv, 0.0)")
            out("generated", "vector", "pt_generated()")
        elif kind == "value":
            out("value", "float", arg("value", "float"))
        elif kind == "rgb":
            out("color", "color", arg("color", "color"))
        elif kind == "mix":
            data = settings.get("data_type", "RGBA")
            fac_type = ins.get("factor", ("", "float"))[1]
            fac = _clamped(arg("factor", fac_type), settings.get("clamp_factor", "1"))
            if data == "FLOAT":
                out("result", "float", f"mix({arg('a', 'float')}, {arg('b', 'float')}, {fac})")
            elif data == "VECTOR":
                out("result", "vector", f"mix({arg('a', 'vector')}, {arg('b', 'vector')}, {fac})")
            else:
                blend = BLEND_TYPES.index(settings.get("blend_type", "MIX"))
                out("result", "color", _clamped(
                    f"pt_blend({blend}, {fac}, {arg('a', 'color')}, {arg('b', 'color')})",
                    settings.get("clamp_result", "0")))
        elif kind == "math":
            op = MATH_OPS.index(settings["operation"])
            out("value", "float", _clamped(
                f"pt_math({op}, {arg('a', 'float')}, {arg('b', 'float')}, {arg('c', 'float')})",
                settings.get("clamp", "0")))
        elif kind == "vector_math":
            op = VECTOR_MATH_OPS.index(settings["operation"])
            emit(f"    vec3 {p}_vector; float {p}_value;")
            emit(f"    pt_vector_math({op}, {arg('a', 'vector')}, {arg('b', 'vector')}, "
                 f"{arg('c', 'vector')}, {arg('scale', 'float', '1.0')}, {p}_vector, {p}_value);")
            self.vars[(node.name, "vector")] = (f"{p}_vector", "vector")
            self.vars[(node.name, "value")] = (f"{p}_value", "float")
        elif kind == "mapping":
            t = MAPPING_TYPES.index(settings.get("vector_type", "POINT"))
            out("vector", "vector", f"pt_mapping({t}, {arg('vector', 'vector')}, "
                f"{arg('location', 'vector')}, {arg('rotation', 'vector')}, "
                f"{arg('scale', 'vector', '1.0')})")
        elif kind == "invert":
            c = arg("color", "color")
            out("color", "color", f"mix({c}, vec3(1.0) - {c}, {arg('fac', 'float')})")
        elif kind in ("separate_xyz", "separate_color"):
            src = arg("vector", "vector") if kind == "separate_xyz" else arg("color", "color")
            if settings.get("mode") == "HSV":
                src = f"pt_rgb_to_hsv({src})"
            emit(f"    vec3 {p}_src = {src};")
            for i, axis in enumerate("xyz"):
                out(axis, "float", f"{p}_src[{i}]")
        elif kind in ("combine_xyz", "combine_color"):
            expr = f"vec3({arg('x', 'float')}, {arg('y', 'float')}, {arg('z', 'float')})"
            if settings.get("mode") == "HSV":
                expr = f"pt_hsv_to_rgb({expr})"
            out("vector" if kind == "combine_xyz" else "color",
                "vector" if kind == "combine_xyz" else "color", expr)
        elif kind == "color_ramp":
            self._ramp(p, node, values, settings, arg("fac", "float"))
        elif kind == "hue_saturation":
            out("color", "color", f"pt_hsv_adjust({arg('hue', 'float')}, "
                f"{arg('saturation', 'float')}, {arg('value', 'float')}, {arg('fac', 'float')}, "
                f"{arg('color', 'color')})")
        elif kind == "checker":
            emit(f"    float {p}_fac = pt_checker({arg('vector', 'vector')} * "
                 f"{arg('scale', 'float')});")
            self.vars[(node.name, "fac")] = (f"{p}_fac", "float")
            out("color", "color", f"mix({arg('color2', 'color')}, {arg('color1', 'color')}, "
                f"{p}_fac)")
        elif kind == "gradient":
            t = GRADIENT_TYPES.index(settings.get("gradient_type", "LINEAR"))
            out("fac", "float", f"pt_gradient({t}, {arg('vector', 'vector')})")
            out("color", "color", f"vec3({p}_fac)")
        elif kind == "image":
            k = self.images
            self.images += 1
            emit(f"    vec4 {p}_texel = sample_map(t_pattern{k}, m_pattern{k}, "
                 f"{arg('vector', 'vector')}.xy);")
            out("color", "color", f"{p}_texel.rgb")
            out("alpha", "float", f"{p}_texel.a")
        elif kind == "voronoi":
            metric = VORONOI_METRICS.index(settings.get("distance", "EUCLIDEAN"))
            emit(f"    float {p}_distance; vec3 {p}_color, {p}_position;")
            emit(f"    float {p}_scale = {arg('scale', 'float', '5.0')};")
            emit(f"    pt_voronoi({arg('vector', 'vector')} * {p}_scale, {p}_scale, "
                 f"clamp({arg('detail', 'float')}, 0.0, 15.0), "
                 f"clamp({arg('roughness', 'float', '0.5')}, 0.0, 1.0), "
                 f"{arg('lacunarity', 'float', '2.0')}, {arg('exponent', 'float', '0.5')}, "
                 f"clamp({arg('randomness', 'float', '1.0')}, 0.0, 1.0), {metric}, "
                 f"{p}_distance, {p}_color, {p}_position);")
            for name, typ in (("distance", "float"), ("color", "color"), ("position", "vector")):
                self.vars[(node.name, name)] = (f"{p}_{name}", typ)
        elif kind == "wave":
            numbers = (WAVE_TYPES.index(settings.get("wave_type", "BANDS")),
                       WAVE_DIRECTIONS.index(settings.get("direction", "X")),
                       WAVE_PROFILES.index(settings.get("wave_profile", "SIN")))
            out("fac", "float", f"pt_wave({numbers[0]}, {numbers[1]}, {numbers[2]}, "
                f"{arg('vector', 'vector')} * {arg('scale', 'float', '5.0')}, "
                f"{arg('distortion', 'float')}, clamp({arg('detail', 'float', '2.0')}, 0.0, 15.0), "
                f"{arg('detail_scale', 'float', '1.0')}, "
                f"max({arg('detail_roughness', 'float', '0.5')}, 0.0), {arg('phase', 'float')})")
            out("color", "color", f"vec3({p}_fac)")
        elif kind == "noise":
            self._noise(p, settings, arg)
        elif kind == "attribute":
            out("color", "color", "pt_color_attribute()")
            out("vector", "vector", f"{p}_color")
            out("fac", "float", f"pt_vector_to_float({p}_color)")   # Cycles: the average
            out("alpha", "float", "pt_color_alpha()")
        elif kind == "bump":
            invert = "true" if settings.get("invert", "0") == "1" else "false"
            normal_in = arg("normal", "vector") if "normal" in ins else "pt_N"
            out("normal", "vector", f"pt_bump({arg('strength', 'float', '1.0')}, "
                f"{arg('distance', 'float', '1.0')}, {arg('height', 'float', '1.0')}, {invert}, "
                f"{normal_in})")
        elif kind == "normal_map":
            out("normal", "vector", f"pt_normal_map({arg('strength', 'float', '1.0')}, "
                f"{arg('color', 'color', '0.5')})")
        else:
            raise ValueError(f"pattern node kind {kind!r} has no GLSL")

    def _noise(self, p, settings, arg):
        """Cycles' svm_node_tex_noise, 3D fBm: Vector x Scale, distorted by three
        offset noises, then the value and two offset copies for the colour."""
        emit = self.lines.append
        norm = "true" if settings.get("normalize", "1") == "1" else "false"
        emit(f"    vec3 {p}_p = {arg('vector', 'vector')} * {arg('scale', 'float', '5.0')};")
        emit(f"    float {p}_detail = clamp({arg('detail', 'float', '2.0')}, 0.0, 15.0);")
        emit(f"    float {p}_rough = max({arg('roughness', 'float', '0.5')}, 0.0);")
        emit(f"    float {p}_lac = {arg('lacunarity', 'float', '2.0')};")
        emit(f"    float {p}_dist = {arg('distortion', 'float')};")

        def offset(seed):
            return "vec3(" + ", ".join(f"{c:.9g}" for c in random_offset(seed)) + ")"

        emit(f"    if ({p}_dist != 0.0) {p}_p += vec3(pt_snoise({p}_p + {offset(0.0)}), "
             f"pt_snoise({p}_p + {offset(1.0)}), pt_snoise({p}_p + {offset(2.0)})) * {p}_dist;")
        fbm = f"{p}_detail, {p}_rough, {p}_lac, {norm})"
        emit(f"    float {p}_fac = pt_noise_fbm({p}_p, {fbm};")
        emit(f"    vec3 {p}_color = vec3({p}_fac, pt_noise_fbm({p}_p + {offset(3.0)}, {fbm}, "
             f"pt_noise_fbm({p}_p + {offset(4.0)}, {fbm});")
        self.vars[(self.current, "fac")] = (f"{p}_fac", "float")
        self.vars[(self.current, "color")] = (f"{p}_color", "color")

    def _ramp(self, p, node, values, settings, fac):
        """Blender's colour band (BKE_colorband_evaluate): below the first stop its
        colour, above the last the last's, between two stops by interpolation."""
        pos_slot, _, positions = values["positions"]
        col_slot = values["colors"][0]
        n = len(positions)
        interp = RAMP_INTERPOLATIONS.index(settings.get("interpolation", "LINEAR"))
        emit = self.lines.append

        def pos(i):
            return f"u_pattern[{pos_slot + i // 4}][{i % 4}]"

        emit(f"    float {p}_t = {fac};")
        emit(f"    vec4 {p}_c = u_pattern[{col_slot}];")
        for i in range(n - 1):
            lo, hi = pos(i), pos(i + 1)
            if interp == 1:
                step = f"u_pattern[{col_slot + i}]"
            else:
                f = f"clamp(({p}_t - {lo}) / max({hi} - {lo}, 1e-9), 0.0, 1.0)"
                if interp == 2:
                    f = f"smoothstep(0.0, 1.0, {f})"
                step = f"mix(u_pattern[{col_slot + i}], u_pattern[{col_slot + i + 1}], {f})"
            emit(f"    if ({p}_t >= {lo}) {p}_c = {step};")
        emit(f"    if ({p}_t >= {pos(n - 1)}) {p}_c = u_pattern[{col_slot + n - 1}];")
        self.vars[(node.name, "color")] = (f"{p}_c.rgb", "color")
        self.vars[(node.name, "alpha")] = (f"{p}_c.a", "float")


def generate(graph) -> PatternCode:
    writer = _Writer(graph)
    for i, node in enumerate(graph.nodes):
        writer.node(i, node)
    body = writer.lines
    for target, node, out, _ in graph.outputs:
        name, want = SURFACE[target]
        var, have = writer.vars[(node, out)]
        body.append(f"    {name} = {_convert(var, have, want)};")
    samplers = [f"uniform sampler2D t_pattern{k}; uniform Map m_pattern{k};"
                for k in range(writer.images)]
    outs = ", ".join(f"inout {'float' if t == 'float' else 'vec3'} {n}" for n, t in SURFACE.values())
    source = "\n".join([
        "// Generated by engine/gpu/pattern.py for one graph shape.",
        "#define HAS_PATTERN",
        '#include "pattern_lib.glsl"',
        f"uniform vec4 u_pattern[{max(writer.slot, 1)}];",
        *samplers,
        f"void pattern_eval(vec2 uv, {outs}) {{",
        *body,
        "}",
        ""])
    return PatternCode(source=source, key=hashlib.sha1(source.encode()).hexdigest()[:16],
                       slots=writer.slot)


# Shape -> PatternCode: generation is a pure function of the shape, so one memo serves
# every context in the process.
_CODES: dict = {}


def code_of(graph) -> PatternCode:
    shape = graph.shape
    code = _CODES.get(shape)
    if code is None:
        code = _CODES[shape] = generate(graph)
    return code


def material_variant(mat) -> tuple:
    """The `generated` argument of ProgramCache.get for a material: its graph's code
    in place of shaders/pattern.glsl, or nothing (the fast path)."""
    if mat.pattern is None:
        return ()
    return (("pattern.glsl", code_of(mat.pattern).source),)


def pattern_images(mat) -> list:
    """TextureRef of each image of the material's graph, in t_pattern<k> order."""
    if mat.pattern is None:
        return []
    refs = []
    for node in mat.pattern.nodes:
        if node.kind == "image":
            settings = dict(node.settings)
            path = next(v for i, t, v in node.values if t == "asset")
            wrap = settings.get("wrap", "repeat")
            refs.append(TextureRef(path=path, colorspace=settings.get("color_space", "sRGB"),
                                   wrap_s=wrap, wrap_t=wrap,
                                   filtertype=settings.get("filtertype", "linear")))
    return refs


def set_parameters(prog, mat) -> int:
    """Uploads the material's pattern parameters; returns the bytes written."""
    if mat.pattern is None:
        return 0
    return set_uniform_array(prog, "u_pattern", parameters(mat.pattern))
