"""The depsgraph's instances -> prototypes and per-instancer placements; particles and
point clouds -> points.

Blender lists every instance (collection instances, geometry-nodes instances, particle
instances, instancing by vertices or faces) in `depsgraph.object_instances`, flattened,
with its world matrix and the object that generated it (`inst.parent`). It also lists
geometry an object makes beyond its own type there, as an instance of the object
itself (a curve's or text's mesh, a geometry-nodes point cloud or hair). Instance
objects live only while the iterator is on them, so everything is read on the spot.
"""
import numpy as np

from ..errors import require_finite
from ..ir import InstancesRecord, PointsRecord, PrototypeRecord
from .curves import gather_curves
from .mesh import _get, color_attribute_names, gather_mesh
from .tangents import mikktspace_tangents, tangent_uv_map

# persistent_id entries past the instance's own level are this.
NO_ID = 2 ** 31 - 1
MESH_LIKE = {"MESH", "CURVE", "SURFACE", "FONT", "META"}
# Not exported. Hair curves are (gather/curves.py), but not as instances' prototypes.
UNSUPPORTED = {"CURVES": "instanced hair curves", "VOLUME": "volumes",
               "GREASEPENCIL": "grease pencil", "GPENCIL": "grease pencil"}
# Blender's point radius when a point cloud has none.
DEFAULT_RADIUS = 0.01


def unsupported_warning(name, kind):
    return f"object '{name}': {kind} are not supported; skipped"


def faceless_warning(name, vertices, edges):
    return (f"object '{name}': a mesh with no faces ({vertices} vertices, {edges} edges) "
            "has nothing to render; skipped")


def own_component(inst):
    """True for geometry an object makes beyond its own type (not an instance)."""
    return inst.object.original == inst.parent.original and inst.persistent_id[1] == NO_ID


def pointcloud_points(pointcloud, name):
    """(N, 3) positions and (N,) diameters of a point cloud's points."""
    attributes = pointcloud.attributes
    position = attributes.get("position")
    n = len(position.data) if position is not None else 0
    points = _get(position.data, "vector", np.float32, 3) if n else np.zeros((0, 3), np.float32)
    radius = attributes.get("radius")
    if radius is not None and len(radius.data) == n:
        widths = 2.0 * _get(radius.data, "value", np.float32, 1)
    else:
        widths = np.full(n, 2.0 * DEFAULT_RADIUS, np.float32)
    return PointsRecord(name=name, points=points, widths=widths)


def particle_points(ob_eval, world_inverse, warn):
    """Points of the emitter particle systems rendered as halos, in the object's space;
    particle hair and path rendering are not supported (a warning each)."""
    name = ob_eval.original.name
    chunks, widths = [], []
    for modifier in ob_eval.original.modifiers:
        if modifier.type != "PARTICLE_SYSTEM" or not modifier.show_viewport:
            continue
        system = ob_eval.particle_systems.get(modifier.particle_system.name)
        if system is None:
            continue
        settings = system.settings
        if settings.type == "HAIR" or settings.render_type == "PATH":
            warn(f"object '{name}': particle system '{system.name}' renders hair or paths, "
                 "which are not supported; skipped")
            continue
        if settings.render_type != "HALO":
            continue  # objects and collections come as instances; NONE renders nothing
        particles = system.particles
        if not len(particles):
            continue
        location = _get(particles, "location", np.float64, 3)
        size = _get(particles, "size", np.float32, 1)
        state = [p.alive_state for p in particles]
        keep = np.array([s == "ALIVE" or (s == "UNBORN" and settings.show_unborn)
                         or (s == "DEAD" and settings.use_dead) for s in state], dtype=bool)
        local = location[keep] @ world_inverse[:3, :3].T + world_inverse[:3, 3]
        chunks.append(local.astype(np.float32))
        widths.append(2.0 * size[keep])
    if not chunks:
        return None
    return PointsRecord(name=f"{name}_particles", points=np.concatenate(chunks),
                        widths=np.concatenate(widths).astype(np.float32))


