"""Depsgraph updates to stage edits, sized by what changed.

A LiveScene keeps a mirror of the stage the engine host holds for one viewport (or
one F12 view layer). Each sync turns Blender's depsgraph updates into partial exports
(exporters/live.py) written into the mirror, and returns the fragment of what USD
reports changed (engine/usd/fragments.py), which the host applies to its copy:

  an object moved (or its pass index)     that object's transform ops
  a mesh edited (modifiers, edit mode)    that mesh, re-exported alone
  a material edited                       that material
  a light or camera edited                that prim
  a pose, a frame change                  joint channels and blend-shape weights;
                                          transforms of what moves in time; meshes
                                          whose deformation is baked
  the world edited                        the dome
  objects added, removed, renamed,        the whole scene exported again, of which
  re-parented, hidden; scene settings     only the difference is sent

Nothing is sampled over the frame range: a frame change reads that frame only.
No bpy.types here besides isinstance checks, so the whole path runs in background
mode and in tests, with real depsgraph updates.
"""
from __future__ import annotations

import time
from collections import Counter

import bpy

from ..engine.usd.fragments import Mirror
from ..exporters import ExportOptions, export_depsgraph
from ..exporters.live import (NeedsFullExport, animated, export_data, export_geometry,
                              export_live, export_material, export_object, export_pose,
                              export_world, settings_key)


def subdivision_option(scene) -> str:
    """The scene's Lantern > Subdivision as ExportOptions.subdivision ("apply" where the
    add-on's settings are not registered: the exporters used alone)."""
    settings = getattr(scene, "lantern", None)
    return settings.subdivision.lower() if settings is not None else "apply"


class StillScene:
    """F12 and previews: the render depsgraph exported whole at each render (as
    `lantern export` would), of which only the difference from the previous render
    goes to the host, whose Session re-reads only that (an animation's frames share
    one Session)."""

    def __init__(self):
        self.mirror = Mirror()
        self.warnings = []

    def sync(self, depsgraph):
        options = ExportOptions(subdivision=subdivision_option(depsgraph.scene))
        report = self.mirror.replace(lambda stage: export_depsgraph(depsgraph, stage, options))
        self.warnings = report.warnings
        return self.mirror.fragment()

    def close(self):
        self.mirror.close()


class LiveScene:
    """A viewport's scene: the current frame, kept up to date from depsgraph updates."""

    def __init__(self):
        self.mirror = Mirror()
        self.index = None
        self.warnings = []
        self.exports = Counter()      # partial and full exports done, by kind
        self.last = []                # the exports of the last sync: [(kind, key)]
        self.seconds = 0.0            # the last sync's export time

    def _warn(self, message):
        if message not in self.warnings:
            self.warnings.append(message)

    def sync(self, depsgraph):
        """Exports what the depsgraph's updates changed; returns the fragment for
        the host (None when the stage did not change)."""
        t0 = time.perf_counter()
        self.last = []
        try:
            if self.index is None or self._structure_changed(depsgraph):
                self._full(depsgraph)
            else:
                self._partial(depsgraph)
        except NeedsFullExport:
            self._full(depsgraph)
        self.seconds = time.perf_counter() - t0
        return self.mirror.fragment()

    def _did(self, kind, key=None):
        self.exports[kind] += 1
        self.last.append((kind, key))

    def _full(self, depsgraph):
        self.warnings = []
        self.index = export_live(depsgraph, self.mirror.stage, self._warn,
                                 subdivision_option(depsgraph.scene))
        self._did("scene")

    # --- what kind of change ----------------------------------------------------------
    def _structure_changed(self, depsgraph) -> bool:
        index = self.index
        if settings_key(depsgraph.scene) != index.settings or \
                subdivision_option(depsgraph.scene) != index.subdivision:
            return True
        for update in depsgraph.updates:
            item = update.id
            if isinstance(item, bpy.types.Collection) and update.is_updated_geometry:
                return True                 # objects linked, unlinked, shown or hidden
            if not isinstance(item, bpy.types.Object):
                continue
            original = item.original
            key = original.name_full
            if key not in index.objects:
                if not original.hide_render and key in _render_visible(depsgraph):
                    return True             # added, renamed, or shown
                continue
            parent = original.parent.name_full if original.parent else None
            if parent != index.parents.get(key) or original.hide_render:
                return True
        return False

    def _partial(self, depsgraph):
        index, scene = self.index, depsgraph.scene
        stage = self.mirror.stage
        objects, materials, world = {}, set(), False
        for update in depsgraph.updates:
            item = update.id
            if isinstance(item, bpy.types.Object):
                key = item.original.name_full
                if key in index.objects:
                    flags = objects.setdefault(key, [False, False])
                    flags[0] |= update.is_updated_transform or update.is_updated_shading
                    flags[1] |= update.is_updated_geometry
            elif isinstance(item, bpy.types.Material):
                materials.add(item.original.name_full)
            elif isinstance(item, bpy.types.World):
                world = True
        frame_changed = scene.frame_current != index.frame
        posed = {key for key in index.skeletons if key in objects and objects[key][1]}
        if frame_changed:
            posed |= set(index.skeletons)
        moved = set(index.moving) if frame_changed else set()
        reshaped = set(index.baked) if frame_changed else set()
        data = {k for k, o in index.objects.items() if o.kind in ("light", "camera") and
                frame_changed and _data_animated(k)}
        for key, (transform, geometry) in objects.items():
            obj = index.objects[key]
            if transform:
                moved.add(key)
            if not geometry:
                continue
            if obj.kind in ("light", "camera"):
                data.add(key)
            elif key in index.skeletons and obj.kind != "mesh":
                posed.add(key)                        # an armature: its pose
            elif key in index.rig_of and key not in index.baked:
                rig = index.rig_of[key]
                # Deformed by its rig being posed or a new frame: the pose says it all.
                # Else its rest mesh, weights or modifiers changed.
                if not (frame_changed or rig in posed or rig == key):
                    raise NeedsFullExport(f"skinned mesh {key} changed")
                posed.add(rig)
            elif obj.kind == "mesh" or obj.curves or obj.points is not None:
                reshaped.add(key)      # hair and point clouds: a full export (export_geometry)
        for key in sorted(moved - data):
            if export_object(depsgraph, stage, index, key):
                self._did("object", key)
        for key in sorted(data):
            export_data(depsgraph, stage, index, key, self._warn)
            self._did("data", key)
        for key in sorted(reshaped):
            export_geometry(depsgraph, stage, index, key, self._warn)
            self._did("geometry", key)
        for key in sorted(posed):
            export_pose(depsgraph, stage, index, key)
            self._did("pose", key)
        for key in sorted(materials & set(index.materials)):
            export_material(depsgraph, stage, index, key, self._warn)
            self._did("material", key)
        if world:
            export_world(depsgraph, stage, index, self._warn)
            self._did("world")
        index.frame = scene.frame_current

    def close(self):
        self.mirror.close()


def _render_visible(depsgraph) -> set:
    from ..exporters.gather.scene import render_visible
    return render_visible(depsgraph.view_layer)


def _data_animated(key) -> bool:
    ob = bpy.data.objects.get(key)
    return ob is not None and animated(ob.data)
