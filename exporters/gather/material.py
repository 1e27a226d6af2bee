"""A Blender material's node tree -> MaterialRecord (UsdPreviewSurface inputs).

The walk starts at the active Material Output's Surface socket. What it cannot
express becomes a warning naming the material and the node, and a constant."""
import dataclasses
import math

from ..ir import MaterialRecord, TexInput, TextureRecord
from .image import image_file

WRAP = {"REPEAT": "repeat", "EXTEND": "clamp", "CLIP": "black", "MIRROR": "mirror"}
SEPARATE = {"ShaderNodeSeparateColor", "ShaderNodeSeparateRGB"}


def principled_ior(ior, level):
    """USD `ior` with the same F0 as Blender's IOR scaled by Specular IOR Level.

    Blender: F0 = ((ior-1)/(ior+1))^2 * 2*level; USD has only ior, so invert F0."""
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2 * 2.0 * max(level, 0.0)
    r = min(math.sqrt(f0), 0.999)
    return (1.0 + r) / (1.0 - r)


def _link(socket):
    """The link feeding `socket`, through reroutes; None when unlinked or muted."""
    while socket.is_linked:
        link = socket.links[0]
        if not link.is_valid or link.is_muted:
            return None
        if link.from_node.bl_idname == "NodeReroute":
            socket = link.from_node.inputs[0]
            continue
        return link
    return None


def _constant(socket, kind):
    value = getattr(socket, "default_value", None)
    if value is None:
        return (0.0, 0.0, 0.0) if kind == "color" else 0.0
    if kind == "color":
        try:
            return tuple(float(v) for v in value[:3])
        except TypeError:
            return (float(value),) * 3
    try:
        return float(value)
    except TypeError:
        return float(value[0])


def _output_node(tree):
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    for targets in ({"ALL", "CYCLES"}, {"ALL", "CYCLES", "EEVEE"}):
        for node in outputs:
            if node.is_active_output and node.target in targets:
                return node
    return outputs[0] if outputs else None


