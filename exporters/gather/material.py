"""A Blender material's node tree -> MaterialRecord (UsdPreviewSurface inputs).

The walk starts at the Surface socket of the output Blender's USD exporter would use
(see output_node). What it cannot express becomes a warning naming the material and
the node, and a constant."""
import dataclasses
import math

from ...core.emission import BLENDER as EMISSION_SAMPLING, DEFAULT as DEFAULT_SAMPLING
from ...core.images import BLENDER_INTERPOLATIONS, WRAP, filtertype_of
from ...core.sheen import DISTRIBUTIONS
from ..ir import MaterialRecord, SheenRecord, TexInput, TextureRecord
from . import node_groups
from .image import image_file
from .pattern import PatternBuilder, Unsupported, is_pattern

SEPARATE = {"ShaderNodeSeparateColor", "ShaderNodeSeparateRGB"}


def principled_ior(ior, level):
    """USD `ior` with the same F0 as Blender's IOR scaled by Specular IOR Level.

    Blender: F0 = ((ior-1)/(ior+1))^2 * 2*level; USD has only ior, so invert F0."""
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2 * 2.0 * max(level, 0.0)
    r = min(math.sqrt(f0), 0.999)
    return (1.0 + r) / (1.0 - r)


def _link(socket):
    """The link feeding `socket`, through reroutes and node groups (node_groups.py);
    None when unlinked or muted."""
    return node_groups.link(socket)


def _computed_coordinates(tex_node) -> bool:
    """Whether an Image Texture's Vector is more than a UV map (a UsdUVTexture's st)."""
    link = _link(tex_node.inputs["Vector"])
    if link is None:
        return False
    node = link.from_node
    return not (node.bl_idname == "ShaderNodeUVMap" or
                (node.bl_idname == "ShaderNodeTexCoord" and link.from_socket.name == "UV"))


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


def shader_output(tree, bl_idname, target):
    """The output node Blender's ntreeShaderOutputNode(tree, target) picks: among
    outputs of `bl_idname`, one for exactly `target` beats one for ALL, and the active
    output beats the others of its kind; None when no output fits."""
    chosen = None
    for node in tree.nodes:
        if node.bl_idname != bl_idname:
            continue
        if node.target == "ALL":
            if chosen is None or (chosen.target == "ALL" and node.is_active_output
                                  and not chosen.is_active_output):
                chosen = node
        elif node.target == target:
            if chosen is None or chosen.target == "ALL" or (node.is_active_output
                                                            and not chosen.is_active_output):
                chosen = node
    return chosen


def output_node(tree, bl_idname, owner, warn):
    """The output to export, chosen as Blender's USD exporter chooses it (the All
    output, as for MaterialX: ntreeShaderOutputNode(tree, SHD_OUTPUT_ALL)), else the
    one Cycles renders. Warns, naming `owner`, when Cycles and EEVEE render different
    outputs: the exported one cannot match both."""
    cycles = shader_output(tree, bl_idname, "CYCLES")
    eevee = shader_output(tree, bl_idname, "EEVEE")
    chosen = shader_output(tree, bl_idname, "ALL") or cycles
    if cycles is not None and eevee is not None and cycles != eevee:
        warn(f"{owner}: Cycles renders output '{cycles.name}' and EEVEE '{eevee.name}'; "
             f"exporting '{chosen.name}'")
    return chosen


def normal_map_scale_bias(strength, invert_green=False):
    """UsdUVTexture scale and bias that turn a tangent-space normal-map texel c into
    Cycles' strength-weighted normal before the renderer normalises it
    (svm_node_normal_map, tangent space): n = 2c - 1, then (s n.x, s n.y,
    1 + clamp(s, 0, 1) (n.z - 1)). Strength above 1 steepens x and y only."""
    k = min(max(strength, 0.0), 1.0)
    sy = -strength if invert_green else strength
    return (2.0 * strength, 2.0 * sy, 2.0 * k, 1.0), (-strength, -sy, 1.0 - 2.0 * k, 0.0)


