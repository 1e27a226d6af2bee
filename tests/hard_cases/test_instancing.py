"""Instancing, export side: collection instances, geometry-nodes instances, particle
instances and instancing by vertices become UsdGeom.PointInstancers whose prototypes
are written once; particles and point clouds become UsdGeom.Points.

Each instance's transform, as USD computes it (PointInstancer.
ComputeInstanceTransformsAtTime × the instancer's world), matches Blender's depsgraph
instance matrix within 1e-5 of the scene's bounding-box diagonal. The engine draws
them (engine/usd/read_instancers.py), and the render test below checks it."""
import numpy as np
import pytest

BOUND = 1e-5


def _mesh_object(name, location=(0, 0, 0), collection=None):
    import bpy
    from _export_helpers import CUBE_FACES, CUBE_VERTS
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(CUBE_VERTS, [], CUBE_FACES)
    mesh.update()
    ob = bpy.data.objects.new(name, mesh)
    (collection or bpy.context.scene.collection).objects.link(ob)
    ob.location = location
    return ob


def _instance_node_group():
    """Geometry nodes: a cube instanced on the input's points, rotated and scaled."""
    import bpy
    tree = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    group_in, group_out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    on_points = nodes.new("GeometryNodeInstanceOnPoints")
    cube = nodes.new("GeometryNodeMeshCube")
    cube.inputs["Size"].default_value = (0.3, 0.2, 0.1)
    on_points.inputs["Rotation"].default_value = (0.3, 0.5, 0.7)
    on_points.inputs["Scale"].default_value = (1.0, 2.0, 0.5)
    links.new(group_in.outputs[0], on_points.inputs["Points"])
    links.new(cube.outputs[0], on_points.inputs["Instance"])
    links.new(on_points.outputs[0], group_out.inputs[0])
    return tree


def _instancing_scene():
    """Every kind of instance in one scene; returns the instancer objects."""
    import bpy
    scene = bpy.context.scene
    hidden = bpy.data.collections.new("Library")
    scene.collection.children.link(hidden)
    bpy.context.view_layer.layer_collection.children["Library"].exclude = True
    piece = _mesh_object("Piece", collection=hidden)
    piece.rotation_euler = (0.2, 0.1, 0.4)
    piece.scale = (0.5, 0.25, 0.4)
    _mesh_object("Other", location=(0, 2, 0), collection=hidden)

    empties = []
    for i in range(3):  # the same collection instanced three times
        empty = bpy.data.objects.new(f"Instancer{i}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = hidden
        empty.location = (4.0 * i, 10, 0)
        empty.rotation_euler = (0, 0, 0.5 * i)
        empty.scale = (1, 1 + i, 1)
        scene.collection.objects.link(empty)
        empties.append(empty)

    grid = _mesh_object("Scatter", location=(0, -10, 0))
    modifier = grid.modifiers.new("Scatter", "NODES")
    modifier.node_group = _instance_node_group()

    emitter = _mesh_object("Emitter", location=(10, 0, 0))
    system = emitter.modifiers.new("Particles", "PARTICLE_SYSTEM").particle_system
    settings = system.settings
    settings.count, settings.frame_start, settings.frame_end = 12, 1, 1
    settings.physics_type, settings.render_type = "NO", "OBJECT"
    settings.instance_object = piece
    settings.use_rotation_instance = True

    verts = _mesh_object("Verts", location=(-10, 0, 0))
    verts.instance_type = "VERTS"
    child = _mesh_object("VertChild", location=(-10, 0, 0))
    child.scale = (0.2, 0.2, 0.2)
    child.parent = verts
    return empties + [grid, emitter, verts]


def _usd_instance_worlds(stage, instancer_path):
    from pxr import Usd, UsdGeom
    prim = stage.GetPrimAtPath(instancer_path)
    pi = UsdGeom.PointInstancer(prim)
    xforms = pi.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default())
    parent = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
    protos = pi.GetPrototypesRel().GetTargets()
    indices = list(pi.GetProtoIndicesAttr().Get())
    # USD row-vector matrices -> Blender's column-vector convention.
    worlds = [(np.array(m) @ parent).T for m in xforms]
    names = [stage.GetPrimAtPath(protos[i]).GetAttribute("lantern:blenderName").Get()
             for i in indices]
    return worlds, names


