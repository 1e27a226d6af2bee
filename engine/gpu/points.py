"""Points prims and round curve tubes on the GPU: each cloud one instanced draw of
camera-facing quads, one per point (or per straight piece of a curve), ray-cast into
spheres (or the spheres swept along the piece) in the fragment shader
(shaders/points.vert and points.frag), into the G-buffer and into shadow maps, so
particles, point clouds and curves are lit and shadowed like meshes. A cloud's
primitives go up once (16 bytes a point, 32 a piece, plus 12 for colour); its
placement is an object of the object table, like a mesh's."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.transforms import transform_aabbs
from .programs import set_uniform


@dataclass
class Cloud:
    oid: int
    n: int
    points: object               # buffer: (x, y, z, radius) float32 per point, two per piece
    colours: object | None       # buffer: rgb float32 per point or piece, or None
    material: str
    local: tuple                 # (lo, hi) in the prim's space
    world: np.ndarray
    vaos: dict
    segments: bool = False       # curve pieces (two ends each), not spheres

    def release(self):
        for obj in [self.points, self.colours] + list(self.vaos.values()):
            if obj is not None:
                obj.release()


def set_camera_facing(prog, view):
    """The uniforms that turn each point into a sphere facing `view`'s camera
    (shaders/points.vert); shadow maps face their light instead (passes/shadows.py)."""
    set_uniform(prog, "view_proj", view.view_proj)
    set_uniform(prog, "u_window", view.window)
    set_uniform(prog, "u_far", view.far_clip)
    set_uniform(prog, "u_face_axis", bool(view.camera.ortho))
    set_uniform(prog, "u_axis", view.camera.forward)
    view.set_origin(prog)


class PointClouds:
    def __init__(self, ctx, uploads, objects):
        self.ctx, self.uploads, self.objects = ctx, uploads, objects
        self.clouds = {}             # Points prim path -> Cloud

    def update(self, scene, changed: set) -> list:
        """Uploads the clouds that changed; returns the world boxes that moved (for
        shadow maps)."""
        moved = []
        for path in sorted(changed):          # ids in path order (geometry.py update)
            old = self.clouds.pop(path, None)
            if old is not None:
                moved.append(self._box(old))
                self.objects.free_ids(old.oid)
                old.release()
            rec = scene.points.get(path)
            if rec is None:
                continue
            data = np.concatenate([rec.points, rec.radii[:, None]], axis=1).astype(np.float32)
            colours = rec.colours
            if rec.segments is not None:
                data = data[rec.segments].reshape(-1, 8)
                colours = None if colours is None else colours[rec.segments[:, 0]]
            colours = None if colours is None else \
                self.uploads.buffer(colours.astype(np.float32), kind="mesh")
            cloud = Cloud(self.objects.new_ids(1), len(data),
                          self.uploads.buffer(np.ascontiguousarray(data), kind="mesh"),
                          colours, rec.material, rec.bounds, rec.world, {},
                          segments=rec.segments is not None)
            self.objects.set(cloud.oid, rec.world)
            self.clouds[path] = cloud
            moved.append(self._box(cloud))
        return moved

    @staticmethod
    def _box(cloud):
        lo, hi = transform_aabbs(np.asarray(cloud.local[0])[None], np.asarray(cloud.local[1])[None],
                                 np.asarray(cloud.world)[None])
        return lo[0], hi[0]

    def boxes(self):
        """[(path, world lo, world hi)] of every cloud."""
        return [(path, *self._box(c)) for path, c in self.clouds.items()]

    def _vao(self, cloud, prog):
        vao = cloud.vaos.get(prog.extra)
        if vao is None:
            content = [(cloud.points, "4f 4f/i", "in_point", "in_point_b") if cloud.segments
                       else (cloud.points, "4f/i", "in_point")]
            if cloud.colours is not None:
                content.append((cloud.colours, "3f/i", "in_colour"))
            vao = cloud.vaos[prog.extra] = self.ctx.vertex_array(prog, content, skip_errors=True)
        return vao

    VARIANTS = {"gbuffer": [], "shadow": ["POINTS_SHADOW"], "id": ["POINTS_ID"]}

    def draw(self, programs, variant: str, setup, visible=None, defines=()) -> tuple:
        """Draws every cloud (those `visible(lo, hi)` allows) with the points program
        (variant: gbuffer, shadow or id, with the pass's own `defines`); setup(prog,
        cloud) sets the pass's uniforms. Returns (draws, points and pieces)."""
        draws = points = 0
        for path, cloud in self.clouds.items():
            if visible is not None and not visible(*self._box(cloud)):
                continue
            variant_defines = self.VARIANTS[variant] + list(defines) + \
                (["POINTS_COLOUR"] if cloud.colours is not None and variant == "gbuffer" else []) + \
                (["POINTS_SEGMENT"] if cloud.segments else [])
            prog = programs.get("points.vert", "points.frag", variant_defines)
            set_uniform(prog, "u_object", cloud.oid)
            setup(prog, cloud)
            self._vao(cloud, prog).render(self.ctx.TRIANGLE_STRIP, vertices=4, instances=cloud.n)
            draws += 1
            points += cloud.n
        return draws, points

    def path_of(self, oid: int):
        return next((p for p, c in self.clouds.items() if c.oid == oid), None)

    def release(self):
        for cloud in self.clouds.values():
            cloud.release()
        self.clouds.clear()
