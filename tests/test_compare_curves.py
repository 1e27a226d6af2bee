"""lantern compare, without rendering: equal-error interpolation on synthetic curves,
the winner at equal error, the summary line, and the image metrics on made-up images."""
import math

import numpy as np
import pytest

from lantern.compare import metrics
from lantern.compare.curves import time_to_reach
from lantern.compare.run import _bounds, _equal_error, _summary, _winner


def power_law_curve(samples=(1, 4, 16, 64, 256), c=0.2, slope=0.5, per_sample=0.01, sync=0.0):
    """error = c·s^-slope, seconds = per_sample·s: a straight line in log-log."""
    return [(s, sync + per_sample * s, c * s ** -slope) for s in samples]


def test_a_power_law_is_interpolated_exactly():
    curve = power_law_curve()
    target = 0.2 * 10 ** -0.5          # the error at 10 samples, between 4 and 16
    found = time_to_reach(curve, target)
    assert found.status == "reached"
    assert found.seconds == pytest.approx(0.1, rel=1e-12)
    assert found.samples == pytest.approx(10.0, rel=1e-12)


def test_a_target_on_a_sweep_point_gives_that_point():
    found = time_to_reach(power_law_curve(), 0.2 * 16 ** -0.5)
    assert found.status == "reached"
    assert found.seconds == pytest.approx(0.16) and found.samples == pytest.approx(16)


def test_interpolation_is_log_log_not_linear():
    # Two points 100x apart in time and 10x apart in error: the geometric middle of
    # the errors is reached at the geometric middle of the times (10x), where a
    # linear interpolation would say about 55x.
    found = time_to_reach([(1, 1.0, 0.1), (100, 100.0, 0.01)], math.sqrt(0.1 * 0.01))
    assert found.seconds == pytest.approx(10.0)


def test_already_below_at_the_first_sample():
    found = time_to_reach(power_law_curve(), 0.5)   # above the 1-sample error 0.2
    assert found.status == "already_below"
    assert found.bound_seconds == pytest.approx(0.01) and found.bound_samples == 1
    assert found.seconds is None


def test_not_reached_by_the_last_sample():
    found = time_to_reach(power_law_curve(), 0.001)  # 256 samples give 0.0125
    assert found.status == "not_reached"
    assert found.bound_seconds == pytest.approx(2.56) and found.bound_samples == 256


def test_a_noisy_curve_uses_the_first_crossing():
    # Noise makes the curve go up again after crossing: the first crossing counts.
    curve = [(1, 0.1, 0.30), (4, 0.4, 0.12), (16, 1.6, 0.14), (64, 6.4, 0.05)]
    found = time_to_reach(curve, 0.13)
    assert found.status == "reached" and 0.1 < found.seconds < 0.4


def test_points_arrive_in_any_order_and_unusable_ones_are_ignored():
    curve = power_law_curve()
    shuffled = [curve[3], curve[0], (8, 0.08, None), curve[4], curve[2], (2, float("nan"), 0.1),
                curve[1]]
    assert time_to_reach(shuffled, 0.05) == time_to_reach(curve, 0.05)


def test_no_curve():
    assert time_to_reach([], 0.1).status == "no_curve"
    assert time_to_reach([(1, 0.5, None)], 0.1).status == "no_curve"
    assert time_to_reach(power_law_curve(), float("nan")).status == "no_curve"


def test_an_error_of_zero_is_reached_where_it_occurs():
    found = time_to_reach([(1, 1.0, 0.5), (4, 4.0, 0.0)], 0.0)
    assert found.status == "reached" and found.seconds == pytest.approx(4.0)


# --- the winner at equal error ------------------------------------------------------

def test_the_winner_is_strictly_fastest_or_undecided():
    assert _winner({"lantern": (0.2, 0.2), "cycles": (38.0, 38.0)}) == "lantern"
    assert _winner({"lantern": (0.2, 0.2), "cycles": (0.1, 0.1)}) == "cycles"
    # Cycles does not reach Lantern's error by 256 spp (12 s), Lantern took 20 s:
    # Cycles needs more than 12 s, which may be more or less than 20 s.
    assert _winner({"lantern": (20.0, 20.0), "cycles": (12.0, math.inf)}) == "undecided"
    assert _winner({"lantern": (0.2, 0.2), "cycles": (12.0, math.inf)}) == "lantern"


