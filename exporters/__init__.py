"""Blender to USD. Gathers Blender data into plain records, then writes USD.

Importing this package imports bpy and makes the process use Blender's own pxr
(see `blender_env`), so import it before anything that imports pxr.
"""
from . import blender_env  # noqa: F401  (must run before any pxr import)
from .api import (ExportError, ExportOptions, ExportReport, export_blend,  # noqa: E402
                  export_depsgraph, export_depsgraph_to_file, open_blend,
                  stage_from_blend, stage_from_depsgraph)
from .validate import validation_errors  # noqa: E402

__all__ = ["ExportError", "ExportOptions", "ExportReport", "export_blend", "export_depsgraph",
           "export_depsgraph_to_file", "open_blend", "stage_from_blend",
           "stage_from_depsgraph", "validation_errors"]
