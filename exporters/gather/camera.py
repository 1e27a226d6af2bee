"""A Blender camera + render settings -> CameraRecord."""
from ..ir import CameraRecord


def apertures(fit, sensor_width, sensor_height, aspect):
    """(horizontal, vertical, fitted size) in sensor units; aspect = width / height.

    AUTO fits the sensor width to the larger image side, as Blender does."""
    if fit == "AUTO":
        fit = "HORIZONTAL" if aspect >= 1.0 else "VERTICAL"
        sensor_height = sensor_width
    if fit == "HORIZONTAL":
        return sensor_width, sensor_width / aspect, sensor_width
    return sensor_height * aspect, sensor_height, sensor_height


def gather_camera(camera, render, warn):
    aspect = (render.resolution_x * render.pixel_aspect_x) / \
             (render.resolution_y * render.pixel_aspect_y)
    ortho = camera.type == "ORTHO"
    if camera.type == "PANO":
        warn(f"camera '{camera.name}': panoramic cameras are written as perspective")
    if ortho:
        # USD expresses orthographic apertures in tenths of a scene unit.
        size = camera.ortho_scale * 10.0
        h, v, fitted = apertures(camera.sensor_fit, size, size, aspect)
    else:
        h, v, fitted = apertures(camera.sensor_fit, camera.sensor_width,
                                 camera.sensor_height, aspect)
    # Blender's shift is a fraction of the fitted (larger) side.
    return CameraRecord(projection="orthographic" if ortho else "perspective",
                        focal_length=float(camera.lens),
                        horizontal_aperture=float(h), vertical_aperture=float(v),
                        horizontal_offset=float(camera.shift_x * fitted),
                        vertical_offset=float(camera.shift_y * fitted),
                        clip_start=float(camera.clip_start), clip_end=float(camera.clip_end))