def test_already_below_at_one_sample_is_an_exact_time():
    one = time_to_reach(power_law_curve(), 0.5)
    assert _bounds(one) == (pytest.approx(0.01), pytest.approx(0.01))
    four = time_to_reach(power_law_curve(samples=(4, 16)), 0.5)
    assert four.status == "already_below" and _bounds(four) == (0.0, pytest.approx(0.04))
    assert _winner({"lantern": (0.5, 0.5), "cycles": _bounds(one)}) == "cycles"
    assert _winner({"lantern": (0.02, 0.02), "cycles": _bounds(four)}) == "undecided"


def _render(renderer, seconds, flip, **extra):
    return {"renderer": renderer, "seconds": seconds,
            "metrics": {"direct": {"all": {"hdr_flip": flip}}}, **extra}


def _renders(lantern_flip):
    renders = [_render("lantern", 0.21, lantern_flip, preset="high", cold_seconds=1.9,
                       mode="direct")]
    renders += [_render("cycles", seconds, flip, samples=s, mode="direct")
                for s, seconds, flip in power_law_curve(per_sample=0.15)]
    renders += [_render("eevee", 2.1, 0.094, samples=1), _render("eevee", 4.0, 0.05, samples=4)]
    return renders


@pytest.mark.parametrize("flip, expected", [
    (0.071, r"^Lantern high: 0\.21 s warm \(1\.9 s cold\), FLIP 0\.071; Cycles needs [\d.]+ s "
            r"for that FLIP \([\d.]+x\); EEVEE 1 spp 2\.1 s, FLIP 0\.094$"),
    (0.5, r"Cycles is already below it at 1 spp \(0\.15 s, 0\.714x\)"),
    (0.001, r"Cycles does not reach it by 256 spp \(> 38\.4 s, > 183x\)"),
])
def test_the_summary_line_says_each_case(flip, expected):
    renders = _renders(flip)
    rows = _equal_error(renders, ("direct",), ("high",))
    assert len(rows) == 1
    assert rows[0]["winner_warm"] == ("cycles" if flip == 0.5 else "lantern")
    import re
    assert re.search(expected, _summary(rows, renders, ("direct",))), _summary(rows, renders, ("direct",))


def test_equal_error_uses_each_renderers_own_curve():
    rows = _equal_error(_renders(0.071), ("direct",), ("high",))
    cycles, eevee = rows[0]["cycles"], rows[0]["eevee"]
    # Cycles: 0.2·s^-0.5 = 0.071 at s = 7.93, 0.15 s per sample.
    assert cycles["status"] == "reached"
    assert cycles["samples"] == pytest.approx((0.2 / 0.071) ** 2, rel=1e-9)
    assert cycles["seconds"] == pytest.approx(0.15 * (0.2 / 0.071) ** 2, rel=1e-9)
    assert cycles["ratio_warm"] == pytest.approx(cycles["seconds"] / 0.21)
    assert eevee["status"] == "reached" and 2.1 < eevee["seconds"] < 4.0
    assert rows[0]["cycles_denoised"] is None


def test_a_faster_lantern_at_a_worse_error_is_said_so():
    """Cycles at 1 spp (0.5 s) is already below Lantern's FLIP but slower than Lantern
    (0.21 s): Lantern is fastest at its own error, and the row says Cycles' cheapest
    image is better."""
    renders = [_render("lantern", 0.21, 0.5, preset="high", cold_seconds=1.9, mode="direct")]
    renders += [_render("cycles", seconds, flip, samples=s, mode="direct")
                for s, seconds, flip in power_law_curve(per_sample=0.5)]
    row = _equal_error(renders, ("direct",), ("high",))[0]
    assert row["winner_warm"] == "lantern" and row["better_at_cheapest"] == ["cycles"]
    assert row["winner_cold"] == "cycles"          # 0.5 s < 1.9 s cold
    assert _equal_error(_renders(0.071), ("direct",), ("high",))[0]["better_at_cheapest"] == []


