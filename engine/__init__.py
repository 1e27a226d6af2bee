"""USD to pixels: pxr, numpy and moderngl. Never imports bpy.

The engine owns its own headless GL context on a dedicated thread and returns
scene-linear float images; it never touches Blender's GL context.
"""
