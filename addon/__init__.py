"""Blender UI: the LANTERN render engine, its properties, panels and operators."""
