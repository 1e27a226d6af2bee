"""What the engine does with each UsdGeom gprim type: the one table of it
(docs/stage_contract.md lists the same), and the warning for those it does not draw.

Drawn: Mesh; the implicit surfaces (shapes.py, as meshes); BasisCurves and
NurbsCurves (curves.py: round tubes, or oriented ribbons where normals are
authored); NurbsPatch (patches.py: its control hull, as a mesh); Points. A
PointInstancer is not a gprim: it draws its prototypes.
Every other gprim type (Volume, TetMesh, HermiteCurves, a codeless or
plugin type) and every prim of a type no schema defines is counted by type, and
each type is one warning: "3 Volume prims are not drawn (...): /a, /b and 1 more"."""
from __future__ import annotations

from pxr import Usd, UsdGeom

from .curve_shapes import ribbon_surface
from .curves import has_normals
from .patches import hull_surface, is_patch
from .shapes import is_implicit, parameters, segments_for
from .shapes import surface as shape_surface

CURVES = ("BasisCurves", "NurbsCurves")

# Why a gprim type is not drawn (the warning's reason); any other: "not a type Lantern draws".
NOT_DRAWN = {
    "Volume": "Lantern draws no volumes",
    "TetMesh": "Lantern draws no tetrahedral meshes",
    "HermiteCurves": "Lantern does not draw Hermite curves",
}
NAMED = 3                  # prims a warning names


def kind_of(prim) -> str | None:
    """How a prim is drawn: 'mesh' (MeshData: a Mesh, an implicit surface, curves
    with authored normals as oriented ribbons, a NURBS patch's hull), 'points'
    (PointCloud: Points, and curves as round tubes), or None when it draws nothing
    by itself."""
    if not prim.IsA(UsdGeom.Gprim):            # lights, Xforms, shaders: one call
        return None
    if prim.IsA(UsdGeom.Mesh) or is_implicit(prim) or is_patch(prim):
        return "mesh"
    if is_curves(prim):
        return "mesh" if has_normals(prim) else "points"
    if prim.IsA(UsdGeom.Points):
        return "points"
    return None


def is_curves(prim) -> bool:
    return prim.GetTypeName() in CURVES and prim.IsA(UsdGeom.Curves)


def source_key(prim, time, instances=1):
    """What 'mesh' kind prims share their MeshData by: an implicit surface's type and
    sizes and its sides around (fewer when a PointInstancer draws it `instances`
    times); a Mesh's (or ribbons', or a patch hull's) strongest `points` opinion."""
    if is_implicit(prim):
        return parameters(prim, time) + (segments_for(instances),)
    spec = strongest_spec(UsdGeom.PointBased(prim).GetPointsAttr())
    if is_curves(prim):
        return ("ribbons", spec)
    return ("hull", spec) if is_patch(prim) else spec


def made_surface(prim, time, warnings, instances=1, points=None):
    """The faces the engine makes for a 'mesh' kind prim that is not a Mesh
    (build_mesh's `surface`), or None for a Mesh. `points`: curves' skinned points."""
    if is_implicit(prim):
        return shape_surface(parameters(prim, time), segments_for(instances))
    if is_curves(prim):
        return ribbon_surface(prim, time, warnings, points)
    if is_patch(prim):
        return hull_surface(prim, time)
    return None


def strongest_spec(attr):
    """(layer, path) of the strongest opinion of an attribute: prims whose data comes
    from the same place share what is built from it."""
    stack = attr.GetPropertyStack(Usd.TimeCode.Default())
    if stack:
        return (stack[0].layer.identifier, str(stack[0].path))
    return ("", str(attr.GetPath()))


def undrawn_type(prim) -> str | None:
    """The type name of a prim that should draw and does not: a gprim the engine has
    no path for, or a typed prim whose type no schema defines ('Foo (unknown type)')."""
    type_name = prim.GetTypeName()
    if not type_name:
        return None
    if prim.GetPrimTypeInfo().GetSchemaType().isUnknown:
        return f"{type_name} (unknown type)"
    if prim.IsA(UsdGeom.Gprim) and kind_of(prim) is None:
        return str(type_name)
    return None


def undrawn_warnings(undrawn: dict) -> list:
    """One line per type of {prim path: undrawn type}, in type order."""
    by_type = {}
    for path, type_name in sorted(undrawn.items()):
        by_type.setdefault(type_name, []).append(path)
    lines = []
    for type_name, paths in sorted(by_type.items()):
        reason = NOT_DRAWN.get(type_name.split(" ")[0], "not a type Lantern draws") \
            if not type_name.endswith("(unknown type)") else "no schema defines the type"
        named = ", ".join(paths[:NAMED])
        more = f" and {len(paths) - NAMED} more" if len(paths) > NAMED else ""
        what = "prim is" if len(paths) == 1 else "prims are"
        lines.append(f"{len(paths)} {type_name} {what} not drawn ({reason}): {named}{more}")
    return lines
