"""Bounces: how often light bounces, a plain record that the stage (/Render/Settings)
and a render's settings both carry; and whether a scene's surfaces can send each other
light at all."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.lights import SUN
from .mesh_topology import closed


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


# Triangle-point pairs surfaces_light_each_other compares at most:
# past it a scene is taken to bounce.
PAIRS_LIMIT = 20_000_000
BLOCK = 2048                         # triangles compared with every point at once


def surfaces_light_each_other(scene, tolerance: float = 1e-5) -> bool:
    """Whether light leaving one of the scene's surfaces can reach another. Not where
    every triangle lies in one plane, or on the boundary of one closed convex solid with
    no lamp inside: what a face sends leaves the hull, as with a ground under its lights
    (the calibration scenes) or a lone cube under the sky (the corpus's 01_cube). There
    a bounce adds only the irradiance field's angular blur, light a convex surface
    cannot send itself (against Cycles at full bounces, HDR-FLIP 0.91 on the spot-lit
    plane and 0.14 on 01_cube, against 0.022 and 0.008 lit directly). Emitting
    materials, points, meshes posed on the GPU (skinned, blend-shaped, subdivided) and
    scenes of more than PAIRS_LIMIT triangle-point pairs are taken to bounce.
    `tolerance`: of the scene's size, how far past a face's plane a point may lie."""
    if scene.points or any(max(m.emissive) > 0.0 for m in scene.materials.values()):
        return True
    placed = []                          # (mesh, its world matrices)
    for inst in scene.instances.values():
        mesh = scene.meshes[inst.mesh_key]
        if mesh.skin is not None or mesh.patches is not None or inst.shapes:
            return True
        placed.append((mesh, np.asarray(inst.worlds if inst.worlds is not None
                                        else [inst.world], np.float64)))
    points = sum(len(m.vertices) * len(w) for m, w in placed)
    if points * sum(len(m.indices) // 3 * len(w) for m, w in placed) > PAIRS_LIMIT:
        return True
    lamps = np.array([light.position for light in scene.lights.values()
                      if light.kind != SUN], np.float64).reshape(-1, 3)
    return _faces_see_each_other(placed, lamps, tolerance)


def would_bounce(frame, light_each_other=surfaces_light_each_other) -> bool:
    """Whether `frame` asks for the bounce: a diffuse bounce, something that lights the
    surfaces (a lamp, the dome, an emissive material), and surfaces that light each
    other (`light_each_other(scene)`: surfaces_light_each_other, or a kept answer)."""
    scene = frame.scene
    if frame.options.bounces_for(scene).diffuse_bounces <= 0 or not scene.instances:
        return False
    lit = bool(scene.lights) or scene.dome is not None or \
        any(max(m.emissive) > 0.0 for m in scene.materials.values())
    return lit and light_each_other(scene)


def _faces_see_each_other(placed, lamps, tolerance) -> bool:
    """surfaces_light_each_other's test on (mesh, world matrices) pairs."""
    points, triangles, all_closed = [], [], True
    for mesh, worlds in placed:
        all_closed = all_closed and closed(mesh)
        local = mesh.vertices[:, :3].astype(np.float64)
        corners = mesh.indices.reshape(-1, 3)
        for world in worlds:
            p = local @ world[:3, :3].T + world[:3, 3]
            points.append(p)
            triangles.append(p[corners])
    p, tri = np.concatenate(points), np.concatenate(triangles)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normals, axis=1)
    tri, normals = tri[length > 0.0], normals[length > 0.0] / length[length > 0.0, None]
    tol = tolerance * (float(np.ptp(p, axis=0).max()) or 1.0)
    lamp_inside = np.ones(len(lamps), bool)
    solid = False
    for k in range(0, len(tri), BLOCK):
        n, origin = normals[k:k + BLOCK], tri[k:k + BLOCK, 0]
        offset = (origin * n).sum(axis=1)
        side = p @ n.T - offset                                  # (points, triangles)
        below, above = side.min(axis=0) < -tol, side.max(axis=0) > tol
        if (below & above).any():
            return True                  # points on both sides of a face: it is seen
        inner = np.where(below, -1.0, np.where(above, 1.0, 0.0))  # 0: all in its plane
        solid |= bool(inner.any())
        lamp_side = (lamps @ n.T - offset) * inner
        lamp_inside &= ((lamp_side > tol) | (inner == 0.0)).all(axis=1)
    # A solid's faces see only the outside when it is closed: an open one (a room with
    # an opening, a box without its lid) lets the light in to bounce inside.
    return solid and (not all_closed or bool(lamp_inside.any()))
