"""Overlays (engine/overlays.py, engine/gpu/overlays.py, `lantern render --burn-in
--watermark`): glyph coverage against the font's outlines rasterised on the CPU by
FreeType (through Pillow), the burn-in's rectangle, the watermark's alpha, the CLI's
fields and its scene-linear .exr left clean."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from lantern.engine.overlays import BurnIn, Sprite, Text, draw, font_atlas, text_box

ImageFont = pytest.importorskip("PIL.ImageFont")
from PIL import Image, ImageDraw  # noqa: E402

LINE = "Lantern f0012 {gAy}"


def _font_path():
    import matplotlib
    return os.path.join(os.path.dirname(matplotlib.__file__), "mpl-data", "fonts", "ttf",
                        "DejaVuSansMono.ttf")


def _freetype(text, width, height, supersample):
    """The text's coverage by FreeType at the same pen origins as the engine's layout
    (each glyph on a whole pixel). supersample > 1: the outline rasterised at that many
    times the size and averaged (area coverage, hinting negligible); 1: FreeType's own
    hinted pixels."""
    k = supersample
    font = ImageFont.truetype(_font_path(), int(text.size * k))
    atlas = font_atlas()
    canvas = Image.new("L", (width * k, height * k), 0)
    pen_draw = ImageDraw.Draw(canvas)
    baseline = math.floor(text.y + float(atlas["ascent"]) * text.size + 0.5)
    pen = float(text.x)
    for ch in text.text:
        pen_draw.text((math.floor(pen + 0.5) * k, baseline * k), ch, font=font, fill=255, anchor="ls")
        pen += float(atlas["advance"][atlas["index"][ch]]) * text.size
    return (np.asarray(canvas) / 255.0).reshape(height, k, width, k).mean(axis=(1, 3))


def _coverage(size, mode):
    """(engine's coverage, the text): white text, no halo, on opaque black."""
    width, height = int(size * 0.62 * len(LINE) + 12), int(size * 1.3 + 10)
    black = np.zeros((height, width, 4), np.uint8)
    black[..., 3] = 255
    text = Text(LINE, 5, 5, size, halo_color=(0, 0, 0, 0), mode=mode)
    return draw(black, [], [text])[..., 0] / 255.0, text


def _edge_figures(ours, reference):
    edge = ((reference > 0) & (reference < 1)) | ((ours > 0) & (ours < 1))
    diff = np.abs(ours - reference)
    return diff[edge].mean(), (diff[edge] > 0.25).mean(), edge


@pytest.mark.parametrize("size, mean_bound, wrong_bound", [(12, 0.08, 0.02), (96, 0.12, 0.06)])
def test_sdf_text_coverage_matches_freetype_outlines(size, mean_bound, wrong_bound):
    # Measured 2026-11-25: 12 px mean 0.043, 0.5 % of edge pixels off by > 0.25;
    # 96 px mean 0.081, 2.7 % (the distance field rounds the outlines' corners).
    ours, text = _coverage(size, "sdf")
    reference = _freetype(text, ours.shape[1], ours.shape[0], supersample=8)
    mean, wrong, edge = _edge_figures(ours, reference)
    assert mean <= mean_bound and wrong <= wrong_bound, (mean, wrong)
    assert abs(ours.sum() / reference.sum() - 1.0) < 0.03
    # Away from the outlines (2 px and more) ink is ink and paper is paper.
    from scipy.ndimage import binary_dilation
    near = binary_dilation(edge, iterations=2)
    assert np.abs(ours - reference)[~near].max() < 0.02
    if size > 20:
        assert (reference[~near] == 1).sum() > 1000


def test_bitmap_text_is_freetypes_own_pixels():
    ours, text = _coverage(12, "bitmap")
    reference = _freetype(text, ours.shape[1], ours.shape[0], supersample=1)
    assert np.abs(ours - reference).max() <= 1 / 255 + 1e-9
    assert reference.sum() > 200


def test_sdf_text_is_sharp_from_8_to_200_px():
    """The edge stays about one pixel wide at any size: partial pixels per unit of
    outline length do not grow with the size."""
    for size in (8, 24, 200):
        width, height = int(size * 0.62 * 2 + 12), int(size * 1.3 + 10)
        black = np.zeros((height, width, 4), np.uint8)
        black[..., 3] = 255
        ours = draw(black, [], [Text("Il", 2, 2, size, halo_color=(0, 0, 0, 0),
                                     mode="sdf")])[..., 0] / 255.0
        partial = ((ours > 0.05) & (ours < 0.95)).sum()
        outline_px = 2 * ((ours > 0.5).sum(axis=0) > 0).sum() + 2 * ((ours > 0.5).sum(axis=1) > 0).sum()
        assert partial < 2.5 * outline_px, (size, partial, outline_px)


def test_burn_in_changes_only_its_rectangle():
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (90, 320, 4), dtype=np.uint8)
    image[..., 3] = 255
    burn = BurnIn("{scene} {camera} f{frame:04d}", anchor="bottom-left", size=20,
                  values=dict(scene="shot010", camera="cam", preset="medium"))
    out = burn.apply(image, frame=12)
    (text,) = burn.texts(320, 90, 12)
    assert text.text == "shot010 cam f0012"
    x, y, w, h = text_box(text)
    changed = np.any(out != image, axis=-1)
    inside = np.zeros_like(changed)
    inside[y:y + h, x:x + w] = True
    assert changed.sum() > 100 and not changed[~inside].any()
    assert 0 <= x and y + h <= 90 and h <= 1.5 * 20 + 8     # the rectangle is the text's


