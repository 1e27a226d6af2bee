"""The names the comparison's parent and its worker processes share: the Cycles
reference modes, and the marker of a worker's progress lines. No bpy, so every
side imports it and nothing else for these."""

# The Cycles references: `direct` (no bounce past the camera ray's hit) and `full`
# (the scene's own bounce limits); blender_render.configure_cycles applies them.
MODES = ("direct", "full")

# A worker prints this, then JSON, on stdout after each render; tasks.py reads it.
PROGRESS = "@@lantern-compare@@"
