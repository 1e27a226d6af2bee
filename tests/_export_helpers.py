"""Shared helpers for the procedural export tests."""
import bpy
import numpy as np
from pxr import Usd

from lantern.exporters import export_depsgraph, validation_errors

CUBE_VERTS = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
CUBE_FACES = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]


def cube_object(name, mesh=None):
    if mesh is None:
        mesh = bpy.data.meshes.new(name + "_mesh")
        mesh.from_pydata(CUBE_VERTS, [], CUBE_FACES)
        mesh.update()
    ob = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def export_current(options=None, path=None):
    """Exports the current scene into a new stage (in memory unless `path`)."""
    bpy.context.view_layer.update()
    stage = Usd.Stage.CreateNew(str(path)) if path else Usd.Stage.CreateInMemory()
    report = export_depsgraph(bpy.context.evaluated_depsgraph_get(), stage, options)
    assert validation_errors(stage) == []
    return stage, report


def evaluated_mesh_data(ob, fn):
    deps = bpy.context.evaluated_depsgraph_get()
    ev = ob.evaluated_get(deps)
    mesh = ev.to_mesh()
    try:
        return fn(mesh)
    finally:
        ev.to_mesh_clear()


def vectors(collection, attr="vector", width=3):
    out = np.empty(len(collection) * width, dtype=np.float32)
    collection.foreach_get(attr, out)
    return out.reshape(-1, width)
