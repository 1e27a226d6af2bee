"""Pure math shared by the exporters and the engine: transforms, quaternions, bounds,
polygon triangulation, atomic file writes, and the tables that must exist once (light
kinds, quality presets). numpy and small native helpers (mapbox-earcut) only: imports
neither bpy, pxr nor moderngl, so both sides can use it, and a test guards that
(tests/test_boundary.py)."""