def test_every_kind_of_instance_matches_blenders_matrices(empty_scene, hard_case):
    import bpy
    from _export_helpers import export_current, object_paths
    from pxr import UsdGeom
    instancers = _instancing_scene()
    stage, report = export_current()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    expected = {}
    for inst in depsgraph.object_instances:
        if inst.is_instance and inst.parent.original in instancers:
            name = inst.object.original.name
            if inst.object.original == inst.parent.original:
                name = f"{name}_geometry"
            expected.setdefault(inst.parent.original.name, []).append(
                (name, np.array(inst.matrix_world, dtype=np.float64)))
    all_points = np.concatenate([[m[:3, 3] for _, m in v] for v in expected.values()])
    diag = float(np.linalg.norm(all_points.max(0) - all_points.min(0)))

    paths = object_paths(stage)
    worst, count = 0.0, 0
    for ob in instancers:
        children = [c for c in stage.GetPrimAtPath(paths[ob.name]).GetChildren()
                    if c.IsA(UsdGeom.PointInstancer)]
        assert len(children) == 1, f"{ob.name}: one PointInstancer expected"
        worlds, names = _usd_instance_worlds(stage, children[0].GetPath())
        want = expected[ob.name]
        assert len(worlds) == len(want) > 0, ob.name
        assert names == [n for n, _ in want], ob.name
        for got, (_, m) in zip(worlds, want):
            worst = max(worst, float(np.abs(got - m).max()))
        count += len(want)
    assert count == 3 * 2 + 8 + 12 + 8  # collections, geometry nodes, particles, vertices
    hard_case("PointInstancer transforms vs depsgraph instance matrices / diag",
              worst / diag, BOUND)


def test_prototypes_are_written_once(empty_scene):
    from _export_helpers import export_current
    from pxr import UsdGeom
    _instancing_scene()
    stage, report = export_current()
    prototypes = stage.GetPrimAtPath("/root/_prototypes")
    assert prototypes.IsAbstract()
    meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    data = {}
    for prim in [p for p in prototypes.GetAllChildren()]:
        for child in [prim] + list(prim.GetAllChildren()):
            if child.IsA(UsdGeom.Mesh):
                data.setdefault(str(child.GetAttribute("lantern:blenderName").Get()), []).append(child)
    # Piece (collection and particles), Other, the GN cube, VertChild: one data prim each.
    names = sorted(p.GetName() for p in prototypes.GetAllChildren())
    assert len([n for n in names if n.startswith("Piece")]) == 2, names  # data + prototype
    # Every instancer targets prototypes inside the class prim.
    for prim in stage.Traverse():
        if prim.IsA(UsdGeom.PointInstancer):
            for target in UsdGeom.PointInstancer(prim).GetPrototypesRel().GetTargets():
                assert target.HasPrefix("/root/_prototypes"), target
    assert not any("not exported" in w for w in report.warnings), report.warnings
    assert meshes  # the emitter, the grid and the vertex parent are still meshes


def test_a_negative_control_catches_a_wrong_instance(empty_scene):
    """Moving one instance by 1e-3 of the diagonal fails the comparison above."""
    import bpy
    from _export_helpers import export_current, object_paths
    from pxr import UsdGeom, Vt
    instancers = _instancing_scene()
    stage, _ = export_current()
    grid = next(ob for ob in instancers if ob.name == "Scatter")
    prim = next(c for c in stage.GetPrimAtPath(object_paths(stage)["Scatter"]).GetChildren()
                if c.IsA(UsdGeom.PointInstancer))
    positions = np.array(UsdGeom.PointInstancer(prim).GetPositionsAttr().Get())
    positions[0] += 0.01
    UsdGeom.PointInstancer(prim).GetPositionsAttr().Set(Vt.Vec3fArray.FromNumpy(
        positions.astype(np.float32)))
    worlds, _ = _usd_instance_worlds(stage, prim.GetPath())
    depsgraph = bpy.context.evaluated_depsgraph_get()
    want = [np.array(i.matrix_world) for i in depsgraph.object_instances
            if i.is_instance and i.parent.original == grid]
    assert max(float(np.abs(g - w).max()) for g, w in zip(worlds, want)) > 1e-3