def test_outline_keeps_text_legible_on_its_own_colour():
    white = np.full((40, 120, 4), 255, np.uint8)
    out = draw(white, [], [Text("Ag", 5, 5, 24, mode="sdf")])
    assert (out[..., 0] < 40).sum() > 50         # the dark outline around white glyphs


def test_watermark_alpha_and_normalised_placement():
    background = np.zeros((40, 60, 4), np.uint8)
    background[..., 2] = 200
    background[..., 3] = 255
    sprite = np.zeros((10, 20, 4), np.uint8)
    sprite[..., 0] = 255
    sprite[..., 3] = 64
    sprite[:, 10:, 3] = 255
    out = draw(background, [Sprite(sprite, 5, 7, 20, 10)])
    a = 64 / 255
    np.testing.assert_allclose(out[7:17, 5:15, 0], round(255 * a), atol=1)
    np.testing.assert_allclose(out[7:17, 5:15, 2], round(200 * (1 - a)), atol=1)
    assert (out[7:17, 15:25, :3] == (255, 0, 0)).all()
    untouched = np.ones((40, 60), bool)
    untouched[7:17, 5:25] = False
    assert (out[untouched] == background[untouched]).all()
    # Normalised: the same place as fractions of the target.
    again = draw(background, [Sprite(sprite, 5 / 60, 7 / 40, 20 / 60, 10 / 40, normalised=True)])
    assert (again == out).all()
    # Over a transparent image the result keeps straight alpha.
    clear = np.zeros((40, 60, 4), np.uint8)
    over = draw(clear, [Sprite(sprite, 5, 7, 20, 10)])
    assert abs(int(over[10, 8, 3]) - 64) <= 1 and over[10, 8, 0] == 255


# --- the command line ---------------------------------------------------------------------

def _lantern(*args):
    return subprocess.run([sys.executable, "-m", "lantern", *args], capture_output=True,
                          text=True)


def test_burn_in_unknown_field_is_a_usage_error(tmp_path):
    for template in ("{shot} f{frame}", "{frame:04q}", "{scene"):
        proc = _lantern("render", str(tmp_path / "none.usda"), "-o", str(tmp_path / "x.png"),
                        "--burn-in", template)
        assert proc.returncode == 2, (template, proc.stderr)
        assert "--burn-in" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    proc = _lantern("render", "x.usda", "-o", "x.png", "--help")
    assert "{camera}" in proc.stdout and "{frame}" in proc.stdout and "{date}" in proc.stdout


