"""A Blender node network feeding a surface input -> PatternGraph (plain records).

Each supported node becomes one PatternNode of a Lantern kind: its settings (operation,
blend type, ...) are the graph's shape, its unlinked sockets are values. A node outside
NODES anywhere upstream is one warning naming it; the caller then keeps its constant
(the UsdPreviewSurface fallback)."""
from __future__ import annotations

from ...core.images import WRAP
from ...core.pattern_nodes import MAX_IMAGES, unsupported_setting
from ..ir import PatternGraph, PatternNode
from .mesh import attribute_primvar

SOCKET_TYPES = {"VALUE": "float", "INT": "float", "BOOLEAN": "float",
                "VECTOR": "vector", "RGBA": "color"}
MIX_TYPES = {"FLOAT": ("Float", "float"), "VECTOR": ("Vector", "vector"), "RGBA": ("Color", "color")}


class Unsupported(Exception):
    def __init__(self, node, why="not supported"):
        super().__init__(why)
        self.node, self.why = node, why


def _mix(node):
    """ShaderNodeMix: (kind, settings, {input: socket}, {output: socket})."""
    if node.data_type not in MIX_TYPES:
        raise Unsupported(node, f"with data type {node.data_type} is not supported")
    suffix, _ = MIX_TYPES[node.data_type]
    by_id = {s.identifier: s for s in node.inputs}
    factor = by_id["Factor_Vector"] if node.data_type == "VECTOR" and \
        node.factor_mode == "NON_UNIFORM" else by_id["Factor_Float"]
    settings = {"data_type": node.data_type, "clamp_factor": str(int(node.clamp_factor))}
    if node.data_type == "RGBA":
        settings.update(blend_type=node.blend_type, clamp_result=str(int(node.clamp_result)))
    out = {s.identifier: s for s in node.outputs}[f"Result_{suffix}"]
    return "mix", settings, {"factor": factor, "a": by_id[f"A_{suffix}"],
                             "b": by_id[f"B_{suffix}"]}, {"result": out}


def _mix_rgb(node):
    """The legacy ShaderNodeMixRGB: a colour Mix with clamped factor."""
    return "mix", {"data_type": "RGBA", "clamp_factor": "1", "blend_type": node.blend_type,
                   "clamp_result": str(int(node.use_clamp))}, \
        {"factor": node.inputs[0], "a": node.inputs[1], "b": node.inputs[2]}, \
        {"result": node.outputs[0]}


def _math(node):
    return "math", {"operation": node.operation, "clamp": str(int(node.use_clamp))}, \
        {"a": node.inputs[0], "b": node.inputs[1], "c": node.inputs[2]}, {"value": node.outputs[0]}


def _vector_math(node):
    return "vector_math", {"operation": node.operation}, \
        {"a": node.inputs[0], "b": node.inputs[1], "c": node.inputs[2], "scale": node.inputs[3]}, \
        {"vector": node.outputs[0], "value": node.outputs[1]}


def _mapping(node):
    ins = {"vector": node.inputs["Vector"], "rotation": node.inputs["Rotation"],
           "scale": node.inputs["Scale"]}
    if node.vector_type in {"POINT", "TEXTURE"}:
        ins["location"] = node.inputs["Location"]
    return "mapping", {"vector_type": node.vector_type}, ins, {"vector": node.outputs[0]}


def _texcoord(node):
    return "uv", {}, {}, {"uv": node.outputs["UV"], "generated": node.outputs["Generated"]}


def _separate_color(node, mode=None):
    mode = mode or node.mode
    if mode not in {"RGB", "HSV"}:
        raise Unsupported(node, f"in {mode} mode is not supported")
    return "separate_color", {"mode": mode}, {"color": node.inputs[0]}, \
        {"x": node.outputs[0], "y": node.outputs[1], "z": node.outputs[2]}


def _combine_color(node, mode=None):
    mode = mode or node.mode
    if mode not in {"RGB", "HSV"}:
        raise Unsupported(node, f"in {mode} mode is not supported")
    return "combine_color", {"mode": mode}, \
        {"x": node.inputs[0], "y": node.inputs[1], "z": node.inputs[2]}, {"color": node.outputs[0]}


def _bump(node):
    """Cycles' Bump node on the shading normal, or on its linked Normal (chained bumps,
    a normal map under a bump). Its Filter Width only sets where Cycles takes its finite
    differences; the engine takes the height's screen-space derivatives."""
    inputs = {"strength": node.inputs["Strength"], "distance": node.inputs["Distance"],
              "height": node.inputs["Height"]}
    if node.inputs["Normal"].is_linked:
        inputs["normal"] = node.inputs["Normal"]
    return "bump", {"invert": str(int(node.invert))}, inputs, {"normal": node.outputs["Normal"]}


