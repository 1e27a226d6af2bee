"""Skinned crowd export: Lantern against Blender's own USD exporter, in one run.

A crowd of characters (a 12-bone chain skinning a ~1,200-vertex tube each), every bone
keyed, 100 frames. Both exporters write the whole animation to a .usdc; prints both
times and their ratio, asserts nothing.

    .venv/bin/python bench/bench_skel_export.py [--large]   # --large: 10× the crowd
"""
import argparse
import os
import tempfile
import time

import lantern.exporters  # noqa: F401  (Blender's pxr first)
import bpy
import numpy as np

from lantern.exporters import export_depsgraph_to_file

BONES, RINGS, SEGMENTS, FRAMES = 12, 100, 12, 100


def _character(index, spacing=2.0):
    name = f"Char{index:03d}"
    data = bpy.data.armatures.new(name + "_rig")
    arm = bpy.data.objects.new(name + "_rig", data)
    bpy.context.scene.collection.objects.link(arm)
    arm.location = ((index % 16) * spacing, (index // 16) * spacing, 0)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    previous = None
    for b in range(BONES):
        eb = data.edit_bones.new(f"Bone{b:02d}")
        eb.head, eb.tail, eb.roll = (0, 0, b * 0.25), (0, 0, (b + 1) * 0.25), 0.1 * b
        eb.parent = previous
        previous = eb
    bpy.ops.object.mode_set(mode="OBJECT")

    s = np.arange(SEGMENTS) * 2 * np.pi / SEGMENTS
    z = np.linspace(0, BONES * 0.25, RINGS)
    verts = np.stack([np.tile(0.3 * np.cos(s), RINGS), np.tile(0.3 * np.sin(s), RINGS),
                      np.repeat(z, SEGMENTS)], axis=1)
    faces = [(r * SEGMENTS + k, r * SEGMENTS + (k + 1) % SEGMENTS,
              (r + 1) * SEGMENTS + (k + 1) % SEGMENTS, (r + 1) * SEGMENTS + k)
             for r in range(RINGS - 1) for k in range(SEGMENTS)]
    mesh = bpy.data.meshes.new(name + "_body")
    mesh.from_pydata(verts.tolist(), [], faces)
    body = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(body)
    body.parent = arm
    body.modifiers.new("Armature", "ARMATURE").object = arm
    for b in range(BONES):
        group = body.vertex_groups.new(name=f"Bone{b:02d}")
        w = np.clip(1 - np.abs(verts[:, 2] - (b + 0.5) * 0.25) / 0.4, 0, 1)
        for v in np.flatnonzero(w > 0):
            group.add([int(v)], float(w[v]), "REPLACE")

    for f in range(1, FRAMES + 1, 10):
        for b, pb in enumerate(arm.pose.bones):
            pb.rotation_mode = "XYZ"
            pb.rotation_euler = (0.2 * np.sin(f / 10 + b + index), 0.15 * np.cos(f / 7 + b), 0)
            pb.keyframe_insert("rotation_euler", frame=f)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--large", action="store_true", help="10× the characters")
    parser.add_argument("--runs", type=int, default=5, help="runs of each exporter")
    args = parser.parse_args()
    count = 160 if args.large else 16
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, FRAMES
    for i in range(count):
        _character(i)
    scene.frame_set(1)
    verts = sum(len(o.data.vertices) for o in scene.objects if o.type == "MESH")
    print(f"crowd: {count} characters × {BONES} bones, {verts // count} vertices each, "
          f"{FRAMES} frames")

    with tempfile.TemporaryDirectory() as folder:
        lantern_path = os.path.join(folder, "lantern.usdc")
        blender_path = os.path.join(folder, "blender.usdc")
        lantern_runs, blender_runs = [], []
        # Alternate the two exporters so that machine noise hits both alike.
        for _ in range(args.runs):
            start = time.perf_counter()
            report = export_depsgraph_to_file(bpy.context.evaluated_depsgraph_get(), lantern_path)
            lantern_runs.append(time.perf_counter() - start)
            start = time.perf_counter()
            bpy.ops.wm.usd_export(filepath=blender_path, export_animation=True,
                                  export_armatures=True, export_shapekeys=True,
                                  export_materials=False, selected_objects_only=False)
            blender_runs.append(time.perf_counter() - start)
        lantern, blender = float(np.median(lantern_runs)), float(np.median(blender_runs))
        print(f"lantern:          {lantern:7.3f} s (median of {args.runs})  "
              f"{os.path.getsize(lantern_path) / 1e6:6.1f} MB  "
              f"{report.counts['skinned']} skinned, {report.counts['baked']} baked, exact "
              f"(UsdSkel parity is tested in tests/test_skel_parity.py)")
        print(f"wm.usd_export:    {blender:7.3f} s (median of {args.runs})  "
              f"{os.path.getsize(blender_path) / 1e6:6.1f} MB")
        print(f"time ratio Lantern / Blender: {lantern / blender:.2f}x (target <= 1.0x)")


if __name__ == "__main__":
    main()