class _Walker:
    def __init__(self, material, warn, texture_dir):
        self.material = material
        self.warn = warn
        self.texture_dir = texture_dir

    def unsupported(self, node, why="not supported"):
        self.warn(f"material '{self.material.name}': node '{node.name}' ({node.bl_idname}) "
                  f"{why}; using a constant")

    def uv_of(self, tex_node):
        link = _link(tex_node.inputs["Vector"])
        while link is not None:
            node = link.from_node
            if node.bl_idname == "ShaderNodeUVMap":
                return node.uv_map or None
            if node.bl_idname == "ShaderNodeTexCoord" and link.from_socket.name == "UV":
                return None
            if node.bl_idname == "ShaderNodeMapping":
                self.warn(f"material '{self.material.name}': node '{node.name}' (Mapping) "
                          f"is ignored; the texture uses plain UVs")
                link = _link(node.inputs["Vector"])
                continue
            self.warn(f"material '{self.material.name}': node '{node.name}' ({node.bl_idname}) "
                      f"as texture coordinates is not supported; using the UV map")
            return None
        return None

    def texture(self, node, raw=False):
        path = image_file(node.image, f"material '{self.material.name}', node '{node.name}'",
                          self.warn, self.texture_dir)
        if path is None:
            return None
        space = node.image.colorspace_settings.name
        return TextureRecord(file=path, uv=self.uv_of(node),
                             wrap=WRAP.get(node.extension, "repeat"),
                             color_space="sRGB" if space == "sRGB" and not raw else "raw")

    def value(self, socket, kind):
        """A constant, or a TexInput when `socket` reads an image (maybe one channel)."""
        link = _link(socket)
        if link is None:
            return _constant(socket, kind)
        node = link.from_node
        if node.bl_idname == "ShaderNodeTexImage":
            tex = self.texture(node, raw=(kind == "float"))
            if tex is None:
                return _constant(socket, kind)
            if link.from_socket.name == "Alpha":
                return TexInput(tex, "a")
            return TexInput(tex, "rgb" if kind == "color" else "r")
        if node.bl_idname in SEPARATE and getattr(node, "mode", "RGB") == "RGB":
            src = _link(node.inputs[0])
            if src is not None and src.from_node.bl_idname == "ShaderNodeTexImage":
                tex = self.texture(src.from_node, raw=True)
                if tex is not None:
                    channel = "rgb"[list(node.outputs).index(link.from_socket)]
                    return TexInput(tex, channel)
                return _constant(socket, kind)
        self.unsupported(node)
        return _constant(socket, kind)

    def normal(self, socket):
        link = _link(socket)
        if link is None:
            return None
        node = link.from_node
        if node.bl_idname == "ShaderNodeNormalMap" and node.space == "TANGENT":
            src = _link(node.inputs["Color"])
            if src is not None and src.from_node.bl_idname == "ShaderNodeTexImage":
                tex = self.texture(src.from_node, raw=True)
                if tex is None:
                    return None
                strength = _constant(node.inputs["Strength"], "float")
                if abs(strength - 1.0) > 1e-6:
                    self.warn(f"material '{self.material.name}': node '{node.name}' "
                              f"strength {strength:g} is written as 1")
                tex = dataclasses.replace(tex, scale=(2.0, 2.0, 2.0, 1.0),
                                          bias=(-1.0, -1.0, -1.0, 0.0))
                return TexInput(tex, "rgb")
        self.unsupported(node, "as a normal is not supported")
        return None

    def principled(self, node, inputs):
        get = node.inputs.get
        inputs["diffuseColor"] = self.value(get("Base Color"), "color")
        inputs["metallic"] = self.value(get("Metallic"), "float")
        inputs["roughness"] = self.value(get("Roughness"), "float")
        for name in ("IOR", "Specular IOR Level"):
            if _link(get(name)) is not None:
                self.unsupported(_link(get(name)).from_node, f"on '{name}' is not supported")
        inputs["ior"] = principled_ior(_constant(get("IOR"), "float"),
                                       _constant(get("Specular IOR Level"), "float"))
        self.emission(get("Emission Color"), get("Emission Strength"), inputs)
        self.alpha(get("Alpha"), inputs)
        normal = self.normal(get("Normal"))
        if normal is not None:
            inputs["normal"] = normal

    def emission(self, color_socket, strength_socket, inputs):
        strength = self.value(strength_socket, "float")
        if isinstance(strength, TexInput):
            self.unsupported(_link(strength_socket).from_node, "on 'Emission Strength' is not supported")
            strength = _constant(strength_socket, "float")
        color = self.value(color_socket, "color")
        if isinstance(color, TexInput):
            # UsdUVTexture's scale carries the strength.
            tex = dataclasses.replace(color.texture, scale=(strength, strength, strength, 1.0))
            inputs["emissiveColor"] = TexInput(tex, color.channel)
        else:
            inputs["emissiveColor"] = tuple(c * strength for c in color)

    def alpha(self, socket, inputs):
        link = _link(socket)
        # glTF-style alpha clip: texture alpha -> Math (Greater Than / Round) -> Alpha.
        if link is not None and link.from_node.bl_idname == "ShaderNodeMath" \
                and link.from_node.operation in {"GREATER_THAN", "ROUND"}:
            math_node = link.from_node
            inputs["opacityThreshold"] = (0.5 if math_node.operation == "ROUND"
                                          else _constant(math_node.inputs[1], "float"))
            inputs["opacity"] = self.value(math_node.inputs[0], "float")
            return
        inputs["opacity"] = self.value(socket, "float")
        if getattr(self.material, "blend_method", None) == "CLIP":
            inputs["opacityThreshold"] = float(self.material.alpha_threshold)

    def shader(self, link, inputs):
        """Fill `inputs` from the shader feeding Surface; returns False if nothing fit."""
        node = link.from_node
        kind = node.bl_idname
        if kind == "ShaderNodeBsdfPrincipled":
            self.principled(node, inputs)
        elif kind == "ShaderNodeBsdfDiffuse":
            inputs["diffuseColor"] = self.value(node.inputs["Color"], "color")
            inputs["roughness"] = 1.0
            inputs["ior"] = 1.0  # no specular layer
        elif kind == "ShaderNodeEmission":
            inputs.setdefault("diffuseColor", (0.0, 0.0, 0.0))
            inputs.setdefault("ior", 1.0)
            self.emission(node.inputs["Color"], node.inputs["Strength"], inputs)
        elif kind in {"ShaderNodeAddShader", "ShaderNodeMixShader"}:
            shaders = [s for s in node.inputs if s.type == "SHADER"]
            if kind == "ShaderNodeMixShader":
                self.warn(f"material '{self.material.name}': node '{node.name}' (Mix Shader) "
                          f"factor is ignored; both shaders are combined")
            # Emission last so that it adds to the BSDF rather than replacing it.
            links = [l for l in (_link(s) for s in shaders) if l is not None]
            links.sort(key=lambda l: l.from_node.bl_idname == "ShaderNodeEmission")
            return any([self.shader(l, inputs) for l in links])
        else:
            self.unsupported(node)
            return False
        return True


def gather_material(material, warn, texture_dir=None):
    inputs = {
        "diffuseColor": tuple(material.diffuse_color[:3]),
        "metallic": float(material.metallic),
        "roughness": float(material.roughness),
        "ior": 1.5,
        "emissiveColor": (0.0, 0.0, 0.0),
        "opacity": 1.0,
    }
    tree = material.node_tree
    if tree is not None:
        walker = _Walker(material, warn, texture_dir)
        output = _output_node(tree)
        link = _link(output.inputs["Surface"]) if output is not None else None
        if link is not None:
            found = {}
            walker.shader(link, found)
            inputs.update(found)
    return MaterialRecord(key=material.name_full, name=material.name, inputs=inputs,
                          backface_culling=bool(material.use_backface_culling),
                          pass_index=int(material.pass_index))