def _normal_map(node):
    return "normal_map", {"space": node.space}, \
        {"strength": node.inputs["Strength"], "color": node.inputs["Color"]}, \
        {"normal": node.outputs["Normal"]}


def _attribute(node):
    """A colour attribute of the mesh (the engine reads the primvar exporters/gather/
    mesh.py writes for it)."""
    if node.bl_idname == "ShaderNodeVertexColor":
        return "attribute", {"name": attribute_primvar(node.layer_name)}, {}, \
            {"color": node.outputs["Color"], "alpha": node.outputs["Alpha"]}
    if node.attribute_type != "GEOMETRY":
        raise Unsupported(node, f"of type {node.attribute_type} is not supported")
    return "attribute", {"name": attribute_primvar(node.attribute_name)}, {}, \
        {"color": node.outputs["Color"], "vector": node.outputs["Vector"],
         "fac": node.outputs["Fac"], "alpha": node.outputs["Alpha"]}


def _ramp(node):
    ramp = node.color_ramp
    if ramp.color_mode != "RGB" or ramp.interpolation not in {"LINEAR", "CONSTANT", "EASE"}:
        raise Unsupported(node, f"with {ramp.color_mode}/{ramp.interpolation} interpolation "
                                f"is not supported")
    return "color_ramp", {"interpolation": ramp.interpolation, "stops": str(len(ramp.elements))}, \
        {"fac": node.inputs["Fac"]}, {"color": node.outputs["Color"], "alpha": node.outputs["Alpha"]}


def _ramp_values(node):
    elements = node.color_ramp.elements
    return {"positions": ("float[]", [float(e.position) for e in elements]),
            "colors": ("color4[]", [tuple(float(c) for c in e.color) for e in elements])}


# bl_idname -> function(node) giving (kind, settings, {input: socket}, {output: socket}).
NODES = {
    "ShaderNodeMix": _mix,
    "ShaderNodeMixRGB": _mix_rgb,
    "ShaderNodeMath": _math,
    "ShaderNodeVectorMath": _vector_math,
    "ShaderNodeMapping": _mapping,
    "ShaderNodeTexCoord": _texcoord,
    # A UV Map node reads the mesh's render-active UV map (the engine draws one UV set
    # per material): exact for that map, approximated for another.
    "ShaderNodeUVMap": lambda n: ("uv", {}, {}, {"uv": n.outputs["UV"]}),
    "ShaderNodeRGB": lambda n: ("rgb", {}, {}, {"color": n.outputs[0]}),
    "ShaderNodeValue": lambda n: ("value", {}, {}, {"value": n.outputs[0]}),
    "ShaderNodeInvert": lambda n: ("invert", {}, {"fac": n.inputs["Fac"], "color": n.inputs["Color"]},
                                   {"color": n.outputs[0]}),
    "ShaderNodeSeparateXYZ": lambda n: ("separate_xyz", {}, {"vector": n.inputs[0]},
                                        {"x": n.outputs[0], "y": n.outputs[1], "z": n.outputs[2]}),
    "ShaderNodeCombineXYZ": lambda n: ("combine_xyz", {}, {"x": n.inputs[0], "y": n.inputs[1],
                                                          "z": n.inputs[2]}, {"vector": n.outputs[0]}),
    "ShaderNodeSeparateColor": _separate_color,
    "ShaderNodeCombineColor": _combine_color,
    "ShaderNodeSeparateRGB": lambda n: _separate_color(n, "RGB"),
    "ShaderNodeCombineRGB": lambda n: _combine_color(n, "RGB"),
    "ShaderNodeValToRGB": _ramp,
    "ShaderNodeHueSaturation": lambda n: ("hue_saturation", {}, {
        "hue": n.inputs["Hue"], "saturation": n.inputs["Saturation"], "value": n.inputs["Value"],
        "fac": n.inputs["Fac"], "color": n.inputs["Color"]}, {"color": n.outputs[0]}),
    "ShaderNodeTexChecker": lambda n: ("checker", {}, {
        "vector": n.inputs["Vector"], "color1": n.inputs["Color1"], "color2": n.inputs["Color2"],
        "scale": n.inputs["Scale"]}, {"color": n.outputs["Color"], "fac": n.outputs["Fac"]}),
    "ShaderNodeTexNoise": lambda n: ("noise", {
        "dimensions": n.noise_dimensions, "noise_type": n.noise_type,
        "normalize": str(int(n.normalize))}, {
        "vector": n.inputs["Vector"], "scale": n.inputs["Scale"], "detail": n.inputs["Detail"],
        "roughness": n.inputs["Roughness"], "lacunarity": n.inputs["Lacunarity"],
        "distortion": n.inputs["Distortion"]},
        {"fac": n.outputs["Fac"], "color": n.outputs["Color"]}),
    "ShaderNodeTexImage": lambda n: ("image", {
        "wrap": WRAP.get(n.extension, "repeat"),
        "color_space": "sRGB" if n.image is not None and
        n.image.colorspace_settings.name == "sRGB" else "raw"},
        {"vector": n.inputs["Vector"]}, {"color": n.outputs["Color"], "alpha": n.outputs["Alpha"]}),
    "ShaderNodeTexVoronoi": lambda n: ("voronoi", {
        "dimensions": n.voronoi_dimensions, "feature": n.feature, "distance": n.distance,
        "normalize": str(int(n.normalize))}, {
        "vector": n.inputs["Vector"], "scale": n.inputs["Scale"], "detail": n.inputs["Detail"],
        "roughness": n.inputs["Roughness"], "lacunarity": n.inputs["Lacunarity"],
        # Exponent only shows for Minkowski: by identifier, as unavailable sockets
        # are not found by name.
        "exponent": {i.identifier: i for i in n.inputs}["Exponent"],
        "randomness": n.inputs["Randomness"]},
        {"distance": n.outputs["Distance"], "color": n.outputs["Color"],
         "position": n.outputs["Position"]}),
    "ShaderNodeTexWave": lambda n: ("wave", {
        "wave_type": n.wave_type, "wave_profile": n.wave_profile,
        "direction": n.bands_direction if n.wave_type == "BANDS" else n.rings_direction}, {
        "vector": n.inputs["Vector"], "scale": n.inputs["Scale"],
        "distortion": n.inputs["Distortion"], "detail": n.inputs["Detail"],
        "detail_scale": n.inputs["Detail Scale"], "detail_roughness": n.inputs["Detail Roughness"],
        "phase": n.inputs["Phase Offset"]}, {"fac": n.outputs["Fac"], "color": n.outputs["Color"]}),
    "ShaderNodeBump": _bump,
    "ShaderNodeVertexColor": _attribute,
    "ShaderNodeAttribute": _attribute,
    "ShaderNodeNormalMap": _normal_map,
    "ShaderNodeTexGradient": lambda n: ("gradient", {"gradient_type": n.gradient_type},
                                        {"vector": n.inputs["Vector"]},
                                        {"color": n.outputs["Color"], "fac": n.outputs["Fac"]}),
}
# Texture nodes whose unlinked Vector is Blender's Generated coordinates (the engine
# computes them from the mesh's rest points: engine/usd/mesh.py).
GENERATED_DEFAULT = {"ShaderNodeTexChecker", "ShaderNodeTexGradient", "ShaderNodeTexNoise",
                     "ShaderNodeTexWave", "ShaderNodeTexVoronoi"}


