"""The committed Cycles references (tests/references/) match their scene list, and the sky map
the environment scenes use is as asymmetric as documented (no builder runs here: the
engine's image tests build the scenes they render)."""
import pathlib

import numpy as np
import pytest

import reference_scenes

LOOKS = pathlib.Path(__file__).resolve().parent / "references" / "looks"


@pytest.mark.parametrize("name", sorted(reference_scenes.SCENES))
def test_reference_exists_at_its_recorded_size(name):
    from lantern.engine.image_io import read_exr
    image = read_exr(str(LOOKS / f"{name}.exr"))
    width, height = reference_scenes.SCENES[name].size
    assert image.shape == (height, width, 3)
    assert np.isfinite(image).all() and image.max() > 0


def test_before_tables_cover_every_scene():
    for table in ("BEFORE.md", "EXPORTER.md"):
        rows = {line.split("|")[1].strip() for line in (LOOKS / table).read_text().splitlines()
                if line.startswith("| ") and not line.startswith("| scene")}
        assert rows == set(reference_scenes.SCENES), table


def test_sky_features_sit_at_their_documented_directions():
    sky = reference_scenes.sky_pixels()
    d = reference_scenes.latlong_directions(*sky.shape[:2])
    for blob in (reference_scenes.SKY_SUN, reference_scenes.SKY_PATCH):
        brightest = np.unravel_index(np.argmax(
            (sky[..., :3] * (np.array(blob["radiance"]) / np.max(blob["radiance"]))).sum(-1)
            * (d @ reference_scenes.direction(blob["azimuth"], blob["elevation"]) > 0.9)),
            sky.shape[:2])
        got = d[brightest]
        want = reference_scenes.direction(blob["azimuth"], blob["elevation"])
        assert np.degrees(np.arccos(np.clip(got @ want, -1, 1))) < 4.0
    # Asymmetric: the map differs from its own mirror image in every direction.
    assert np.abs(sky - sky[:, ::-1]).max() > 1.0 and np.abs(sky - sky[::-1]).max() > 1.0
