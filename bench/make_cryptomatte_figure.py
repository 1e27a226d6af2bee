"""Makes docs/figures/cryptomatte.png: Blender's own compositor reading a Cryptomatte
file `lantern render` wrote (the demo scene, frame 13, high).

Blender cannot draw its node editor without a window and a GPU, so the figure is what
the compositor computes, headless: its Cryptomatte node (Image mode) on Lantern's EXR,
left to right: the Combined image, the node's Pick output (each id its colour), the
Matte of an object picked by name, and the Combined image keyed by that matte.

    .venv/bin/python bench/make_cryptomatte_figure.py   # ~1 min on 2 cores
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

FIGURE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs", "figures",
                      "cryptomatte.png")
SIZE = (320, 180)
PICKED = "/root/Suzanne/Suzanne"      # the object picked by name (a mesh prim's path)


def run_lantern(*args):
    subprocess.run([sys.executable, "-m", "lantern", *args], check=True)


def compositor(exr, output, folder):
    """One output of the Cryptomatte node, picking PICKED, as float RGBA, row 0 = top."""
    import bpy
    from lantern.engine.image_io import read_exr
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    tree = bpy.data.node_groups.new("mattes", "CompositorNodeTree")
    scene.compositing_node_group = tree
    image = tree.nodes.new("CompositorNodeImage")
    image.image = bpy.data.images.load(exr)
    matte = tree.nodes.new("CompositorNodeCryptomatteV2")
    matte.source = 'IMAGE'
    matte.image = image.image
    matte.layer_name = "ViewLayer.CryptoObject"
    matte.matte_id = PICKED
    tree.links.new(image.outputs[0], matte.inputs["Image"])
    out = tree.nodes.new("NodeGroupOutput")
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    source = image.outputs[0] if output == "Combined" else matte.outputs[output]
    tree.links.new(source, out.inputs[0])
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.filepath = os.path.join(folder, f"{output}.exr")
    bpy.ops.render.render(write_still=True)
    return read_exr(scene.render.filepath)


def main():
    import lantern.exporters  # noqa: F401  (Blender's pxr first)
    from lantern.demo.build_scene import build
    import OpenImageIO as oiio
    from lantern.engine.color import to_display8
    with tempfile.TemporaryDirectory() as folder:
        blend = os.path.join(folder, "demo.blend")
        build(blend)
        run_lantern("export", blend, "-o", os.path.join(folder, "demo.usdc"))
        exr = os.path.join(folder, "frame.exr")
        run_lantern("render", os.path.join(folder, "demo.usdc"), "-o", exr, "--frame", "13",
                "--size", f"{SIZE[0]}x{SIZE[1]}", "--preset", "high",
                "--passes", "crypto_object,crypto_material,crypto_asset")
        panels = []
        for output in ("Combined", "Pick", "Matte", "Image"):
            rgba = compositor(exr, output, folder)
            if output == "Matte":
                rgba = np.concatenate([np.repeat(rgba[..., :1], 3, -1),
                                       np.ones_like(rgba[..., :1])], -1)
            panels.append(to_display8(rgba, view="AgX" if output in ("Combined", "Image") else "Standard"))
        gap = np.full((SIZE[1], 4, 4), 255, np.uint8)
        row = np.concatenate(sum(([p, gap] for p in panels), [])[:-1], axis=1)
        row[..., 3] = 255
        image = oiio.ImageBuf(oiio.ImageSpec(row.shape[1], row.shape[0], 4, "uint8"))
        image.set_pixels(oiio.ROI(), row)
        image.write(FIGURE)


if __name__ == "__main__":
    main()