def socket_type(socket) -> str:
    return SOCKET_TYPES.get(socket.type, "float")


def socket_value(socket, kind):
    value = getattr(socket, "default_value", 0.0)
    if kind == "float":
        try:
            return float(value)
        except TypeError:
            return float(value[0])
    try:
        return tuple(float(v) for v in value[:3])
    except TypeError:
        return (float(value),) * 3


def is_pattern(node) -> bool:
    """Whether `node` can start a network (an Image Texture straight on an input stays
    a UsdUVTexture: the callers look for that first)."""
    return node.bl_idname in NODES


class PatternBuilder:
    """Builds one material's PatternGraph across its surface inputs (shared nodes once).
    `link_of(socket)`: the link feeding a socket through reroutes, or None;
    `image_of(node)`: an Image Texture node's (file, filter type), or None (it has
    warned)."""

    def __init__(self, link_of, image_of):
        self.link_of = link_of
        self.image_of = image_of
        self.graph = PatternGraph()
        self._names = {}          # Blender node name -> PatternNode name

    def connect(self, target, link) -> None:
        """Makes surface input `target` read the node output `link.from_socket`;
        raises Unsupported (naming the node) when anything upstream is not in NODES."""
        nodes = list(self.graph.nodes)
        names = dict(self._names)
        try:
            name = self._node(link.from_node, set())
        except Unsupported:
            self.graph.nodes, self._names = nodes, names
            raise
        self.graph.outputs[target] = (name, self._output_name(link.from_node, link.from_socket))

    def connect_scaled(self, target, link, factor) -> None:
        """As connect, times a constant `factor` (an emission's strength and weight):
        a Vector Math Scale node after the output."""
        self.connect(target, link)
        self.scale(target, factor)

    def connect_mix(self, target, kind, fac, sockets, default, factor=0.5) -> None:
        """Surface input `target` reads a Mix node of the two `sockets` (a socket, or None
        for `default`) by the factor socket `fac` (None: the value `factor`): the Mix
        Shader of two BSDFs, input by input. Raises Unsupported (naming the node) as
        connect does."""
        nodes, names = list(self.graph.nodes), dict(self._names)
        settings = {"data_type": "FLOAT", "clamp_factor": "1"}
        if kind == "color":
            settings.update(data_type="RGBA", blend_type="MIX", clamp_result="0")
        rec = PatternNode(name="", kind="mix", settings=settings, outputs={"result": kind})
        try:
            for name, socket, want, unset in (("factor", fac, "float", factor),
                                              ("a", sockets[0], kind, default),
                                              ("b", sockets[1], kind, default)):
                link = self.link_of(socket) if socket is not None else None
                if link is None:
                    value = socket_value(socket, want) if socket is not None else unset
                    rec.values[name] = (want, value)
                else:
                    src = self._node(link.from_node, set())
                    rec.links[name] = (want, src, self._output_name(link.from_node,
                                                                    link.from_socket))
        except Unsupported:
            self.graph.nodes, self._names = nodes, names
            raise
        rec.name = f"n{len(self.graph.nodes)}_mix"
        self.graph.nodes.append(rec)
        self.graph.outputs[target] = (rec.name, "result")

    def scale(self, target, factor) -> None:
        """Surface input `target` reads `factor` times what it read (a Vector Math Scale
        node after it)."""
        src, out = self.graph.outputs[target]
        rec = PatternNode(name=f"n{len(self.graph.nodes)}_vector_math", kind="vector_math",
                          settings={"operation": "SCALE"},
                          values={"scale": ("float", float(factor))},
                          links={"a": ("vector", src, out)},
                          outputs={"vector": "vector", "value": "float"})
        self.graph.nodes.append(rec)
        self.graph.outputs[target] = (rec.name, "vector")

    def complement(self, target) -> None:
        """Surface input `target` reads 1 - what it read (a Math Subtract node after it)."""
        src, out = self.graph.outputs[target]
        rec = PatternNode(name=f"n{len(self.graph.nodes)}_math", kind="math",
                          settings={"operation": "SUBTRACT", "clamp": "0"},
                          values={"a": ("float", 1.0)},
                          links={"b": ("float", src, out)}, outputs={"value": "float"})
        self.graph.nodes.append(rec)
        self.graph.outputs[target] = (rec.name, "value")

    def _output_name(self, node, socket):
        for out, s in NODES[node.bl_idname](node)[3].items():
            if s == socket:
                return out
        raise Unsupported(node, f"output '{socket.name}' is not supported")

    def _node(self, node, visiting):
        if node.name in self._names:
            return self._names[node.name]
        if node.bl_idname not in NODES:
            raise Unsupported(node)
        if node.name in visiting:
            raise Unsupported(node, "is in a cycle")
        visiting.add(node.name)
        kind, settings, inputs, outputs = NODES[node.bl_idname](node)
        why = unsupported_setting(kind, settings)
        if why is not None:
            raise Unsupported(node, f"with {why.replace(' is not supported', '')} is not supported")
        rec = PatternNode(name="", kind=kind, settings=dict(settings),
                          outputs={o: socket_type(s) for o, s in outputs.items()})
        if kind == "color_ramp":
            rec.values.update(_ramp_values(node))
        elif kind == "image":
            if sum(n.kind == "image" for n in self.graph.nodes) >= MAX_IMAGES:
                raise Unsupported(node, f"is a network's image beyond {MAX_IMAGES}: not supported")
            image = self.image_of(node)
            if image is None:
                raise Unsupported(node, "has no image file")
            rec.values["file"] = ("asset", image[0])
            rec.settings["filtertype"] = image[1]
        for name, socket in inputs.items():
            typ = socket_type(socket)
            link = self.link_of(socket)
            if link is None:
                if name == "vector" and node.bl_idname in GENERATED_DEFAULT:
                    rec.links[name] = (typ, self._uv_node(), "generated")
                elif name == "vector" and kind == "image":
                    rec.links[name] = (typ, self._uv_node(), "uv")
                else:
                    rec.values[name] = (typ, socket_value(socket, typ))
                continue
            src = self._node(link.from_node, visiting)
            rec.links[name] = (typ, src, self._output_name(link.from_node, link.from_socket))
        if kind == "rgb":
            rec.values["color"] = ("color", socket_value(node.outputs[0], "color"))
        elif kind == "value":
            rec.values["value"] = ("float", socket_value(node.outputs[0], "float"))
        visiting.discard(node.name)
        rec.name = f"n{len(self.graph.nodes)}_{kind}"     # after its sources: unique
        self.graph.nodes.append(rec)
        self._names[node.name] = rec.name
        return rec.name

    def _uv_node(self):
        key = "<uv>"
        if key not in self._names:
            rec = PatternNode(name=f"n{len(self.graph.nodes)}_uv", kind="uv",
                              outputs={"uv": "vector", "generated": "vector"})
            self.graph.nodes.append(rec)
            self._names[key] = rec.name
        return self._names[key]
