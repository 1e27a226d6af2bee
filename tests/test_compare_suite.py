"""The comparison suite (bench/compare_suite.py) in both modes: its summary names, per
mode, the scenes where Lantern is fastest at equal error. One tiny scene end to end
(64x36, Cycles at 1 and 4 samples against 16, Lantern low), and the summary's logic on
hand-made rows."""
import argparse
import json
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "bench"))
import compare_suite  # noqa: E402

from test_compare_report import build_scene  # noqa: E402


def _scene(name, winners, better_at_cheapest=()):
    """A suite entry whose equal-error rows have these warm winners: {mode: winner}."""
    rows = [{"mode": mode, "preset": "medium", "flip": 0.1, "lantern_warm_seconds": 0.05,
             "lantern_cold_seconds": 2.0, "cycles": None, "eevee": None,
             "winner_warm": winner, "better_at_cheapest": list(better_at_cheapest)}
            for mode, winner in winners.items()]
    return {"name": name, "equal_error": rows, "eevee": {}, "report": f"{name}/index.html"}


def test_the_summary_names_the_fastest_scenes_per_mode():
    scenes = [_scene("box", {"direct": "lantern", "full": "cycles"}),
              _scene("room", {"direct": "undecided", "full": "lantern"}),
              _scene("panel", {"direct": "lantern", "full": "lantern"}),
              # Fastest at its own error, but Cycles' 1 spp is already better: not named.
              _scene("plane", {"direct": "lantern", "full": "lantern"}, ["cycles"])]
    assert compare_suite.fastest(scenes, "direct") == {"box": ["medium"], "panel": ["medium"]}
    assert compare_suite.fastest(scenes, "full") == {"room": ["medium"], "panel": ["medium"]}
    text = compare_suite.markdown(scenes)
    direct, full = text.split("## full mode")
    assert direct.startswith("## direct mode")
    assert "in direct mode (warm): 2 of 4 scenes: box (medium), panel (medium)" in direct
    assert "in full mode (warm): 2 of 4 scenes: room (medium), panel (medium)" in full
    assert direct.count("| box | medium |") == full.count("| box | medium |") == 1


def test_one_tiny_scene_in_both_modes(tmp_path):
    scene = tmp_path / "scene.blend"
    build_scene(scene)
    args = argparse.Namespace(out=str(tmp_path / "out"), size=(64, 36), reference_samples=16,
                              no_eevee=True, jobs=1, cache=str(tmp_path / "cache"),
                              cycles_samples=(1, 4), presets=("low",), mode=("direct", "full"))
    entry = {"blend": str(scene), "group": "corpus", "repairs": []}
    measured = compare_suite.run_scene("tiny", entry, args)
    assert measured["failures"] == []
    assert sorted((r["mode"], r["preset"]) for r in measured["equal_error"]) == [
        ("direct", "low"), ("full", "low")]
    out = pathlib.Path(args.out)
    compare_suite.write_summary(out, [measured], args, 1.0)
    summary = json.loads((out / "summary.json").read_text())
    for mode in ("direct", "full"):
        row = next(r for r in measured["equal_error"] if r["mode"] == mode)
        won = row["winner_warm"] == "lantern" and not row["better_at_cheapest"]
        assert summary["lantern_fastest"][mode] == ({"tiny": ["low"]} if won else {})
    text = (out / "summary.md").read_text()
    assert "## direct mode" in text and "## full mode" in text
    assert text.count("| tiny | low |") == 2
    html = (out / "index.html").read_text()
    assert "direct mode</h2>" in html and "full mode</h2>" in html
