"""One module per pass of the deferred pipeline, in the order a frame runs them:
skinning, view, shadows, gbuffer, aovs (surface render passes), ao (ambient
occlusion), ambient (the dome and emission), lights, antialias (supersampling's
filter), post (FXAA, exposure, blur, grayscale, mirror), resolve
(engine/gpu/renderer.py assembles them into a frame graph)."""