class _Walker:
    def __init__(self, material, warn, texture_dir):
        self.material = material
        self.warn = warn
        self.texture_dir = texture_dir
        self.pattern = PatternBuilder(_link, self.network_image)
        self.base_occlusion = False
        self.sheen = None          # SheenRecord: the first sheen lobe met
        self.transmission = 0.0    # the share of light that goes through (glass)

    def unsupported(self, node, why="not supported"):
        self.warn(f"material '{self.material.name}': node '{node.name}' ({node.bl_idname}) "
                  f"{why}; using a constant")

    def constant_only(self, socket):
        """A warning when a node feeds `socket`, an input exported as its constant."""
        link = _link(socket)
        if link is not None:
            node = link.from_node
            self.warn(f"material '{self.material.name}': input '{socket.name}' takes a "
                      f"constant only, not node '{node.name}' ({node.bl_idname}); using "
                      f"its value")

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

    def _owner(self, node):
        return f"material '{self.material.name}', node '{node.name}'"

    def filtertype(self, node):
        """The Image Texture node's interpolation as the stage's filter type."""
        return filtertype_of(BLENDER_INTERPOLATIONS.get(node.interpolation, node.interpolation),
                             self._owner(node), self.warn)

    def network_image(self, node):
        """(file, filter type) of an Image Texture node in a network; None when it has
        no file (it has warned)."""
        path = image_file(node.image, self._owner(node), self.warn, self.texture_dir)
        return None if path is None else (path, self.filtertype(node))

    def texture(self, node, raw=False):
        path = image_file(node.image, self._owner(node), self.warn, self.texture_dir, udim=True)
        if path is None:
            return None
        space = node.image.colorspace_settings.name
        return TextureRecord(file=path, uv=self.uv_of(node),
                             wrap=WRAP.get(node.extension, "repeat"),
                             color_space="sRGB" if space == "sRGB" and not raw else "raw",
                             filtertype=self.filtertype(node))

    def value(self, socket, kind, target=None):
        """A constant, or a TexInput when `socket` reads an image (maybe one channel).
        A node network feeding surface input `target` goes into the pattern graph, and
        the socket's constant is UsdPreviewSurface's fallback."""
        link = _link(socket)
        if link is None:
            return _constant(socket, kind)
        node = link.from_node
        if node.bl_idname == "ShaderNodeAmbientOcclusion" and target == "diffuseColor" and \
                link.from_socket.name == "Color":
            # Color x occlusion on Base Color: its Color input, times the renderer's AO.
            self.base_occlusion = True
            return self.value(node.inputs["Color"], kind, target)
        if node.bl_idname == "ShaderNodeTexImage" and target is not None and \
                _computed_coordinates(node):
            # Mapped (or otherwise computed) coordinates: the image as a network node;
            # failing that, the image on plain UVs as before (uv_of warns).
            try:
                self.pattern.connect(target, link)
                return _constant(socket, kind)
            except Unsupported as exc:
                self.warn(f"material '{self.material.name}': node '{exc.node.name}' "
                          f"({exc.node.bl_idname}) {exc.why}; the image uses plain UVs")
        if node.bl_idname == "ShaderNodeTexImage":
            tex = self.texture(node, raw=(kind == "float"))
            if tex is None:
                return _constant(socket, kind)
            if link.from_socket.name == "Alpha":
                return TexInput(tex, "a")
            return TexInput(tex, "rgb" if kind == "color" else "r")
        if node.bl_idname in SEPARATE and getattr(node, "mode", "RGB") == "RGB":
            src = _link(node.inputs[0])
            if src is not None and src.from_node.bl_idname == "ShaderNodeTexImage" and \
                    target is not None and _computed_coordinates(src.from_node):
                # One channel of a mapped image (an ORM map through Mapping): a network.
                try:
                    self.pattern.connect(target, link)
                    return _constant(socket, kind)
                except Unsupported:
                    pass            # the channel on plain UVs, below (uv_of warns)
            if src is not None and src.from_node.bl_idname == "ShaderNodeTexImage":
                tex = self.texture(src.from_node, raw=True)
                if tex is not None:
                    channel = "rgb"[list(node.outputs).index(link.from_socket)]
                    return TexInput(tex, channel)
                return _constant(socket, kind)
        if target is not None and is_pattern(node):
            try:
                self.pattern.connect(target, link)
            except Unsupported as exc:
                self.unsupported(exc.node, exc.why)
            return _constant(socket, kind)
        if is_pattern(node):      # a supported node, on an input that takes no network
            self.constant_only(socket)
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
            if src is not None and src.from_node.bl_idname == "ShaderNodeTexImage" and \
                    not _computed_coordinates(src.from_node):
                tex = self.texture(src.from_node, raw=True)
                if tex is None:
                    return None
                if _link(node.inputs["Strength"]) is not None:
                    self.unsupported(_link(node.inputs["Strength"]).from_node,
                                     "on 'Strength' is not supported")
                strength = _constant(node.inputs["Strength"], "float")
                scale, bias = normal_map_scale_bias(
                    strength, bool(getattr(node, "invert_green", False)))
                tex = dataclasses.replace(tex, scale=scale, bias=bias)
                return TexInput(tex, "rgb")
        if is_pattern(node):
            # A Bump node, or a Normal Map whose colour a network computes: the
            # pattern graph's `normal` (UsdPreviewSurface's fallback has none).
            try:
                self.pattern.connect("normal", link)
            except Unsupported as exc:
                self.unsupported(exc.node, exc.why)
            return None
        self.unsupported(node, "as a normal is not supported")
        return None

    def principled(self, node, inputs, weight=1.0):
        get = node.inputs.get
        inputs["diffuseColor"] = self.value(get("Base Color"), "color", "diffuseColor")
        inputs["metallic"] = self.value(get("Metallic"), "float", "metallic")
        inputs["roughness"] = self.value(get("Roughness"), "float", "roughness")
        for name in ("IOR", "Specular IOR Level"):
            self.constant_only(get(name))
        inputs["ior"] = principled_ior(_constant(get("IOR"), "float"),
                                       _constant(get("Specular IOR Level"), "float"))
        self.emission(get("Emission Color"), get("Emission Strength"), inputs, weight)
        self.alpha(get("Alpha"), inputs)
        normal = self.normal(get("Normal"))
        if normal is not None:
            inputs["normal"] = normal
        self.coat(node, inputs)
        self.constant_only(get("Transmission Weight"))
        self.transmission = min(max(_constant(get("Transmission Weight"), "float"), 0.0), 1.0)
        self.constant_only(get("Sheen Weight"))
        self.sheen_lobe(node, "principled", get("Sheen Tint"),
                        _constant(get("Sheen Weight"), "float"), get("Sheen Roughness"), weight)

    def sheen_lobe(self, node, mode, color, factor, roughness, weight):
        """A sheen lobe: the `color` socket x `factor` x `weight` (closure weights scale
        it exactly, as they scale emission), and the `roughness` socket; a network on
        either feeds the pattern graph's sheenColor or sheenRoughness, their constants
        are the fallback. One sheen a material: a second is a warning. Cycles clamps the
        roughness to [0, 1] and the colour to >= 0."""
        scale = max(factor, 0.0) * weight
        constant = tuple(max(c, 0.0) * scale for c in _constant(color, "color"))
        networks = {target: link for target, link in (("sheenColor", _link(color)),
                                                      ("sheenRoughness", _link(roughness)))
                    if link is not None and is_pattern(link.from_node)}
        for socket in (color, roughness):
            if _link(socket) is not None and not is_pattern(_link(socket).from_node):
                self.unsupported(_link(socket).from_node)
        if scale <= 0.0 or ("sheenColor" not in networks and not any(constant)):
            return
        if self.sheen is not None:
            self.warn(f"material '{self.material.name}': node '{node.name}' is a second sheen "
                      f"(one a material is exported); keeping the first")
            return
        for target, link in networks.items():
            try:
                if target == "sheenColor":
                    self.pattern.connect_scaled(target, link, scale)
                else:
                    self.pattern.connect(target, link)
            except Unsupported as exc:
                self.unsupported(exc.node, exc.why)
        self.sheen = SheenRecord(mode, constant,
                                 min(max(_constant(roughness, "float"), 0.0), 1.0))

    def coat(self, node, inputs):
        """Coat Weight and Roughness -> clearcoat, clearcoatRoughness (as Blender's USD
        exporter). UsdPreviewSurface's coat is white with IOR 1.5 and the base normal."""
        get = node.inputs.get
        inputs["clearcoat"] = self.value(get("Coat Weight"), "float")
        inputs["clearcoatRoughness"] = self.value(get("Coat Roughness"), "float")
        if inputs["clearcoat"] == 0.0:
            return
        if _link(get("Coat IOR")) is not None or abs(_constant(get("Coat IOR"), "float") - 1.5) > 1e-4:
            self.warn(f"material '{self.material.name}': node '{node.name}' Coat IOR "
                      f"{_constant(get('Coat IOR'), 'float'):g} is written as 1.5 "
                      f"(UsdPreviewSurface's clearcoat)")
        if _link(get("Coat Tint")) is not None or _constant(get("Coat Tint"), "color") != (1.0, 1.0, 1.0):
            self.warn(f"material '{self.material.name}': node '{node.name}' Coat Tint is "
                      f"not exported (UsdPreviewSurface's clearcoat is white)")
        if _link(get("Coat Normal")) is not None:
            self.warn(f"material '{self.material.name}': node '{node.name}' Coat Normal is "
                      f"not exported (the coat uses the base normal)")

    def emission(self, color_socket, strength_socket, inputs, weight=1.0):
        """emissiveColor += weight x Color x Strength (Blender's emitted radiance).
        Emissions add up across Add and Mix Shaders; a texture carries the factor in
        its UsdUVTexture scale, and cannot be summed with another emission."""
        self.constant_only(strength_socket)
        factor = _constant(strength_socket, "float") * weight
        if factor == 0.0:
            return
        have = inputs.get("emissiveColor", (0.0, 0.0, 0.0))
        link = _link(color_socket)
        if link is not None and is_pattern(link.from_node) and (
                link.from_node.bl_idname != "ShaderNodeTexImage" or
                _computed_coordinates(link.from_node)):     # an image through Mapping too
            if isinstance(have, TexInput) or any(have) or \
                    "emissiveColor" in self.pattern.graph.outputs:
                self.warn(f"material '{self.material.name}': an emission from nodes cannot be "
                          f"added to another emission; keeping the first")
                return
            try:
                self.pattern.connect_scaled("emissiveColor", link, factor)
            except Unsupported as exc:
                self.unsupported(exc.node, exc.why)
            inputs["emissiveColor"] = tuple(c * factor for c in _constant(color_socket, "color"))
            return
        color = self.value(color_socket, "color")
        if isinstance(color, TexInput):
            if isinstance(have, TexInput) or any(have):
                self.warn(f"material '{self.material.name}': a textured emission cannot be "
                          f"added to another emission; keeping the first")
                return
            tex = dataclasses.replace(color.texture, scale=(factor, factor, factor, 1.0))
            inputs["emissiveColor"] = TexInput(tex, color.channel)
        elif isinstance(have, TexInput):
            if any(color):
                self.warn(f"material '{self.material.name}': a constant emission cannot be "
                          f"added to a textured one; keeping the texture")
        else:
            inputs["emissiveColor"] = tuple(h + c * factor for h, c in zip(have, color))

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
        inputs["opacity"] = self.value(socket, "float", "opacity")
        if getattr(self.material, "blend_method", None) == "CLIP":
            inputs["opacityThreshold"] = float(self.material.alpha_threshold)

    def shader(self, link, inputs, weight=1.0):
        """Fill `inputs` from the shader feeding Surface with closure weight `weight`;
        returns False if nothing fit. Only emission and sheen are weighted exactly: a BSDF's
        weight has no UsdPreviewSurface equivalent (one layer)."""
        node = link.from_node
        kind = node.bl_idname
        if kind == "ShaderNodeBsdfPrincipled":
            self.principled(node, inputs, weight)
        elif kind == "ShaderNodeBsdfDiffuse":
            inputs["diffuseColor"] = self.value(node.inputs["Color"], "color", "diffuseColor")
            inputs["roughness"] = 1.0
            inputs["ior"] = 1.0  # no specular layer
        elif kind in GLASS_BSDFS:
            # Clear glass of the node's Color (the tint), Roughness and IOR (Fresnel's
            # and Snell's); the Refraction BSDF is drawn as glass (with its reflection).
            inputs["diffuseColor"] = self.value(node.inputs["Color"], "color", "diffuseColor")
            inputs["metallic"] = 0.0
            inputs["roughness"] = self.value(node.inputs["Roughness"], "float", "roughness")
            self.constant_only(node.inputs["IOR"])
            inputs["ior"] = _constant(node.inputs["IOR"], "float")
            normal = self.normal(node.inputs["Normal"])
            if normal is not None:
                inputs["normal"] = normal
            self.transmission = 1.0
        elif kind == "ShaderNodeBsdfSheen":
            # Alone, the surface is the sheen: nothing else reflects.
            inputs.setdefault("diffuseColor", (0.0, 0.0, 0.0))
            inputs.setdefault("ior", 1.0)
            self.sheen_lobe(node, DISTRIBUTIONS[node.distribution], node.inputs["Color"], 1.0,
                            node.inputs["Roughness"], weight)
        elif kind == "ShaderNodeEmission":
            inputs.setdefault("diffuseColor", (0.0, 0.0, 0.0))
            inputs.setdefault("ior", 1.0)
            self.emission(node.inputs["Color"], node.inputs["Strength"], inputs, weight)
        elif kind in {"ShaderNodeAddShader", "ShaderNodeMixShader"}:
            links = [_link(s) for s in node.inputs if s.type == "SHADER"]
            if kind == "ShaderNodeMixShader":
                kinds = [link.from_node.bl_idname if link else None for link in links]
                if kinds.count("ShaderNodeBsdfTransparent") == 1:
                    return self.transparent_mix(node, links, kinds.index(
                        "ShaderNodeBsdfTransparent"), inputs, weight)
                if all(k in MIXABLE_BSDFS for k in kinds):
                    return self.bsdf_mix(node, links, inputs, weight)
            elif all(link is not None and link.from_node.bl_idname in MIXABLE_BSDFS
                     for link in links):
                return self.bsdf_add(node, links, inputs, weight)
            weights = [weight, weight]
            if kind == "ShaderNodeMixShader":
                fac = node.inputs[0]
                if _link(fac) is not None:
                    self.warn(f"material '{self.material.name}': node '{node.name}' (Mix Shader) "
                              f"factor is textured; both shaders are combined")
                else:
                    f = min(max(_constant(fac, "float"), 0.0), 1.0)
                    weights = [weight * (1.0 - f), weight * f]
            pairs = [(l, w) for l, w in zip(links, weights) if l is not None and w > 0.0]
            bsdfs = [w for l, w in pairs if l.from_node.bl_idname not in EXACTLY_WEIGHTED]
            if len(bsdfs) > 1 or (kind == "ShaderNodeMixShader" and
                                  any(w != weight for w in bsdfs)):
                self.warn(f"material '{self.material.name}': node '{node.name}' ({node.bl_label}) "
                          f"BSDF weights are not exported (UsdPreviewSurface has one layer); "
                          f"emission and sheen are weighted exactly")
            # Emission and sheen last so that they add to the BSDF rather than replace it.
            pairs.sort(key=lambda p: p[0].from_node.bl_idname in EXACTLY_WEIGHTED)
            return any([self.shader(l, inputs, w) for l, w in pairs])
        else:
            self.unsupported(node)
            return False
        return True

    def bsdf_add(self, node, links, inputs, weight):
        """An Add Shader of two Principled (or Diffuse) BSDFs: twice their even mix. The
        base colour doubles, which adds the diffuse and metallic lobes exactly where the
        two agree on the other inputs; the dielectric specular's F0 doubles, which
        overstates Fresnel's rise at grazing angles; emissions add, as before."""
        self.bsdf_mix(node, links, inputs, weight, added=True)
        base = inputs.get("diffuseColor")
        if "diffuseColor" in self.pattern.graph.outputs:
            self.pattern.scale("diffuseColor", 2.0)
        if isinstance(base, TexInput):
            scale = base.texture.scale
            inputs["diffuseColor"] = TexInput(dataclasses.replace(
                base.texture, scale=tuple(2.0 * s for s in scale[:3]) + tuple(scale[3:])),
                base.channel)
        elif isinstance(base, tuple):
            inputs["diffuseColor"] = tuple(2.0 * c for c in base)
        # Specular IOR Level 1 is twice the IOR's F0 (principled_ior).
        inputs["ior"] = principled_ior(inputs.get("ior", 1.5), 1.0)
        return True

    def bsdf_mix(self, node, links, inputs, weight, added=False):
        """A Mix Shader of two Principled (or Diffuse) BSDFs: one layer whose inputs mix
        by the factor. Exact where Cycles' closure mix is linear in them (base colour,
        metallic, alpha: the Principled BSDF blends its lobes by metallic too, and
        emission, weighted exactly as before); roughness and the other inputs mix as
        values (one warning where they differ). `added`: an Add Shader's two, mixed
        evenly, each emission whole (bsdf_add doubles the rest)."""
        fac = None if added else node.inputs[0]
        f = 0.5 if added else (None if _link(fac) is not None else
                               min(max(_constant(fac, "float"), 0.0), 1.0))
        sides = []
        shares = (1.0, 1.0) if added else (None if f is None else 1.0 - f, f)
        for link, share in zip(links, shares):
            side = {}
            self.shader(link, side, weight if share is None else weight * share)
            sides.append(side)
        # Emission adds across the two (weighted); the rest starts from the first.
        inputs.update({k: v for k, v in sides[0].items() if k != "emissiveColor"})
        emitted = [e for e in (s.get("emissiveColor", (0.0, 0.0, 0.0)) for s in sides)
                   if isinstance(e, TexInput) or any(e)]
        if emitted and f is None:
            self.warn(f"material '{self.material.name}': node '{node.name}' (Mix Shader) "
                      f"emission under a textured factor is not exported")
        elif len(emitted) > 1 and any(isinstance(e, TexInput) for e in emitted):
            inputs["emissiveColor"] = emitted[0]
            self.warn(f"material '{self.material.name}': a textured emission cannot be "
                      f"added to another emission; keeping the first")
        else:
            inputs["emissiveColor"] = emitted[0] if len(emitted) == 1 else \
                tuple(map(sum, zip(*emitted))) if emitted else (0.0, 0.0, 0.0)
        for target, (kind, names) in MIXED_INPUTS.items():
            sockets = [_bsdf_socket(l.from_node, names) for l in links]
            if all(s is None or _link(s) is None for s in sockets) and f is not None:
                a, b = (_constant(s, kind) if s is not None else MIXED_DEFAULTS[target]
                        for s in sockets)
                inputs[target] = tuple(x + (y - x) * f for x, y in zip(a, b)) \
                    if kind == "color" else a + (b - a) * f
                continue
            try:
                self.pattern.connect_mix(target, kind, fac, sockets,
                                         MIXED_DEFAULTS[target], factor=f)
            except Unsupported as exc:
                self.unsupported(exc.node, exc.why)
        iors = {_bsdf_ior(link.from_node) for link in links}
        if len(iors) > 1:
            self.warn(f"material '{self.material.name}': node '{node.name}' ({node.bl_label}) "
                      f"mixes BSDFs of different specular (IOR and Specular IOR Level); the "
                      f"first's is used")
        return True

    def transparent_mix(self, node, links, slot, inputs, weight):
        """A Mix Shader of a Transparent BSDF (in shader `slot`) and another shader: Cycles
        lets the transparent share of the light through, which is the surface's opacity
        (as the Principled BSDF's Alpha is): opacity = the other's share x its own."""
        transparent = links[slot].from_node
        color = transparent.inputs["Color"]
        if _link(color) is not None or tuple(_constant(color, "color")) != (1.0, 1.0, 1.0):
            self.warn(f"material '{self.material.name}': node '{transparent.name}' "
                      f"(Transparent BSDF) colour is not exported (white: uncoloured "
                      f"transparency)")
        other = links[1 - slot]
        filled = other is not None and self.shader(other, inputs, weight)
        if not filled:
            inputs.setdefault("diffuseColor", (0.0, 0.0, 0.0))
        fac = node.inputs[0]
        if _link(fac) is None:
            f = min(max(_constant(fac, "float"), 0.0), 1.0)
            share = f if slot == 0 else 1.0 - f          # the other shader's weight
            inputs["opacity"] = self.scaled_opacity(node, inputs.get("opacity", 1.0), share)
            return True
        if inputs.get("opacity", 1.0) != 1.0:
            self.warn(f"material '{self.material.name}': node '{node.name}' (Mix Shader) "
                      f"has a textured factor over a see-through shader; the factor alone "
                      f"is the opacity")
        opacity = self.value(fac, "float", "opacity")
        if slot == 1:                                     # opacity = 1 - factor
            if isinstance(opacity, TexInput):
                opacity = _remapped(opacity, -1.0, 1.0)
            else:
                if self.pattern.graph.outputs.get("opacity") is not None:
                    self.pattern.complement("opacity")
                opacity = 1.0 - float(opacity)           # and UsdPreviewSurface's fallback
        inputs["opacity"] = opacity
        return True

    def scaled_opacity(self, node, opacity, share):
        """`opacity` (a constant or a texture) times a constant share."""
        if isinstance(opacity, TexInput):
            return _remapped(opacity, share, 0.0)
        if self.pattern.graph.outputs.get("opacity") is not None and share != 1.0:
            self.warn(f"material '{self.material.name}': node '{node.name}' (Mix Shader) "
                      f"weight over a network's alpha is not exported; the network's alpha "
                      f"alone is the opacity")
            return opacity
        return float(opacity) * share


