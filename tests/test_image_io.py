"""Image I/O on OpenImageIO: precision kept, errors named, atomic writes, GIF previews.

The engine's image path must work where Blender's Python has no imageio, OpenEXR or
Pillow: the first tests import it with those blocked, in this (bpy) process with
Blender's own OpenImageIO, and in a plain process with PyPI's."""
import importlib
import os
import subprocess
import sys

import numpy as np
import pytest

BLOCKED = ("imageio", "imageio.v3", "OpenEXR", "Imath", "PIL", "PIL.Image")
ENGINE_IMAGE_MODULES = ("lantern.engine.image_io", "lantern.engine.color",
                        "lantern.engine.textures")


def _fixtures(folder):
    """Files in every precision the engine reads, written with OpenImageIO directly:
    name -> (path, expected array)."""
    import OpenImageIO as oiio
    ramp16 = (np.arange(64 * 16, dtype=np.uint32).reshape(16, 64) * 64).astype(np.uint16)
    cases = {
        "png8": ("a8.png", "uint8", np.dstack([np.arange(256, dtype=np.uint8).reshape(16, 16)] * 3)),
        "png16": ("a16.png", "uint16", np.dstack([ramp16] * 3)),
        "tif16": ("a16.tif", "uint16", np.dstack([ramp16, ramp16[::-1], ramp16, ramp16])),
        "exr_half": ("h.exr", "half", np.full((4, 6, 4), 4.0, np.float16)),
        "exr_float": ("f.exr", "float", np.array([[[1e-8, 4.0, 65504.0 * 4, 0.5]]], np.float32)),
        "hdr": ("e.hdr", "float", np.full((4, 8, 3), 4.0, np.float32)),
    }
    out = {}
    for name, (file, kind, pixels) in cases.items():
        path = os.path.join(folder, file)
        spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], kind)
        spec.attribute("oiio:UnassociatedAlpha", 1)
        o = oiio.ImageOutput.create(path)
        assert o.open(path, spec) and o.write_image(pixels), o.geterror()
        o.close()
        out[name] = (path, pixels)
    return out


def _check_reads_and_writes(folder):
    from lantern.engine.image_io import read_image, write_image
    for name, (path, expected) in _fixtures(folder).items():
        got = read_image(path)
        assert got.dtype == expected.dtype, name
        assert got.shape == expected.shape, name
        assert np.array_equal(got, expected), name
    rgba = np.zeros((3, 5, 4), np.float32)
    rgba[..., 0] = 4.0        # above 1: kept in the EXR, clamped in the PNG
    rgba[..., 3] = 0.5
    write_image(os.path.join(folder, "o.exr"), rgba)
    write_image(os.path.join(folder, "o.png"), rgba)
    assert np.array_equal(read_image(os.path.join(folder, "o.exr")), rgba)
    png = read_image(os.path.join(folder, "o.png"))
    assert png.dtype == np.uint8 and tuple(png[0, 0]) == (255, 0, 0, 128)


@pytest.fixture
def without_other_image_libraries(monkeypatch):
    """imageio, OpenEXR and Pillow made unimportable; the engine's image modules
    imported afresh under that rule."""
    for name in BLOCKED:
        monkeypatch.setitem(sys.modules, name, None)
    for name in ENGINE_IMAGE_MODULES:
        monkeypatch.delitem(sys.modules, name, raising=False)
    for name in ENGINE_IMAGE_MODULES:
        importlib.import_module(name)


def test_engine_image_path_needs_no_imageio_openexr_or_pillow(without_other_image_libraries,
                                                               tmp_path):
    import OpenImageIO
    assert "bpy" in OpenImageIO.__file__, "a bpy process must use Blender's OpenImageIO"
    _check_reads_and_writes(str(tmp_path))
    from lantern.engine.textures import read_image_linear
    linear = read_image_linear(str(tmp_path / "e.hdr"), "auto")
    assert linear.shape == (4, 8, 4) and np.all(linear[..., :3] == 4.0)


