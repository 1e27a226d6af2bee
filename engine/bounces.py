"""Bounces: how often light bounces, a plain record that the stage (/Render/Settings)
and a render's settings both carry; and whether a scene's surfaces can send each other
light at all."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Bounces:
    """How often light may bounce on its way to the camera, as Cycles counts it (Render
    Properties > Light Paths): `total` is Max Bounces, `diffuse` and `glossy` cap each
    kind. Cycles' defaults; total 0 is direct light only."""
    total: int = 12
    diffuse: int = 4
    glossy: int = 4

    def __post_init__(self):
        for name in ("total", "diffuse", "glossy"):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 0:
                raise ValueError(f"bounces: {name} must be a whole number >= 0, not {v!r}")

    @property
    def diffuse_bounces(self) -> int:
        """Diffuse bounces a path may take: the smaller cap."""
        return min(self.total, self.diffuse)

    @property
    def glossy_bounces(self) -> int:
        return min(self.total, self.glossy)


DIRECT = Bounces(0, 0, 0)


def surfaces_light_each_other(scene, tolerance: float = 1e-5) -> bool:
    """Whether light leaving one of the scene's surfaces can reach another: not where
    every triangle lies in one plane (a ground under its lights, the calibration
    scenes: what the plane sends goes to the sky, and a bounce would only add the
    irradiance field's angular blur, light a plane cannot send itself). Points, and
    meshes posed on the GPU (skinned, blend-shaped, subdivided), are taken to bounce.
    `tolerance`: of the scene's size, how far off the plane a point may lie."""
    if scene.points:
        return True
    plane = None                       # (unit normal, offset, scale)
    for inst in scene.instances.values():
        mesh = scene.meshes[inst.mesh_key]
        if mesh.skin is not None or mesh.patches is not None or inst.shapes:
            return True
        local = mesh.vertices[:, :3].astype(np.float64)
        for world in (inst.worlds if inst.worlds is not None else [inst.world]):
            world = np.asarray(world, np.float64)
            p = local @ world[:3, :3].T + world[:3, 3]
            if plane is None:
                tri = p[mesh.indices.reshape(-1, 3)]
                normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
                k = int(np.argmax(np.linalg.norm(normals, axis=1)))
                if not np.linalg.norm(normals[k]) > 0.0:
                    return True
                n = normals[k] / np.linalg.norm(normals[k])
                plane = (n, float(tri[k, 0] @ n), float(np.ptp(p, axis=0).max()) or 1.0)
            n, offset, scale = plane
            if np.abs(p @ n - offset).max() > tolerance * scale:
                return True
    return False
