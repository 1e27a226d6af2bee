"""UsdGeom's implicit surfaces -> the triangles of their exact shape (no records, no GL).

Sphere, Cube, Cylinder, Cone, Capsule, Plane, Cylinder_1 and Capsule_1 become a
`Surface` (engine/usd/mesh.py), which build_mesh turns into MeshData like any Mesh:
every pass (shadows, AO, object ids, render passes, transparency) and PointInstancer
prototypes then draw them with no path of their own.

Each round shape is a profile in its (radius, height) half-plane swept around its
`axis` (a surface of revolution), as GeomUtil's generators make them
(pxr/imaging/geomUtil, USD 25.08): the same dimensions and axis conventions; a
Capsule_1 whose radii differ is a cone of those end radii capped by the spheres
tangent to it. Normals are the exact surface's at every vertex, so
shading is the true shape's; the silhouette is a polygon of SEGMENTS sides, within
1 - cos(pi / SEGMENTS) = 0.2 % of the radius (under a pixel until a shape is 470
pixels in radius; docs/status.md has the measured error against Cycles), fewer for a
prototype instanced many times (segments_for). GeomUtil's own default is 10 sides (5 % of the radius), which is what
Storm draws and Blender's USD importer makes."""
from __future__ import annotations

import math

import numpy as np
from pxr import UsdGeom

from .mesh import MeshError, Surface

SEGMENTS = 48                  # around the axis (spheres: half as many rings), drawn once
# A PointInstancer's prototype drawn N times gets the most of these sides whose sphere
# (about sides^2 triangles) over all N stays within TRIANGLES_PER_PROTOTYPE: 4,096
# instanced spheres at 48 sides were 9 M triangles, 4.4 s a frame on llvmpipe, ten
# times GeomUtil's 10 sides (docs/status.md, "Implicit surfaces, curves and hair").
LEVELS = (48, 32, 24, 16, 12)
TRIANGLES_PER_PROTOTYPE = 1 << 20

# Type name -> the schema attributes that shape it, in the order `parameters` reads them.
SHAPES = {
    "Sphere": ("radius",),
    "Cube": ("size",),
    "Cylinder": ("radius", "height", "axis"),
    "Cone": ("radius", "height", "axis"),
    "Capsule": ("radius", "height", "axis"),
    "Plane": ("width", "length", "axis"),
    "Cylinder_1": ("radiusTop", "radiusBottom", "height", "axis"),
    "Capsule_1": ("radiusTop", "radiusBottom", "height", "axis"),
}


def is_implicit(prim) -> bool:
    return prim.GetTypeName() in SHAPES and prim.IsA(UsdGeom.Gprim)


def parameters(prim, time) -> tuple:
    """(type name, its shaping attributes' values at `time`, schema fallbacks where
    unauthored); MeshError when one is not finite or is negative, or the axis is not
    X, Y or Z."""
    kind = prim.GetTypeName()
    values = []
    for name in SHAPES[kind]:
        v = prim.GetAttribute(name).Get(time)
        if name == "axis":
            if v not in ("X", "Y", "Z"):
                raise MeshError(f"axis {v!r} is not X, Y or Z")
            values.append(str(v))
            continue
        if v is None or not math.isfinite(float(v)) or float(v) < 0.0:
            raise MeshError(f"{name} {v} is not a finite size of zero or more")
        values.append(float(v))
    return (kind, *values)


def segments_for(instances: int) -> int:
    """Sides around for a shape drawn `instances` times (LEVELS)."""
    for sides in LEVELS:
        if instances * sides * sides <= TRIANGLES_PER_PROTOTYPE:
            return sides
    return LEVELS[-1]


