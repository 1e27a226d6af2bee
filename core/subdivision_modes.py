"""What an export does with a mesh's Subdivision Surface modifier, the one table:
`lantern export --subdivision`, File > Export and `ExportOptions.subdivision` offer these
names. Each is one of Blender's own USD exporter's `export_subdivision` choices.

The rule for "cage" and "ignore" is Blender's Best Match: only a Catmull-Clark
Subdivision Surface that is the last modifier that is on (for the depsgraph's mode) is
taken off the mesh; a mesh with anything on after it is written with it applied.
F12 and the viewport keep their own setting (the render panel's Subdivision, Apply by
default: a live export cannot switch a modifier off)."""

# What is written for a mesh whose last modifier is such a Subdivision Surface.
SUBDIVISION_MODES = {
    "cage": "its cage, with subdivisionScheme = catmullClark, its levels, creases and "
            "corners: the renderer subdivides (Blender's Best Match)",
    "apply": "the modifier's subdivided mesh (Blender's Tessellate)",
    "ignore": "its cage as a polygon mesh, subdivisionScheme = none (Blender's Ignore)",
}

FILE_DEFAULT = "cage"      # files written by `lantern export` and File > Export