def test_same_without_bpy_on_pypi_openimageio(tmp_path):
    script = (
        "import sys\n"
        f"for n in {BLOCKED!r}: sys.modules[n] = None\n"
        "sys.modules['bpy'] = None\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "import test_image_io as t, OpenImageIO\n"
        "assert 'bpy' not in OpenImageIO.__file__\n"
        "t._check_reads_and_writes(sys.argv[2])\n")
    proc = subprocess.run([sys.executable, "-c", script, os.path.dirname(__file__), str(tmp_path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_unreadable_images_raise_image_error_naming_the_file(tmp_path):
    from lantern.engine.image_io import ImageError, read_image, write_image
    good = tmp_path / "good.png"
    write_image(str(good), np.ones((8, 8, 4), np.float32))
    truncated = tmp_path / "truncated.png"
    truncated.write_bytes(good.read_bytes()[:40])
    garbage = tmp_path / "garbage.exr"
    garbage.write_bytes(b"not an image at all" * 10)
    for path in (truncated, garbage, tmp_path / "missing.tif"):
        with pytest.raises(ImageError, match=path.name):
            read_image(str(path))
    assert issubclass(ImageError, ValueError)


def test_stored_colour_is_kept_under_zero_alpha(tmp_path):
    """No premultiplication on read: a cut-out's hidden texels keep their colour."""
    import imageio.v3 as iio
    from lantern.engine.image_io import read_image
    pixels = np.zeros((2, 2, 4), np.uint8)
    pixels[..., :3] = (200, 100, 50)
    pixels[0, 0, 3] = 0
    pixels[1, 1, 3] = 255
    iio.imwrite(tmp_path / "cut.png", pixels)          # an independent PNG writer
    assert np.array_equal(read_image(str(tmp_path / "cut.png")), pixels)


def test_writes_are_atomic_and_reject_unknown_extensions(tmp_path):
    from lantern.engine.image_io import write_animation, write_image
    img = np.ones((4, 4, 4), np.float32)
    write_image(str(tmp_path / "x.png"), img)
    write_image(str(tmp_path / "x.png"), img * 0.5)
    with pytest.raises(ValueError, match="extension"):
        write_image(str(tmp_path / "z.jpg"), img)
    with pytest.raises(ValueError):
        write_image(str(tmp_path / "w.exr"), img[..., :3])
    with pytest.raises(ValueError, match="gif"):
        write_animation(str(tmp_path / "a.mp4"), [img], 24)
    assert sorted(os.listdir(tmp_path)) == ["x.png"]


def test_gif_preview_decodes_frame_by_frame(tmp_path):
    """Decoded by an independent reader (Pillow, through imageio): every frame, the
    loop, the frame time, and colours close to the exact sRGB encoding."""
    import imageio.v3 as iio
    from PIL import Image
    from lantern.engine.color import to_srgb8
    from lantern.engine.image_io import write_animation
    h, w = 36, 64
    x = np.linspace(0.0, 1.0, w, dtype=np.float32)[None, :]
    frames = []
    for i in range(5):
        rgba = np.ones((h, w, 4), np.float32)
        rgba[..., 0] = x * (i + 1) / 5
        rgba[..., 1] = np.linspace(0, 1, h, dtype=np.float32)[:, None] ** 2
        rgba[..., 2] = 0.2
        frames.append(rgba)
    path = tmp_path / "p.gif"
    write_animation(str(path), frames, fps=25)
    decoded = iio.imread(path, index=None)
    assert decoded.shape[:3] == (5, h, w)
    for got, rgba in zip(decoded, frames):
        err = np.abs(got[..., :3].astype(int) - to_srgb8(rgba)[..., :3].astype(int))
        # 256 colours for a 2-D gradient of 11,520 colours: about 4 levels apart.
        assert err.mean() < 3.5 and err.max() <= 16
    with Image.open(path) as gif:
        assert gif.info["loop"] == 0 and gif.info["duration"] == 40 and gif.n_frames == 5


def test_gif_lzw_survives_a_full_code_table(tmp_path):
    """Enough distinct index pairs to fill the 4096-entry table several times."""
    import imageio.v3 as iio
    from lantern.engine.image_io import encode_gif
    rng = np.random.default_rng(5)
    palette = rng.integers(0, 256, (256, 3), dtype=np.uint8)
    img = palette[rng.integers(0, 256, (120, 160))]
    path = tmp_path / "noise.gif"
    path.write_bytes(encode_gif([img], fps=10))
    decoded = iio.imread(path, index=None)[0][..., :3]
    # Each decoded pixel is the palette colour nearest its 15-bit key: close to the source.
    assert decoded.shape == img.shape
    assert np.abs(decoded.astype(int) - img.astype(int)).mean() < 16


def test_a_png_is_deflated_at_blenders_default_level(tmp_path):
    """PNGs are written as Blender saves them by default (Compression 15%: zlib level 1),
    not at zlib's default level 6, which took more than twice as long: the zlib header
    of the first image data chunk says which (FLEVEL 0: the fastest)."""
    import struct
    from lantern.engine.image_io import read_image, write_image
    rng = np.random.default_rng(5)
    rgba = np.concatenate([rng.random((90, 160, 3)), np.ones((90, 160, 1))], -1)
    path = tmp_path / "x.png"
    write_image(str(path), rgba.astype(np.float32))
    data = path.read_bytes()
    at = 8
    while data[at + 4:at + 8] != b"IDAT":
        at += 12 + struct.unpack(">I", data[at:at + 4])[0]
    cmf, flg = data[at + 8], data[at + 9]
    assert cmf & 0x0F == 8 and flg >> 6 == 0
    assert read_image(str(path)).shape == (90, 160, 4)
