"""MeshRecord -> UsdGeom.Mesh, and material bindings on a mesh."""
import numpy as np
from pxr import Sdf, UsdGeom, UsdShade, Vt

from ...core.pattern_nodes import attribute_opacity
from .names import Namer, primvar_name

LIMIT_ATTR = "lantern:subdivisionLimitSurface"


def write_mesh(stage, path, rec, double_sided, slot_names):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(rec.points)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(rec.face_counts))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(rec.face_indices))
    lo, hi = rec.points.min(axis=0), rec.points.max(axis=0)
    mesh.CreateExtentAttr(Vt.Vec3fArray([tuple(map(float, lo)), tuple(map(float, hi))]))
    mesh.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    if rec.subdivision is None:
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    else:
        write_subdivision(mesh, rec.subdivision)
    mesh.CreateDoubleSidedAttr(bool(double_sided))
    if not double_sided:
        # doubleSided = false alone is USD's default, which usdview draws two-sided;
        # the marker says Blender's Backface Culling asked for culling.
        mesh.GetPrim().CreateAttribute("lantern:backfaceCulling", Sdf.ValueTypeNames.Bool,
                                       custom=True).Set(True)
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(rec.normals)))
    mesh.SetNormalsInterpolation(rec.normals_interpolation)
    primvars = UsdGeom.PrimvarsAPI(mesh)
    for name in sorted(rec.uvs):
        pv = primvars.CreatePrimvar(primvar_name(name), Sdf.ValueTypeNames.TexCoord2fArray,
                                    UsdGeom.Tokens.faceVarying)
        pv.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(rec.uvs[name])))
    for name in sorted(rec.colors):                # attributes networks read
        rgba = rec.colors[name]
        pv = primvars.CreatePrimvar(name, Sdf.ValueTypeNames.Color3fArray,
                                    UsdGeom.Tokens.faceVarying)
        pv.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(rgba[:, :3])))
        if (rgba[:, 3] != 1.0).any():              # written only when not all opaque
            pv = primvars.CreatePrimvar(attribute_opacity(name), Sdf.ValueTypeNames.FloatArray,
                                        UsdGeom.Tokens.faceVarying)
            pv.Set(Vt.FloatArray.FromNumpy(np.ascontiguousarray(rgba[:, 3])))
    if rec.tangents is not None:
        pv = primvars.CreatePrimvar("tangents", Sdf.ValueTypeNames.Float4Array,
                                    UsdGeom.Tokens.faceVarying)
        pv.Set(Vt.Vec4fArray.FromNumpy(np.ascontiguousarray(rec.tangents)))
    slots = face_slots(rec, len(slot_names))
    if slots is not None:
        namer = Namer()
        for slot in np.unique(slots):
            subset_path = namer.child(path, slot_names[slot] or f"slot_{slot}")
            subset = UsdGeom.Subset.Define(stage, subset_path)
            subset.CreateElementTypeAttr(UsdGeom.Tokens.face)
            subset.CreateFamilyNameAttr(UsdShade.Tokens.materialBind)
            subset.CreateIndicesAttr(Vt.IntArray.FromNumpy(
                np.flatnonzero(slots == slot).astype(np.int32)))
        UsdGeom.Subset.SetFamilyType(mesh, UsdShade.Tokens.materialBind,
                                     UsdGeom.Tokens.nonOverlapping)
    return mesh


def write_subdivision(mesh, sub):
    """The cage's Catmull-Clark rules; the levels are Blender's, as lantern: metadata."""
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.catmullClark)
    mesh.CreateInterpolateBoundaryAttr(sub.interpolate_boundary)
    mesh.CreateFaceVaryingLinearInterpolationAttr(sub.face_varying_linear_interpolation)
    if len(sub.crease_lengths):
        mesh.CreateCreaseIndicesAttr(Vt.IntArray.FromNumpy(sub.crease_indices))
        mesh.CreateCreaseLengthsAttr(Vt.IntArray.FromNumpy(sub.crease_lengths))
        mesh.CreateCreaseSharpnessesAttr(Vt.FloatArray.FromNumpy(sub.crease_sharpnesses))
    if len(sub.corner_indices):
        mesh.CreateCornerIndicesAttr(Vt.IntArray.FromNumpy(sub.corner_indices))
        mesh.CreateCornerSharpnessesAttr(Vt.FloatArray.FromNumpy(sub.corner_sharpnesses))
    prim = mesh.GetPrim()
    for name, level in (("lantern:subdivisionRenderLevel", sub.render_level),
                        ("lantern:subdivisionViewportLevel", sub.viewport_level)):
        prim.CreateAttribute(name, Sdf.ValueTypeNames.Int, custom=True).Set(int(level))
    if not sub.limit_surface:      # only when off: on is Blender's default and USD's meaning
        prim.CreateAttribute(LIMIT_ATTR, Sdf.ValueTypeNames.Bool, custom=True).Set(False)


def face_slots(rec, slot_count):
    """Material slot per face, or None when one slot (or none) covers the mesh."""
    if slot_count <= 1 or rec.material_indices is None:
        return None
    slots = np.clip(rec.material_indices, 0, slot_count - 1)
    return slots if len(np.unique(slots)) > 1 else None


# What Blender renders a face without a material with: Cycles' default surface is a
# diffuse BSDF of this colour (EEVEE's a Principled BSDF of it). Written as the mesh's
# displayColor, which UsdPreviewSurface-based renderers (Storm, Lantern) shade unbound
# faces with; USD's own fallback would be 0.18 grey, a quarter as bright.
DEFAULT_SURFACE_COLOR = (0.8, 0.8, 0.8)


def bind_materials(stage, mesh_path, rec, slot_materials, material_paths):
    """Binds per face slot (subsets written by write_mesh), or the whole mesh; faces left
    without a material get Blender's default surface colour."""
    slots = face_slots(rec, len(slot_materials))
    mesh_prim = stage.GetPrimAtPath(mesh_path)
    if slots is None:
        key = slot_materials[int(np.clip(rec.material_indices[0], 0, len(slot_materials) - 1))] \
            if slot_materials and len(rec.material_indices) else None
        if key is not None:
            material = UsdShade.Material(stage.GetPrimAtPath(material_paths[key]))
            UsdShade.MaterialBindingAPI.Apply(mesh_prim).Bind(material)
        else:
            _default_surface(mesh_prim)
        return
    subsets = {int(s.GetIndicesAttr().Get()[0]): s for s in
               UsdGeom.Subset.GetGeomSubsets(UsdGeom.Imageable(mesh_prim),
                                             UsdGeom.Tokens.face, UsdShade.Tokens.materialBind)}
    for first_face, subset in sorted(subsets.items()):
        key = slot_materials[slots[first_face]]
        if key is None:
            _default_surface(mesh_prim)
            continue
        # Over the subset: on a referenced prototype this is a local opinion.
        prim = stage.OverridePrim(subset.GetPath())
        material = UsdShade.Material(stage.GetPrimAtPath(material_paths[key]))
        UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)


def _default_surface(mesh_prim):
    UsdGeom.Gprim(mesh_prim).CreateDisplayColorAttr(Vt.Vec3fArray([DEFAULT_SURFACE_COLOR]))
