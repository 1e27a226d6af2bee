"""The engine host: the engine in its own process, for Blender.

Blender's process (addon/host.py) starts one child process with Blender's own Python
(sys.executable) and talks to it over a pipe. The child (child.py) owns its GL
context (never Blender's), an in-memory USD stage per stream (a viewport, an F12
view layer), and the Sessions that render them. Messages (protocol.py) are plain
pickled data:

  Blender -> host   edit (a stage fragment, engine/usd/fragments.py), render (a
                    view, size, preset, passes), slots (shared memory to draw
                    into), release (a slot read), forget, drop, quit
  host -> Blender   ready, frame (which slot holds which pixels), error, fatal

Pixels travel through multiprocessing.shared_memory blocks that Blender's side
creates and owns ("slots"): the host renders into a free one and hands it over;
Blender copies the pixels out with numpy and hands it back. Rows are bottom-up and
scene linear, as Blender's render results and textures want them.
"""
