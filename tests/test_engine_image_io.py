"""The engine's image files: float EXR round trips exactly, PNG is sRGB-encoded with
alpha kept, and writes are atomic."""
import os

import imageio.v3 as iio
import numpy as np
import pytest

from lantern.engine import read_exr, write_image


def test_exr_round_trip_exact(tmp_path):
    rng = np.random.default_rng(1)
    img = (rng.random((7, 9, 4)) * 100 - 10).astype(np.float32)
    img[0, 0] = (1e-8, 65504.0 * 4, 0.0, 0.5)
    write_image(str(tmp_path / "a.exr"), img)
    assert np.array_equal(read_exr(str(tmp_path / "a.exr")), img)


def test_png_is_srgb_encoded_and_alpha_kept(tmp_path):
    img = np.zeros((2, 3, 4), np.float32)
    img[0, 0] = (0.5, 0.0, 1.0, 1.0)
    img[0, 1] = (2.0, -1.0, 0.0031308, 0.5)
    write_image(str(tmp_path / "a.png"), img)
    out = iio.imread(tmp_path / "a.png")
    assert out.dtype == np.uint8 and out.shape == (2, 3, 4)
    assert tuple(out[0, 0]) == (188, 0, 255, 255)
    assert tuple(out[0, 1]) == (255, 0, 10, 128)


def test_atomic_write_leaves_no_temp_and_rejects_unknown(tmp_path):
    img = np.ones((4, 4, 4), np.float32)
    write_image(str(tmp_path / "x.png"), img)
    write_image(str(tmp_path / "x.png"), img * 0.5)   # overwrite in place
    write_image(str(tmp_path / "y.exr"), img)
    assert sorted(os.listdir(tmp_path)) == ["x.png", "y.exr"]
    with pytest.raises(ValueError, match="extension"):
        write_image(str(tmp_path / "z.tiff"), img)
    assert sorted(os.listdir(tmp_path)) == ["x.png", "y.exr"]
