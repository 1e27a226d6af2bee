"""A Blender world -> WorldRecord (the dome light).

The Environment Texture's orientation is Blender's equirectangular mapping, optionally
turned by a Mapping node's rotation on its Vector input; usd/world.py turns that into
the DomeLight's transform (see docs/stage_contract.md, "World")."""
import math

from ..ir import WorldRecord
from .image import image_file
from .material import _constant, _link, output_node


def _mapping_rotation(env, owner, warn):
    """Euler XYZ rotation (radians) of a Mapping node feeding the texture's Vector, as
    Blender's USD exporter reads it; (0, 0, 0) without one."""
    link = _link(env.inputs["Vector"])
    if link is None:
        return (0.0, 0.0, 0.0)
    node = link.from_node
    if node.bl_idname != "ShaderNodeMapping":
        if node.bl_idname == "ShaderNodeTexCoord" and link.from_socket.name == "Generated":
            return (0.0, 0.0, 0.0)  # the world's Generated coordinates are the view direction
        warn(f"{owner}: node '{node.name}' ({node.bl_idname}) on the environment's Vector is "
             f"not supported; using the plain direction")
        return (0.0, 0.0, 0.0)
    rotation = tuple(float(a) for a in node.inputs["Rotation"].default_value)
    if node.vector_type not in {"POINT", "VECTOR"} or _link(node.inputs["Rotation"]) is not None:
        warn(f"{owner}: node '{node.name}' (Mapping, {node.vector_type}) is exported as a "
             f"point rotation only")
    scale = tuple(node.inputs["Scale"].default_value) if "Scale" in node.inputs else (1, 1, 1)
    location = tuple(node.inputs["Location"].default_value) if "Location" in node.inputs else (0, 0, 0)
    if any(abs(s - scale[0]) > 1e-6 for s in scale) or \
            (node.vector_type == "POINT" and any(abs(v) > 1e-6 for v in location)):
        warn(f"{owner}: node '{node.name}' (Mapping) location and non-uniform scale are "
             f"ignored; only its rotation orients the dome")
    src = _link(node.inputs["Vector"])
    if src is not None and not (src.from_node.bl_idname == "ShaderNodeTexCoord"
                                and src.from_socket.name == "Generated"):
        warn(f"{owner}: node '{src.from_node.name}' ({src.from_node.bl_idname}) before the "
             f"Mapping node is not supported; using the plain direction")
    return tuple(a if math.isfinite(a) else 0.0 for a in rotation)


def gather_world(world, warn, texture_dir=None):
    owner = f"world '{world.name}'"
    rec = WorldRecord(name=world.name, color=tuple(float(c) for c in world.color))
    tree = world.node_tree
    if tree is None:
        return rec
    output = output_node(tree, "ShaderNodeOutputWorld", owner, warn)
    link = _link(output.inputs["Surface"]) if output is not None else None
    if link is None:
        return rec
    node = link.from_node
    if node.bl_idname != "ShaderNodeBackground":
        warn(f"{owner}: node '{node.name}' ({node.bl_idname}) is not supported; "
             f"using the world colour")
        return rec
    color_socket = node.inputs["Color"]
    rec.color = _constant(color_socket, "color")
    rec.intensity = _constant(node.inputs["Strength"], "float")
    src = _link(color_socket)
    if src is None:
        return rec
    env = src.from_node
    if env.bl_idname == "ShaderNodeTexEnvironment" and env.image is not None:
        if env.projection != "EQUIRECTANGULAR":
            warn(f"{owner}: node '{env.name}' projection {env.projection} is not supported; "
                 f"using the Background colour")
            return rec
        path = image_file(env.image, f"{owner}, environment image", warn, texture_dir)
        if path is None:
            return rec  # image_file warned; the dome keeps the Background colour
        rec.texture = path
        rec.color = (1.0, 1.0, 1.0)  # the texture carries the colour
        rec.rotation = _mapping_rotation(env, owner, warn)
    else:
        warn(f"{owner}: node '{env.name}' ({env.bl_idname}) on the Background "
             f"colour is not supported; using its constant colour")
    return rec