def test_each_mode_is_read_off_its_own_lantern_image():
    """Lantern renders each mode lit as its reference is: a mode's row takes that mode's
    image, and the summary names the best image of each mode."""
    renders = []
    for mode, lantern_flip, per_sample in (("direct", 0.071, 0.15), ("full", 0.5, 0.05)):
        renders.append({"renderer": "lantern", "seconds": 0.21, "preset": "high",
                        "cold_seconds": 1.9, "mode": mode,
                        "metrics": {mode: {"all": {"hdr_flip": lantern_flip}}}})
        renders += [{"renderer": "cycles", "seconds": seconds, "samples": s, "mode": mode,
                     "metrics": {mode: {"all": {"hdr_flip": flip}}}}
                    for s, seconds, flip in power_law_curve(per_sample=per_sample)]
    rows = _equal_error(renders, ("direct", "full"), ("high",))
    assert [(r["mode"], r["flip"], r["winner_warm"]) for r in rows] == [
        ("direct", 0.071, "lantern"), ("full", 0.5, "cycles")]
    line = _summary(rows, renders, ("direct", "full"))
    assert line.startswith("direct: Lantern high: 0.21 s warm (1.9 s cold), FLIP 0.071; ")
    assert " | full: Lantern high: 0.21 s warm (1.9 s cold), FLIP 0.5; Cycles is already " \
           "below it at 1 spp (0.05 s, 0.238x)" in line


# --- metrics ----------------------------------------------------------------------

def _image(seed=0, shape=(36, 64)):
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.uniform(0.0, 2.0, shape + (3,)), np.ones(shape + (1,))],
                          axis=-1).astype(np.float32)


def test_an_image_against_itself_has_no_error():
    image = _image()
    scored = metrics.score(image, image)
    assert scored["all"]["hdr_flip"] == 0.0 and scored["all"]["ldr_flip"] == 0.0
    assert scored["all"]["psnr"] is None          # infinite
    assert scored["all"]["ssim"] == pytest.approx(1.0)
    assert scored["all"]["rel_mse"] == 0.0


def test_psnr_and_relative_mse_follow_their_formulas():
    reference = np.full((36, 64, 4), 0.5, np.float32)
    test = reference.copy()
    test[..., :3] += 0.1
    scored = metrics.score(test, reference)["all"]
    assert scored["psnr"] == pytest.approx(20.0, abs=1e-4)          # mse 0.01
    assert scored["rel_mse"] == pytest.approx(0.01 / (0.25 + 0.01), rel=1e-5)


def test_the_foreground_sees_only_the_mask():
    reference = _image(1)
    test = reference.copy()
    test[:, 32:, :3] *= 1.5                       # error on the right half only
    mask = np.zeros(reference.shape[:2], bool)
    mask[:, :20] = True                           # the left: no error there
    scored = metrics.score(test, reference, mask)
    assert scored["all"]["hdr_flip"] > 0.01
    assert scored["foreground"]["hdr_flip"] == 0.0 and scored["foreground"]["rel_mse"] == 0.0
    mask[:] = False
    mask[:, 40:] = True
    assert metrics.score(test, reference, mask)["foreground"]["hdr_flip"] > scored["all"]["hdr_flip"]


def test_non_finite_pixels_are_counted_and_not_scored():
    reference = _image(2)
    test = reference.copy()
    test[3, 4, 0] = np.nan
    test[5, 6, 1] = np.inf
    test[7, 8, 2] = -0.5
    scored = metrics.score(test, reference)
    assert scored["problems"] == {"nonfinite_pixels": 2, "negative_pixels": 1}
    assert scored["all"] is None


def test_images_of_different_sizes_are_refused():
    with pytest.raises(ValueError, match="64x36"):
        metrics.score(_image(shape=(36, 64)), _image(shape=(18, 32)))
