"""`lantern compare`: speed against error, against Cycles and EEVEE, as a report.

A tool beside the engine, not part of it: it drives Blender (Cycles, EEVEE, and the
exporter for Lantern) in worker processes, so it may import bpy; the engine never
imports it. Modules, in the order the data flows (and the imports run: command ->
run -> tasks -> worker -> Blender-side rendering):
- modes.py: the reference modes and the progress-line marker, shared by both sides;
- command.py: the sub-command's options; run.py: the steps of one comparison;
- worker.py: one render job per process (blender_scene.py opens and prepares the
  scene, blender_render.py configures and times Cycles and EEVEE,
  lantern_timing.py times Lantern cold and warm); tasks.py runs the jobs;
- cache.py: the Cycles reference cached by a hash of its inputs;
- metrics.py: image error; curves.py: equal-error times on error-against-time curves;
- report.py: index.html, results.json (results.schema.json), plots and images;
- files.py: atomic writes."""
