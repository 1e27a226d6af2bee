"""The irradiance field's tables of what its rays meet (engine/gpu/passes/irradiance.py,
shaders/irradiance_trace.comp, and the final gather's, shaders/gather_trace.comp; both
shade hits by shaders/field_hits.glsl): per traced material, its albedo, emission and
what it lets through; per traced instance, which sides of its emitting faces are lights
of the light table.

A hit's albedo is its material's base colour times (1 - metallic), its emission the
material's emission colour, a texture map's mean colour where one is bound (the hit's
texel is not sampled), the constant where a pattern network feeds them. Glass keeps the
diffuse share 1 - transmission of its albedo and passes rays and shadow rays straight
on, weighted by transmission x base colour and Fresnel's transmittance at its IOR (a
pane's exactly; a curved object's refraction is not followed)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.emission import SAMPLING
from ..emitters import makes_lights, radiance
from ..mesh_topology import closed
from .programs import UNITS, set_uniform

MATERIAL_TEXELS = 3          # shaders/field_hits.glsl FIELD_MATERIAL
SIDES_BINDING = 15           # shaders/field_hits.glsl FieldSides


@dataclass
class HitTables:
    """What shaders/field_hits.glsl shades a traced hit with, made with a field's build:
    the materials' table (a texture), the instances' sides (a storage buffer), the dome's
    map (None: its spherical harmonics), the view's forward (a headlight's), the rays'
    epsilon, and whether some material transmits."""
    materials: object
    sides: object
    env: object
    forward: np.ndarray
    epsilon: float
    glass: bool

    def defines(self) -> list:
        return ["HAS_DOME_MAP"] if self.env is not None else []

    def bind(self, prog, scene, field, tracer, lights, environment, bounce: bool,
             light=None):
        """Into `prog`: these tables, the tracer, the light table, the dome and `field`
        (read at hits where `bounce`; `light`: another Field of its grids whose light is
        read through `field`'s distances and walls)."""
        tracer.bind()
        self.sides.bind_to_storage_buffer(SIDES_BINDING)
        field.bind(prog, light)
        self.materials.use(UNITS["field_materials"])
        if lights.texture is not None:
            lights.texture.use(UNITS["u_lights"])
        environment.bind(prog, scene.dome, self.env)
        set_uniform(prog, "has_dome", scene.dome is not None)
        set_uniform(prog, "n_lights", len(lights.index))
        set_uniform(prog, "u_bounce", bounce)
        set_uniform(prog, "u_glass", self.glass)
        set_uniform(prog, "u_epsilon", self.epsilon)
        set_uniform(prog, "u_view_forward", self.forward)

    def release(self):
        self.materials.release()
        self.sides.release()


def material_table(scene, names, textures) -> np.ndarray:
    """The tracer's materials `names`: albedo, (emission, sides), (transmittance colour,
    IOR): MATERIAL_TEXELS texels each. `textures`: MaterialTextures, for a map's mean
    colour."""
    k = MATERIAL_TEXELS
    table = np.zeros((1, k * max(len(names), 1), 4), np.float32)
    for i, name in enumerate(names):
        m = scene.materials.get(name)
        if m is None:
            table[0, k * i, :3] = 0.18
            continue
        base = m.maps.get("diffuseColor")
        base = m.diffuse if base is None else textures.mean(base)
        emission = m.maps.get("emissiveColor")
        emission = m.emissive if emission is None else textures.mean(emission)
        # Glass: its diffuse share, and what it lets through (its tint).
        table[0, k * i, :3] = np.asarray(base, np.float32) * (1.0 - m.metallic) * \
            (1.0 - m.transmission)
        table[0, k * i + 1, :3] = emission
        front, back = SAMPLING.get(m.emission_sampling, SAMPLING["auto"])
        table[0, k * i + 1, 3] = front + 2 * back
        if m.alpha == "glass":
            tint = np.clip(np.asarray(base, np.float32), 0.0, 1.0)
            table[0, k * i + 2, :3] = m.transmission * tint
            table[0, k * i + 2, 3] = max(m.ior, 1.0 + 1e-4)
    return table


def transmits(table) -> bool:
    """Whether some material of `table` (material_table's) lets light through."""
    return bool(table[0, 2::MATERIAL_TEXELS, :3].any())


def instance_sides(scene, tracer) -> np.ndarray:
    """Per traced instance, the sides of its emitting faces that are lights of the
    light table (engine/emitters.py: 1 front, 2 back, 4 where its mesh's faces are
    made lights at all, 8 where the mesh is closed): a ray meeting them takes no
    emission there, which the lights bring per pixel; the other sides' emission (the
    inside of a closed emitter, a skinned one's, sampling None's) comes through the
    field, as Cycles finds it by BSDF sampling."""
    memo = {}
    flags = np.zeros(max(len(tracer.instances), 1), np.int32)
    for i, (path, _) in enumerate(tracer.instances):
        key = scene.instances[path].mesh_key
        if key not in memo:
            mesh = scene.meshes[key]
            emits = any(float(radiance(scene.materials[name]).max()) > 0.0
                        for name in mesh.materials if name in scene.materials)
            memo[key] = (4 * makes_lights(mesh) + 8 * closed(mesh)) if emits else 0
        flags[i] = memo[key]
    return flags
