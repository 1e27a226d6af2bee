"""Multi-part EXRs as Blender writes them (one part per view layer and pass), read with
OpenImageIO, the library Lantern itself reads images with."""
import numpy as np


def read_parts(path) -> dict:
    """{part name ('ViewLayer.Combined', ...): float32 (H, W, C)}, row 0 = top."""
    import OpenImageIO as oiio
    image = oiio.ImageInput.open(str(path))
    if image is None:
        raise OSError(f"{path}: {oiio.geterror()}")
    parts = {}
    try:
        subimage = 0
        while image.seek_subimage(subimage, 0):
            spec = image.spec()
            pixels = image.read_image(subimage, 0, 0, spec.nchannels, "float")
            parts[spec.getattribute("name")] = np.asarray(pixels, np.float32).reshape(
                spec.height, spec.width, spec.nchannels)
            subimage += 1
    finally:
        image.close()
    return parts