# BSDFs that are all transmission (contract: "Glass").
GLASS_BSDFS = {"ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction"}

# Shaders an Add or Mix Shader weights exactly: their closure weight scales them.
EXACTLY_WEIGHTED = {"ShaderNodeEmission", "ShaderNodeBsdfSheen"}

# BSDFs a Mix Shader mixes input by input (bsdf_mix), and those inputs: surface input ->
# (kind, {BSDF: socket}); a BSDF without the socket takes MIXED_DEFAULTS (a Diffuse
# BSDF: no metal, fully rough, opaque).
MIXABLE_BSDFS = {"ShaderNodeBsdfPrincipled", "ShaderNodeBsdfDiffuse"}
MIXED_INPUTS = {
    "diffuseColor": ("color", {"ShaderNodeBsdfPrincipled": "Base Color",
                               "ShaderNodeBsdfDiffuse": "Color"}),
    "metallic": ("float", {"ShaderNodeBsdfPrincipled": "Metallic"}),
    "roughness": ("float", {"ShaderNodeBsdfPrincipled": "Roughness"}),
    "opacity": ("float", {"ShaderNodeBsdfPrincipled": "Alpha"}),
}
MIXED_DEFAULTS = {"diffuseColor": (0.8, 0.8, 0.8), "metallic": 0.0, "roughness": 1.0,
                  "opacity": 1.0}