def test_cli_burn_in_on_png_frames_and_clean_exr(tmp_path):
    from test_sequence import animated_stage
    from lantern.engine.image_io import read_image
    scene = tmp_path / "shot010.usda"
    stage = animated_stage()
    stage.GetRootLayer().Export(str(scene))
    mark = tmp_path / "mark.png"
    Image.fromarray(np.full((8, 8, 4), (255, 255, 0, 128), np.uint8)).save(mark)
    common = ("--size", "160x60", "--preset", "low")
    plain = _lantern("render", str(scene), "-o", str(tmp_path / "plain.png"), "--frame", "1",
                     *common)
    burnt = _lantern("render", str(scene), "-o", str(tmp_path / "burnt.png"), "--frame", "1",
                     *common, "--burn-in", "{scene} {camera} f{frame:04d}",
                     "--burn-in-size", "12", "--burn-in-position", "top-left",
                     "--watermark", str(mark), "--watermark-scale", "0.1")
    assert plain.returncode == 0 and burnt.returncode == 0, plain.stderr + burnt.stderr
    a, b = read_image(tmp_path / "plain.png"), read_image(tmp_path / "burnt.png")
    changed = np.any(a != b, axis=-1)
    assert changed[:20, :120].sum() > 50                 # the burn-in, top left
    assert changed[40:, 120:].sum() > 20                 # the watermark, bottom right
    assert not changed[24:38, :].any()                   # nothing between them
    # The .exr stays scene linear: the same with and without a burn-in.
    exr = _lantern("render", str(scene), "-o", str(tmp_path / "b.exr"), "--frame", "1",
                   *common, "--burn-in", "{scene}")
    exr_plain = _lantern("render", str(scene), "-o", str(tmp_path / "a.exr"), "--frame", "1",
                         *common)
    assert exr.returncode == 0 and "overlays are drawn on .png" in exr.stderr
    assert exr_plain.returncode == 0
    assert (read_image(tmp_path / "a.exr") == read_image(tmp_path / "b.exr")).all()
    # A sequence (farm/): each frame gets its own number.
    seq = _lantern("render", str(scene), "-o", str(tmp_path / "seq" / "f_####.png"),
                   "--frames", "1:2", *common, "--burn-in", "f{frame:04d}",
                   "--burn-in-size", "12", "--burn-in-position", "top-left")
    assert seq.returncode == 0, seq.stderr
    one = read_image(tmp_path / "seq" / "f_0001.png")
    two = read_image(tmp_path / "seq" / "f_0002.png")
    box = one[:20, :60] != two[:20, :60]
    assert box.any()                                       # the frame numbers differ


def test_cli_burn_in_on_several_scenes_names_each(tmp_path):
    """Several scenes into a folder: each image gets its own {scene}, and only there."""
    from test_sequence import animated_stage
    from lantern.engine.image_io import read_image
    stage = animated_stage()
    for name in ("shot010", "shot020"):
        stage.GetRootLayer().Export(str(tmp_path / f"{name}.usda"))
    proc = _lantern("render", str(tmp_path / "shot010.usda"), str(tmp_path / "shot020.usda"),
                    "-o", str(tmp_path / "out") + os.sep, "--frame", "1", "--size", "160x60",
                    "--preset", "low", "--burn-in", "{scene}", "--burn-in-size", "12",
                    "--burn-in-position", "top-left")
    assert proc.returncode == 0, proc.stderr
    one = read_image(tmp_path / "out" / "shot010.png")
    two = read_image(tmp_path / "out" / "shot020.png")
    changed = np.any(one != two, axis=-1)
    assert changed[:20, :80].any() and not changed[20:, :].any() and not changed[:, 80:].any()
