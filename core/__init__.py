"""Pure math shared by the exporters and the engine (numpy, and small native helpers such
as mapbox-earcut). Imports neither bpy, pxr nor moderngl, so both sides can use it."""
