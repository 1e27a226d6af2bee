"""The engine's USD side, and the only code in the engine that imports pxr: a stage
read into plain scene records (engine/scene.py), kept current through Usd.Notice and
re-read at each new time only where the stage varies in time.

- opening.py: the one way a stage is opened (a file, or text sent to a worker);
- stage.py: StageReader, the one class the Session talks to, over its jobs:
  read.py (the first read: traversal, meshes, skeletons), read_instancers.py,
  read_shading.py (materials, lights), changes.py (edits through Usd.Notice),
  timeline.py (what varies in time, and the re-read at a new time), validate.py
  (checks that name the prim at fault), paths.py (prim-path relations);
- mesh.py, skel.py, materials.py, lights.py, camera.py, instancers.py: one USD schema
  each into records or arrays; shapes.py (implicit surfaces) and curves.py
  (BasisCurves, NurbsCurves) make the surfaces other gprims are drawn as, and
  gprims.py holds what the engine does with each gprim type;
- fragments.py: stage edits as messages between processes (the engine host)."""
