"""File > Export > Lantern USD: the same code path as `lantern export`."""
import bpy
from bpy_extras.io_utils import ExportHelper

from ..core.subdivision_modes import FILE_DEFAULT, SUBDIVISION_MODES
from ..exporters import ExportError, ExportOptions, export_depsgraph_to_file


class EXPORT_SCENE_OT_lantern_usd(bpy.types.Operator, ExportHelper):
    """Export the scene to USD with Lantern"""
    bl_idname = "export_scene.lantern_usd"
    bl_label = "Export Lantern USD"
    bl_options = {'PRESET'}

    filename_ext = ".usdc"
    filter_glob: bpy.props.StringProperty(default="*.usd;*.usda;*.usdc", options={'HIDDEN'})
    textures: bpy.props.EnumProperty(
        name="Textures", default="reference",
        items=(("reference", "Reference", "Point at images where they are"),
               ("copy", "Copy", "Copy images beside the USD file")))

    subdivision: bpy.props.EnumProperty(
        name="Subdivision", default=FILE_DEFAULT,
        items=tuple((name, name.capitalize(), text[0].upper() + text[1:])
                    for name, text in SUBDIVISION_MODES.items()),
        description="What is written for a mesh whose last modifier is a Catmull-Clark "
                    "Subdivision Surface")

    limit_influences: bpy.props.BoolProperty(
        name="Limit Influences", default=False,
        description="Keep only the largest joint influences per vertex")
    max_influences: bpy.props.IntProperty(
        name="Max Influences", default=4, min=1, max=64,
        description="Joint influences kept per vertex when limited")

    def check(self, context):
        # Keep .usd/.usda/.usdc as typed instead of forcing filename_ext.
        return False

    def execute(self, context):
        path = self.filepath
        if not path.lower().endswith((".usd", ".usda", ".usdc")):
            path += self.filename_ext
        try:
            report = export_depsgraph_to_file(
                context.evaluated_depsgraph_get(), path, ExportOptions(
                    textures=self.textures, subdivision=self.subdivision,
                    max_influences=self.max_influences if self.limit_influences else None))
        except ExportError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        for warning in report.warnings:
            self.report({'WARNING'}, warning)
        self.report({'INFO'}, f"Exported {path} in {report.seconds:.2f} s")
        return {'FINISHED'}


def _menu_entry(self, context):
    self.layout.operator(EXPORT_SCENE_OT_lantern_usd.bl_idname, text="Lantern USD (.usd/.usda/.usdc)")


def register():
    bpy.utils.register_class(EXPORT_SCENE_OT_lantern_usd)
    bpy.types.TOPBAR_MT_file_export.append(_menu_entry)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(_menu_entry)
    bpy.utils.unregister_class(EXPORT_SCENE_OT_lantern_usd)