def surface(params, segments=None) -> Surface:
    """The triangles of a shape given by `parameters`, `segments` sides around
    (SEGMENTS unless given)."""
    n = segments or SEGMENTS
    kind, *values = params
    if kind == "Cube":
        return _cube(values[0])
    if kind == "Plane":
        return _plane(*values)
    if kind == "Sphere":
        strips, axis = [_sphere_arc(values[0], 0.0, -math.pi / 2, math.pi / 2, n // 2)], "Z"
    elif kind == "Capsule":
        r, h, axis = values
        strips = [_capsule(r, r, h, n // 2)]
    elif kind == "Capsule_1":
        top, bottom, h, axis = values
        strips = [_capsule(top, bottom, h, n // 2)]
    elif kind == "Cone":
        r, h, axis = values
        strips = _frustum(0.0, r, h)
    else:                            # Cylinder, Cylinder_1
        if kind == "Cylinder":
            r, h, axis = values
            top = bottom = r
        else:
            top, bottom, h, axis = values
        strips = _frustum(top, bottom, h)
    return _sweep(strips, axis, n)


# A profile point: (radius, height, normal's radial part, normal's axial part).

def _sphere_arc(r, centre, lat0, lat1, steps):
    lat = np.linspace(lat0, lat1, max(int(steps), 1) + 1)
    c, s = np.cos(lat), np.sin(lat)
    c[np.abs(np.abs(lat) - math.pi / 2) < 1e-12] = 0.0    # poles: exactly on the axis
    return np.stack([r * c, centre + r * s, c, s], axis=1)


def _capsule(top, bottom, h, rings):
    """End spheres joined by the cone (a cylinder when the radii are equal) whose ends,
    `h` apart, have the two radii: one smooth strip from the bottom pole to the top
    one. Each sphere touches the cone along that end's circle, so its radius is the
    end's over cos(alpha), tan(alpha) = (bottom - top) / h, and its centre sits
    R sin(alpha) beyond the end (as Hydra's GeomUtil capsule generator in USD 25.08
    makes Capsule_1, and Blender's importer with it). No length: the larger sphere."""
    if h <= 0.0:
        return _sphere_arc(max(top, bottom), 0.0, -math.pi / 2, math.pi / 2, rings)
    lean = math.atan2(bottom - top, h)
    rb, rt = bottom / math.cos(lean), top / math.cos(lean)
    steps = max(rings // 2, 1)
    low = _sphere_arc(rb, -h / 2 - rb * math.sin(lean), -math.pi / 2, lean, steps)
    high = _sphere_arc(rt, h / 2 - rt * math.sin(lean), lean, math.pi / 2, steps)
    return np.concatenate([low, high])


def _frustum(top, bottom, h):
    """A cylinder or cone (top 0) along its axis: the side and its flat caps, each a
    strip of its own, so the rims stay sharp."""
    slant = math.hypot(h, bottom - top)
    nr, nz = (h / slant, (bottom - top) / slant) if slant > 0 else (1.0, 0.0)
    strips = []
    if bottom > 0:
        strips.append(np.array([[0.0, -h / 2, 0.0, -1.0], [bottom, -h / 2, 0.0, -1.0]]))
    strips.append(np.array([[bottom, -h / 2, nr, nz], [top, h / 2, nr, nz]]))
    if top > 0:
        strips.append(np.array([[top, h / 2, 0.0, 1.0], [0.0, h / 2, 0.0, 1.0]]))
    return strips


# The shape's local (u, v, axis) -> its prim's (x, y, z), a rotation (GeomUtil's basis).
_BASES = {"X": ((0, 1, 0), (0, 0, 1), (1, 0, 0)),
          "Y": ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
          "Z": ((1, 0, 0), (0, 1, 0), (0, 0, 1))}


def _sweep(strips, axis, n) -> Surface:
    """Profiles swept n times around the axis, each strip's consecutive rings
    joined by quads (triangles at a pole). A pole's point is repeated for every
    segment with the normal at that segment's middle, so a cone's apex shades as
    the cone does there. Faces wind counter-clockwise seen from outside (profiles run
    from the bottom up along the outside)."""
    phi = 2.0 * math.pi * np.arange(n) / n
    mid = phi + math.pi / n
    points, normals, counts, indices = [], [], [], []
    base = 0
    for strip in strips:
        rings = []
        for r, z, nr, nz in strip:
            angles = mid if r == 0.0 else phi
            c, s = np.cos(angles), np.sin(angles)
            ring = np.arange(n) + base
            points.append(np.stack([r * c, r * s, np.full(n, z)], axis=1))
            normals.append(np.stack([nr * c, nr * s, np.full(n, nz)], axis=1))
            rings.append((ring, r == 0.0))
            base += n
        for (a, a_pole), (b, b_pole) in zip(rings, rings[1:]):
            a1, b1 = np.roll(a, -1), np.roll(b, -1)
            if a_pole and b_pole:
                continue
            if a_pole:
                quads = np.stack([a, b1, b], axis=1)
            elif b_pole:
                quads = np.stack([a, a1, b], axis=1)
            else:
                quads = np.stack([a, a1, b1, b], axis=1)
            counts.append(np.full(n, quads.shape[1]))
            indices.append(quads.reshape(-1))
    basis = np.array(_BASES[axis], np.float64)
    return Surface(points=np.concatenate(points) @ basis,
                   counts=np.concatenate(counts), indices=np.concatenate(indices),
                   normals=np.concatenate(normals) @ basis)


def _cube(size) -> Surface:
    h = size / 2.0
    points, normals = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = np.zeros(3)
            n[axis] = sign
            u, v = np.zeros(3), np.zeros(3)
            u[(axis + 1) % 3], v[(axis + 2) % 3] = 1.0, 1.0
            if sign < 0:
                u, v = v, u                  # counter-clockwise seen from outside
            for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                points.append(h * (n + du * u + dv * v))
                normals.append(n)
    return Surface(points=np.array(points), counts=np.full(6, 4),
                   indices=np.arange(24), normals=np.array(normals))


def _plane(width, length, axis) -> Surface:
    """UsdGeomPlane: `width` along x (z when the axis is X), `length` along y (z when
    the axis is Y), facing +axis."""
    basis = np.array(_BASES[axis], np.float64)
    spine = basis[2]
    along_w = np.array([0.0, 0.0, 1.0]) if axis == "X" else np.array([1.0, 0.0, 0.0])
    along_l = np.array([0.0, 0.0, 1.0]) if axis == "Y" else np.array([0.0, 1.0, 0.0])
    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    points = np.array([du * width / 2 * along_w + dv * length / 2 * along_l
                       for du, dv in corners])
    order = [0, 1, 2, 3] if np.dot(np.cross(along_w, along_l), spine) > 0 else [0, 3, 2, 1]
    return Surface(points=points, counts=np.array([4]), indices=np.array(order),
                   normals=np.tile(spine, (4, 1)))
