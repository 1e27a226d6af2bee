"""A Blender world -> WorldRecord (the dome light)."""
import os

import bpy

from ..ir import WorldRecord
from .material import _constant, _link


def gather_world(world, warn):
    rec = WorldRecord(name=world.name, color=tuple(float(c) for c in world.color))
    tree = world.node_tree
    if tree is None:
        return rec
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    link = _link(output.inputs["Surface"]) if output is not None else None
    if link is None:
        return rec
    node = link.from_node
    if node.bl_idname != "ShaderNodeBackground":
        warn(f"world '{world.name}': node '{node.name}' ({node.bl_idname}) is not supported; "
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
        image = env.image
        path = os.path.normpath(bpy.path.abspath(image.filepath, library=image.library))
        if image.packed_file is None and not os.path.isfile(path):
            warn(f"world '{world.name}': environment image not found: {image.filepath} ({path}); "
                 f"using the Background colour")
        elif image.packed_file is not None:
            warn(f"world '{world.name}': packed environment image '{image.name}' is not "
                 f"exported; using the Background colour")
        else:
            rec.texture = path
            rec.color = (1.0, 1.0, 1.0)  # the texture carries the colour
    else:
        warn(f"world '{world.name}': node '{env.name}' ({env.bl_idname}) on the Background "
             f"colour is not supported; using its constant colour")
    return rec