def _bsdf_ior(node) -> float:
    """The IOR a BSDF is written with (a Diffuse BSDF: 1, no specular layer)."""
    if node.bl_idname != "ShaderNodeBsdfPrincipled":
        return 1.0
    return round(principled_ior(_constant(node.inputs["IOR"], "float"),
                                _constant(node.inputs["Specular IOR Level"], "float")), 6)


def _bsdf_socket(node, names):
    name = names.get(node.bl_idname)
    return node.inputs[name] if name is not None else None


def _remapped(inp: TexInput, a: float, b: float) -> TexInput:
    """A texture input read as a * value + b (its UsdUVTexture scale and bias)."""
    tex = inp.texture
    return TexInput(dataclasses.replace(tex, scale=tuple(a * s for s in tex.scale),
                                        bias=tuple(a * t + b for t in tex.bias)), inp.channel)


def gather_material(material, warn, texture_dir=None):
    inputs = {
        "diffuseColor": tuple(material.diffuse_color[:3]),
        "metallic": float(material.metallic),
        "roughness": float(material.roughness),
        "ior": 1.5,
        "emissiveColor": (0.0, 0.0, 0.0),
        "opacity": 1.0,
    }
    tree, graph, walker = material.node_tree, None, None
    if tree is not None:
        walker = _Walker(material, warn, texture_dir)
        output = output_node(tree, "ShaderNodeOutputMaterial", f"material '{material.name}'", warn)
        link = _link(output.inputs["Surface"]) if output is not None else None
        if link is not None:
            found = {"emissiveColor": (0.0, 0.0, 0.0)}
            walker.shader(link, found)
            inputs.update(found)
            graph = walker.pattern.graph if walker.pattern.graph.outputs else None
    transmission = walker.transmission if walker is not None else 0.0
    mode = alpha_mode(material, inputs, graph)
    if transmission > 0.0:
        mode = see_through_glass(material, inputs, graph, transmission, warn)
    read = list(dict.fromkeys(n.settings["name"] for n in (graph.nodes if graph else ())
                              if n.kind == "attribute"))
    if len(read) > 1:      # one colour stream a material (engine/usd/mesh.py)
        warn(f"material '{material.name}': its network reads attributes "
             f"{', '.join(repr(n) for n in read)}; one attribute a material is drawn, so "
             f"each of them reads {read[0]!r}")
    return MaterialRecord(key=material.name_full, name=material.name, inputs=inputs,
                          backface_culling=bool(material.use_backface_culling),
                          pass_index=int(material.pass_index),
                          alpha_mode=mode, graph=graph, transmission=transmission,
                          bump_correction=bump_correction(material),
                          emission_sampling=emission_sampling(material),
                          base_occlusion=walker is not None and walker.base_occlusion,
                          sheen=walker.sheen if walker is not None else None)