def test_particles_and_point_clouds_become_points(empty_scene, hard_case):
    import bpy
    from _export_helpers import export_current, object_paths
    from pxr import UsdGeom
    emitter = _mesh_object("Halos", location=(1, 2, 3))
    system = emitter.modifiers.new("Particles", "PARTICLE_SYSTEM").particle_system
    settings = system.settings
    settings.count, settings.frame_start, settings.frame_end = 20, 1, 1
    settings.physics_type, settings.render_type = "NO", "HALO"
    settings.particle_size = 0.07

    cloud = _mesh_object("Cloud", location=(-3, 0, 0))
    tree = bpy.data.node_groups.new("ToPoints", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group_in, group_out = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    to_points = tree.nodes.new("GeometryNodeMeshToPoints")
    to_points.inputs["Radius"].default_value = 0.125
    tree.links.new(group_in.outputs[0], to_points.inputs["Mesh"])
    tree.links.new(to_points.outputs[0], group_out.inputs[0])
    cloud.modifiers.new("Points", "NODES").node_group = tree

    stage, report = export_current()
    paths = object_paths(stage)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = emitter.evaluated_get(depsgraph)
    expected = np.array([p.location for p in ev.particle_systems[0].particles])

    points = [c for c in stage.GetPrimAtPath(paths["Halos"]).GetChildren() if c.IsA(UsdGeom.Points)]
    assert len(points) == 1
    p = UsdGeom.Points(points[0])
    local = np.array(p.GetPointsAttr().Get(), np.float64)
    world = np.array(p.ComputeLocalToWorldTransform(0.0))
    got = local @ world[:3, :3] + world[3, :3]
    diag = float(np.linalg.norm(expected.max(0) - expected.min(0)))
    hard_case("halo particles as Points vs particle locations / diag",
              np.abs(got - expected).max() / diag, BOUND)
    assert np.allclose(p.GetWidthsAttr().Get(), 0.14)

    cloud_points = [c for c in stage.GetPrimAtPath(paths["Cloud"]).GetChildren()
                    if c.IsA(UsdGeom.Points)]
    assert len(cloud_points) == 1
    got = np.array(UsdGeom.Points(cloud_points[0]).GetPointsAttr().Get())
    from _export_helpers import CUBE_VERTS
    assert np.allclose(np.sort(got, axis=0), np.sort(np.array(CUBE_VERTS, float), axis=0))
    assert np.allclose(UsdGeom.Points(cloud_points[0]).GetWidthsAttr().Get(), 0.25)
    # The cloud's own mesh is empty: no mesh prim, and no faceless warning.
    assert not any("Cloud" in w for w in report.warnings), report.warnings


def _made_real(instancers):
    """Every mesh Blender renders (instances and the instancers' own geometry, as the
    depsgraph lists them), as plain objects with their evaluated meshes; the originals
    hidden."""
    import bpy
    depsgraph = bpy.context.evaluated_depsgraph_get()
    copies = []
    for i in depsgraph.object_instances:
        if i.object.type != "MESH":
            continue
        matrix = np.array(i.matrix_world)    # before new data invalidates the iterator's
        mesh = bpy.data.meshes.new_from_object(i.object)
        if len(mesh.polygons):
            copies.append((mesh, matrix))
    for ob in list(bpy.context.scene.objects):
        ob.hide_render = True
    from mathutils import Matrix
    for mesh, matrix in copies:
        ob = bpy.data.objects.new(mesh.name, mesh)
        bpy.context.scene.collection.objects.link(ob)
        ob.matrix_world = Matrix(matrix.astype(np.float64).tolist())
    return copies


def test_instances_render_like_the_same_objects_made_real(empty_scene, hard_case):
    from _export_helpers import export_current
    from pxr import UsdGeom
    from lantern.engine import RenderSettings, render_stage
    instancers = _instancing_scene()
    stage, _ = export_current()
    copies = _made_real(instancers)
    real, _ = export_current()
    meshes = [p for p in real.Traverse() if p.GetTypeName() == "Mesh"]
    assert len(meshes) == len(copies) > 34
    assert not any(p.IsA(UsdGeom.PointInstancer) for p in real.Traverse())
    # Without ambient occlusion, FXAA or supersampling: they read their neighbours, so the few pixels
    # decided by the last bit of depth (below) would spread into their surroundings.
    # Direct light: the bounce's reflections and field are traced, and a ray grazing
    # where the crossing faces meet takes either face as well (the instancing it
    # tests is the same with or without them).
    from lantern.engine.bounces import DIRECT
    settings = RenderSettings(width=96, height=54, ambient_occlusion=False, fxaa=False,
                              supersample=1, bounces=DIRECT)
    a = render_stage(stage, settings)
    b = render_stage(real, settings)
    assert np.isfinite(a.rgba).all() and not a.warnings
    assert a.stats["instances_drawn"] == 34
    diff = np.abs(a.rgba - b.rgba).max(axis=-1)
    # Two particles land on the same spot with different turns: where their faces
    # cross, the nearer one is decided by the last bit of depth, so a few pixels there
    # may go either way; everywhere else the images agree.
    hard_case("every kind of instance (34, GPU-instanced) vs the same meshes made real: "
              "pixels differing by > 1e-3", int((diff > 1e-3).sum()), 8, "px")
    hard_case("every kind of instance vs made real: mean abs difference over the image's mean",
              float(diff.mean() / b.rgba[..., :3].mean()), 1e-3)


def test_instance_matrices_match_usds_own(empty_scene, hard_case):
    """The engine's vectorised instance matrices (engine/usd/instancers.py) against
    UsdGeom.PointInstancer.ComputeInstanceTransformsAtTime, on every instancer the
    exporter wrote."""
    from _export_helpers import export_current
    from pxr import Usd, UsdGeom
    from lantern.engine.usd.instancers import instance_matrices
    _instancing_scene()
    stage, _ = export_current()
    worst, n = 0.0, 0
    t = Usd.TimeCode.Default()
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.PointInstancer):
            continue
        warnings = []
        protos, indices, mats, keep = instance_matrices(prim, t, warnings)
        assert not warnings and keep.all()
        want = [np.array(m, np.float64).T for m in
                UsdGeom.PointInstancer(prim).ComputeInstanceTransformsAtTime(
                    t, t, UsdGeom.PointInstancer.ExcludeProtoXform)]
        for got, w in zip(mats, want):
            worst = max(worst, float(np.abs(got - w).max()) / max(1.0, float(np.abs(w).max())))
        n += len(want)
    assert n == 34
    hard_case("instance matrices (numpy, all at once) vs ComputeInstanceTransformsAtTime, "
              "relative", worst, 1e-6)
