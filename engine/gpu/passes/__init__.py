"""One module per pass of the deferred pipeline, in the order a frame runs them:
skinning, view, shadows, gbuffer, ambient, lights, resolve (engine/gpu/renderer.py
assembles them into a frame graph)."""
