"""The engine's GL side, and the only code in the engine that imports moderngl: the
context on its own thread, resources (pooled targets, shared geometry buffers, the
object, light and material tables), and the frame graph with one module per pass
(engine/gpu/passes/). Everything here draws scene records (engine/scene.py)."""