def see_through_glass(material, inputs, graph, transmission, warn) -> str:
    """A transmissive material's `opacity` and `ior` say "translucent" to every reader:
    opacity = 1 - transmission (lantern:transmission says the rest, contract "Glass").
    Its Alpha is not exported (one warning where it is not 1). Returns its alpha mode:
    none."""
    alpha = inputs.get("opacity", 1.0)
    if isinstance(alpha, TexInput) or alpha != 1.0 or (graph is not None and
                                                         "opacity" in graph.outputs):
        warn(f"material '{material.name}': Alpha of a transmissive material is not "
             f"exported (glass is drawn whole)")
        if graph is not None:
            graph.outputs.pop("opacity", None)
    inputs["opacity"] = 1.0 - transmission
    inputs.pop("opacityThreshold", None)
    return ""


def bump_correction(material) -> bool:
    """Cycles' Bump Map Correction (Material > Settings, on by default). Without the
    Cycles add-on's settings, its default."""
    settings = getattr(material, "cycles", None)
    return bool(getattr(settings, "use_bump_map_correction", True))


def emission_sampling(material) -> str:
    """Cycles' Emission Sampling (Material > Settings) as a core/emission.py token;
    without the Cycles add-on's settings, its default."""
    settings = getattr(material, "cycles", None)
    return EMISSION_SAMPLING.get(getattr(settings, "emission_sampling", "AUTO"), DEFAULT_SAMPLING)


def alpha_mode(material, inputs, graph=None) -> str:
    """"hashed" for a material that is see-through and set to Blender's Dithered render
    method (EEVEE's hashed alpha, Blender 4.2+'s default), else "". UsdPreviewSurface
    itself says the rest: `opacityThreshold` > 0 is a cut-out (clip), an opacity below 1
    or from a texture without a threshold is blended (Blender's Blended render method)."""
    opacity = inputs.get("opacity", 1.0)
    see_through = isinstance(opacity, TexInput) or opacity < 1.0 or \
        (graph is not None and "opacity" in graph.outputs)
    if not see_through or inputs.get("opacityThreshold", 0.0) > 0.0:
        return ""
    return "hashed" if getattr(material, "surface_render_method", "DITHERED") == "DITHERED" else ""
