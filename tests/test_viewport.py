"""The viewport path without the `gpu` module: the session's pixels, and re-export only
when data changed. (Drawing the pixels through a GPUTexture needs a window.)"""
import numpy as np
import pytest

import calibration


@pytest.fixture(scope="module")
def addon():
    import lantern
    lantern.register()
    yield
    lantern.unregister()


def _camera_matrices(scene, depsgraph, width, height):
    camera = scene.camera
    view = np.array(camera.matrix_world.inverted())
    proj = np.array(camera.calc_matrix_camera(depsgraph, x=width, y=height))
    return view, proj


def test_viewport_from_the_camera_view_equals_f12(addon):
    import bpy
    from lantern.addon.scene_render import ViewportSession, render_final

    scene = calibration.build_scene("point")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    size = calibration.SIZE
    final, _ = render_final(depsgraph, size, size)
    session = ViewportSession()
    session.sync(depsgraph)
    view, proj = _camera_matrices(scene, depsgraph, size, size)
    pixels = session.draw_pixels(view, proj, size, size)
    assert pixels.shape == final.shape
    # Two routes to the same projection (Blender's matrix vs USD's apertures) differ
    # in the last bits, which may round to a neighbouring float16 in the HDR light
    # buffer: one half-precision step is 2^-10 relative.
    assert np.allclose(pixels, final, rtol=2e-3, atol=1e-4), np.abs(pixels - final).max()


def test_redraws_do_not_re_export_unchanged_data(addon):
    """`depsgraph.updates` is filled only inside update callbacks, so the session is
    synced from Blender's depsgraph_update_post handler, as view_update would be."""
    import bpy
    from lantern.addon.scene_render import ViewportSession

    scene = calibration.build_scene("sun")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    session = ViewportSession()
    session.sync(depsgraph)
    view, proj = _camera_matrices(scene, depsgraph, 32, 32)
    first = session.draw_pixels(view, proj, 32, 32)

    def on_update(_scene, updated_depsgraph):
        session.sync(updated_depsgraph)

    bpy.app.handlers.depsgraph_update_post.append(on_update)
    try:
        # Moving the view alone re-renders the stage it has; selecting exports nothing.
        moved = view.copy()
        moved[0, 3] += 1.0
        session.draw_pixels(moved, proj, 32, 32)
        bpy.data.objects["Plane"].select_set(True)
        bpy.context.view_layer.update()
        assert session.exports == 1

        # Changed data is exported again: a brighter sun shows up.
        bpy.data.lights["sun"].energy *= 2.0
        bpy.context.view_layer.update()
        assert session.exports == 2
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(on_update)
    second = session.draw_pixels(view, proj, 32, 32)
    assert np.allclose(second[..., :3], 2.0 * first[..., :3], rtol=1e-3)
