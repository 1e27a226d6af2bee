"""Pure numpy shared by the exporters and the engine: transforms, quaternions, bounds,
atomic file writes, and the tables that must exist once (light kinds, quality
presets). Imports neither bpy, pxr nor moderngl, so both sides can use it and a test
guards that (tests/test_boundary.py)."""