class InstanceGatherer:
    """Collects, while the depsgraph iterates, each instancer's placements and each
    prototype's data (once), and geometry components objects make beyond their type."""

    def __init__(self, rec, warn, shareable, material_users):
        self.rec, self.warn = rec, warn
        self.shareable = shareable        # original object -> True when data == evaluated
        self.material_users = material_users  # material key -> original Material
        self.placements = {}              # instancer key -> [(prototype key, world matrix)]
        self.points = {}                  # object key -> PointsRecord (own components)
        self.curves = {}                  # object key -> [CurvesRecord] (own components)
        self.shared_data = set()          # mesh data names prototypes write once
        self._geometry = {}               # (instancer, data pointer) -> prototype key
        self._skipped = set()

    def add(self, inst):
        instancer = inst.parent.original
        if own_component(inst):
            self._own(inst, instancer)
            return
        key = self._prototype(inst, instancer)
        if key is not None:
            self.placements.setdefault(instancer.name_full, []).append(
                (key, np.array(inst.matrix_world, dtype=np.float64)))

    def _own(self, inst, ob):
        kind = inst.object.type
        if kind == "POINTCLOUD":
            points = pointcloud_points(inst.object.data, f"{ob.name}_points")
            require_finite(points.points, f"object '{ob.name}'", "point positions")
            self.points[ob.name_full] = points
        elif kind == "CURVES":
            self.curves[ob.name_full] = gather_curves(inst.object.data, f"{ob.name}_curves",
                                                      f"object '{ob.name}'", self.warn)
        elif kind in UNSUPPORTED:
            self.warn(unsupported_warning(ob.name, UNSUPPORTED[kind]))
        # MESH: the object's own evaluated mesh, read with to_mesh like any object's

    def _prototype(self, inst, instancer):
        ob = inst.object
        orig = ob.original
        if orig == instancer:  # geometry-nodes geometry: keyed by its data
            slot = (instancer.name_full, ob.data.as_pointer() if ob.data else 0)
            key = self._geometry.get(slot)
            if key is None:
                key = f"geometry:{instancer.name_full}:{len(self._geometry)}"
                self._geometry[slot] = key
            name = f"{instancer.name}_geometry"
        else:
            key, name = f"object:{orig.name_full}", orig.name
        if key in self.rec.prototypes:
            return key
        if key in self._skipped:
            return None
        proto = self._gather(ob, key, name, instancer)
        if proto is None:
            self._skipped.add(key)
            return None
        self.rec.prototypes[key] = proto
        return key

    def _gather(self, ob, key, name, instancer):
        kind = ob.type
        if kind == "POINTCLOUD":
            points = pointcloud_points(ob.data, name)
            require_finite(points.points, f"object '{name}'", "point positions")
            return PrototypeRecord(key=key, name=name, points=points)
        if kind in UNSUPPORTED:
            self.warn(unsupported_warning(ob.original.name, UNSUPPORTED[kind]))
            return None
        if kind == "LIGHT":
            self.warn(f"object '{instancer.name}': it instances lights, which are not "
                      "exported as instances; skipped")
            return None
        if kind not in MESH_LIKE:
            return None  # empties, cameras, armatures: nothing to draw
        orig = ob.original
        if orig != instancer and self.shareable(orig):
            mesh_key = "proto:" + orig.data.name_full
            self.shared_data.add(orig.data.name_full)
        else:
            mesh_key = "instance:" + key
        if mesh_key not in self.rec.meshes:
            mesh = ob.to_mesh()
            try:
                if len(mesh.polygons) == 0:
                    if len(mesh.vertices):
                        self.warn(faceless_warning(name, len(mesh.vertices), len(mesh.edges)))
                    return None
                data_name = orig.data.name if orig != instancer and orig.type == "MESH" else name
                materials = [s.material for s in ob.material_slots]
                record = gather_mesh(mesh, mesh_key, data_name, f"object '{name}'",
                                     color_attribute_names(materials), self.warn)
                uv_map = tangent_uv_map(materials)
                if uv_map is not None:
                    record.tangents = mikktspace_tangents(mesh, uv_map)
                self.rec.meshes[mesh_key] = record
            finally:
                ob.to_mesh_clear()
        materials = []
        for slot in ob.material_slots:
            material = slot.material.original if slot.material is not None else None
            if material is not None:
                self.material_users.setdefault(material.name_full, material)
            materials.append(material.name_full if material is not None else None)
        return PrototypeRecord(key=key, name=name, mesh=mesh_key, materials=materials)

    def instances_of(self, key, instancer_world):
        """InstancesRecord of the instancer `key`, placed relative to its world matrix."""
        from .skeleton import affine_inverse, trs_parts
        placements = self.placements.get(key)
        if not placements:
            return None
        prototypes = sorted({p for p, _ in placements})
        index = {p: i for i, p in enumerate(prototypes)}
        worlds = np.stack([m for _, m in placements])
        require_finite(worlds, f"object '{key}'", "instance transforms")
        matrices = affine_inverse(instancer_world) @ worlds
        parts, exact = trs_parts(matrices)
        return InstancesRecord(
            prototypes=prototypes,
            proto_indices=np.array([index[p] for p, _ in placements], dtype=np.int32),
            matrices=matrices, trs=parts, exact=exact)
