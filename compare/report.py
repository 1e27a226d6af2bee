"""The report a person reads: DIR/index.html with its images and plots, and
DIR/results.json (validated against results.schema.json before it is written).

Images are shown tone-mapped through one function, `display_png`; FLIP heat maps use
FLIP's own colour map (magma, error 0 to 1). Every file is written atomically."""
from __future__ import annotations

import html
import json
import math
import os

from .curves import describe as describe_equal_error
from .curves import hdr_flip, sweep_points
from .files import atomic_write, write_json, write_text
from .lantern_timing import point_sampled

SCHEMA_PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results.schema.json")
LABELS = {"cycles": "Cycles", "cycles_denoised": "Cycles + denoiser", "eevee": "EEVEE",
          "lantern": "Lantern", "undecided": "undecided"}


# --- images -------------------------------------------------------------------------

def display_png(path: str, rgba, view: dict) -> str:
    """Scene-linear RGBA to the 8-bit PNG shown in the report, through the scene's own
    colour management (view = {"transform", "look", "exposure"}, as Blender's Color
    Management panel sets them): the one place the report's images are tone-mapped.
    Returns `path`."""
    from ..engine.image_io import write_image
    os.makedirs(os.path.dirname(path), exist_ok=True)
    write_image(path, rgba, view=view["transform"], look=view["look"],
                exposure=view["exposure"])
    return path


def png_path(out: str, image_path: str) -> str:
    stem = os.path.splitext(os.path.basename(image_path))[0]
    return os.path.join(out, "png", stem + ".png")


def heatmap_path(out: str, image_path: str, mode: str) -> str:
    stem = os.path.splitext(os.path.basename(image_path))[0]
    return os.path.join(out, "png", f"flip_{stem}_vs_{mode}.png")


def heatmap_png(path: str, error_map) -> str:
    import matplotlib.image
    import numpy as np
    from matplotlib import colormaps
    colours = colormaps["magma"](np.clip(error_map, 0.0, 1.0), bytes=True)
    atomic_write(path, lambda tmp: matplotlib.image.imsave(tmp, colours, format="png"), ".png")
    return path


# --- the plot -------------------------------------------------------------------------

def _curve(renders, renderer, mode):
    """The points a log-log plot can show (positive time and error)."""
    return [p for p in sweep_points(renders, renderer, mode) if p[1] > 0 and p[2] > 0]


def plot(out: str, results: dict, mode: str) -> str | None:
    """Error against time, log-log, every renderer of one mode; None if nothing to plot."""
    from matplotlib.figure import Figure
    renders = results["renders"]
    figure = Figure(figsize=(7.5, 4.8), dpi=100)
    axes = figure.add_subplot()
    drawn = 0
    styles = {"cycles": ("o-", "tab:blue"), "cycles_denoised": ("o--", "tab:cyan"),
              "eevee": ("s-", "tab:green")}
    for renderer, (style, colour) in styles.items():
        points = _curve(renders, renderer, mode)
        if not points:
            continue
        axes.plot([p[1] for p in points], [p[2] for p in points], style, color=colour,
                  label=LABELS[renderer])
        for samples, seconds, flip in points:
            axes.annotate(f"{samples}", (seconds, flip), textcoords="offset points",
                          xytext=(4, 4), fontsize=7, color=colour)
        drawn += len(points)
    labelled = set()

    def once(label):
        if label in labelled:
            return None
        labelled.add(label)
        return label

    for render in renders:
        flip = hdr_flip(render, mode)
        if render["renderer"] != "lantern" or not flip:
            continue
        warm, cold = render["seconds"], render["cold_seconds"]
        axes.plot([warm, cold], [flip, flip], ":", color="tab:red", linewidth=0.8)
        axes.plot([warm], [flip], "*", color="tab:red", markersize=11, label=once("Lantern warm"))
        axes.plot([cold], [flip], "o", mfc="none", color="tab:red", label=once("Lantern cold"))
        axes.annotate(render["preset"], (warm, flip), textcoords="offset points",
                      xytext=(5, -10), fontsize=8, color="tab:red")
        drawn += 1
    for row in results["equal_error"]:
        if row["mode"] == mode and row["cycles"] and row["cycles"]["status"] == "reached":
            axes.plot([row["cycles"]["seconds"]], [row["flip"]], "x", color="black")
    if not drawn:
        return None
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("seconds per image (log)")
    axes.set_ylabel(f"mean HDR-FLIP against the {mode} reference (log)")
    axes.set_title(f"{results['scene']['name']}: error against time ({mode}); "
                   "x: Cycles at Lantern's FLIP", fontsize=9)
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    path = os.path.join(out, f"plot_{mode}.png")
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png"), ".png")
    return path


# --- results.json ---------------------------------------------------------------------

def validate(results: dict) -> None:
    """Raises jsonschema.ValidationError when `results` breaks the schema."""
    import jsonschema
    with open(SCHEMA_PATH, encoding="utf-8") as f:
        schema = json.load(f)
    jsonschema.validate(results, schema, cls=jsonschema.Draft202012Validator)


# --- index.html -----------------------------------------------------------------------

def _html(value):
    """Any value as text safe inside HTML."""
    return html.escape(str(value))


def _secs(seconds):
    """A time for the page: three significant digits, or a dash when not measured."""
    return "–" if seconds is None else f"{seconds:.3g} s"


def _num(value, digits=4):
    """A score for the page: `digits` significant digits, a dash when missing, inf and
    nan as themselves."""
    if value is None:
        return "–"
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return f"{value:.{digits}g}"


def _equal_cell(entry, name):
    if entry is None:
        return "–"
    text = describe_equal_error(_entry_result(entry), LABELS[name])
    ratio = entry.get("ratio_warm")
    if ratio is not None:
        prefix = {"reached": "", "already_below": "≤ ", "not_reached": "> "}[entry["status"]]
        text += f"; {prefix}{ratio:.0f}× Lantern warm" if ratio >= 100 else \
            f"; {prefix}{ratio:.3g}× Lantern warm"
    return _html(text)


def _entry_result(entry):
    from .curves import EqualError
    return EqualError(**{k: entry[k] for k in ("status", "seconds", "samples",
                                                "bound_seconds", "bound_samples")})


def _table(header, rows):
    head = "".join(f"<th>{_html(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _figure(src, caption, heatmap=None):
    parts = [f'<img src="{_html(src)}" alt="{_html(caption)}">']
    if heatmap:
        parts.append(f'<img src="{_html(heatmap)}" alt="FLIP heat map: {_html(caption)}">')
    return f"<figure>{''.join(parts)}<figcaption>{_html(caption)}</figcaption></figure>"


def _render_label(render):
    if render["renderer"] == "lantern":
        return f"Lantern {render['preset']}"
    return f"{LABELS[render['renderer']]} {render['samples']} spp"


def _winner_text(row, clock):
    text = LABELS[row[f"winner_{clock}"]]
    if row[f"winner_{clock}"] == "lantern" and row["better_at_cheapest"]:
        text += (" (but " + " and ".join(LABELS[n] for n in row["better_at_cheapest"]) +
                 " at its fewest samples is already more accurate)")
    return text


def _scored(render, mode):
    return hdr_flip(render, mode) is not None


def _equal_time_pairs(renders, mode):
    """(Lantern preset, the Cycles sweep image nearest to its warm time in log time)."""
    sweep = [r for r in renders if r["renderer"] == "cycles" and r.get("mode") == mode
             and _scored(r, mode) and r["seconds"] > 0]
    pairs = []
    for lantern in (r for r in renders if r["renderer"] == "lantern" and _scored(r, mode)):
        if sweep and lantern["seconds"] > 0:
            nearest = min(sweep, key=lambda r: abs(math.log(r["seconds"] / lantern["seconds"])))
            pairs.append((lantern, nearest))
    return pairs


def _mode_section(results, mode, plot_file):
    renders = results["renders"]
    rows = []
    for row in (r for r in results["equal_error"] if r["mode"] == mode):
        lantern = next(r for r in renders if r["renderer"] == "lantern"
                       and r["preset"] == row["preset"] and r["mode"] == mode)
        fg = (lantern["metrics"][mode].get("foreground") or {}).get("hdr_flip")
        rows.append([_html(row["preset"]), _secs(row["lantern_warm_seconds"]),
                     _secs(row["lantern_cold_seconds"]), _num(row["flip"]), _num(fg),
                     _equal_cell(row["cycles"], "cycles"),
                     _equal_cell(row["cycles_denoised"], "cycles_denoised"),
                     _equal_cell(row["eevee"], "eevee"),
                     _html(_winner_text(row, "warm")), _html(_winner_text(row, "cold"))])
    parts = [f"<h2>Against the {mode} reference</h2>"]
    reference = results["references"][mode]
    parts.append(f"<p>Reference: Cycles {reference['samples']} spp, seed {reference['seed']}"
                 f"{' (from the cache)' if reference['cached'] else ''}, "
                 f"{_secs(reference['seconds'])}.</p>")
    if rows:
        parts.append("<h3>Equal error: the time each renderer needs for Lantern's FLIP</h3>")
        parts.append(_table(["preset", "Lantern warm", "Lantern cold", "HDR-FLIP",
                             "foreground HDR-FLIP", "Cycles", "Cycles + denoiser", "EEVEE",
                             "fastest at equal error (warm)", "(cold)"], rows))
    else:
        parts.append("<p class=bad>No Lantern image could be scored against this reference.</p>")
    if plot_file:
        parts.append(f'<p><img class=plot src="{_html(plot_file)}" alt="error against time, {mode}"></p>')
    pairs = _equal_time_pairs(renders, mode)
    if pairs:
        parts.append("<h3>Equal time: each Lantern preset beside the Cycles image closest "
                     "to it in time</h3>")
        parts.append("<div class=grid>" + "".join(
            _figure(r["png"], f"{_render_label(r)}: {_secs(r['seconds'])}, FLIP "
                              f"{_num(r['metrics'][mode]['all']['hdr_flip'], 3)}")
            for pair in pairs for r in pair) + "</div>")
    figures = []
    if reference.get("png"):
        figures.append(_figure(reference["png"], f"reference, Cycles {reference['samples']} spp"))
    for render in renders:
        metric = render["metrics"].get(mode)
        if metric is None:
            continue
        flip = (metric.get("all") or {}).get("hdr_flip")
        figures.append(_figure(render["png"], f"{_render_label(render)}: "
                               f"{_secs(render['seconds'])}, FLIP {_num(flip, 3)}", metric["heatmap"]))
    parts.append("<h3>Images (tone-mapped) and FLIP heat maps (black 0, yellow 1)</h3>")
    parts.append(f"<div class=grid>{''.join(figures)}</div>")
    metric_rows = []
    for render in renders:
        metric = render["metrics"].get(mode)
        if metric is None:
            continue
        every, fg = metric.get("all") or {}, metric.get("foreground") or {}
        metric_rows.append([_html(_render_label(render)), _secs(render["seconds"])] +
                           [_num(every.get(k)) for k in ("hdr_flip", "ldr_flip", "psnr", "ssim", "rel_mse")] +
                           [_num(fg.get(k)) for k in ("hdr_flip", "ldr_flip", "psnr", "ssim", "rel_mse")] +
                           [_html(render["problems"]["nonfinite_pixels"] or "")])
    parts.append("<h3>Every metric (all pixels | foreground)</h3>")
    parts.append(_table(["render", "time", "HDR-FLIP", "LDR-FLIP", "PSNR dB", "SSIM", "rel. MSE",
                         "fg HDR-FLIP", "fg LDR-FLIP", "fg PSNR", "fg SSIM", "fg rel. MSE",
                         "non-finite px"], metric_rows))
    return "\n".join(parts)


STYLE = """
body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;color:#222;max-width:1400px}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:2px 6px;
text-align:right}th{background:#f3f3f3}td:first-child{text-align:left}
.grid{display:flex;flex-wrap:wrap;gap:10px}figure{margin:0;width:min(330px,100%)}
figure img{width:100%;image-rendering:pixelated;display:block;margin-bottom:2px}
figcaption{font-size:12px}.plot{max-width:760px;width:100%}.bad{color:#b00}
code{background:#f3f3f3;padding:0 3px}
"""


def html_page(results: dict, plots: dict) -> str:
    scene, settings = results["scene"], results["settings"]
    head = (f"<!doctype html><html lang=en><head><meta charset=utf-8>"
            f"<link rel=icon href=\"data:,\"><title>lantern compare: {_html(scene['name'])}</title>"
            f"<style>{STYLE}</style></head><body>")
    parts = [head, f"<h1>lantern compare: {_html(os.path.basename(scene['path']))}</h1>",
             f"<p><b>{_html(results['summary'])}</b></p>"]
    facts = [["scene", _html(scene["path"])], ["frame, size", _html(f"{scene['frame']:g}, "
                                                          f"{scene['size'][0]}×{scene['size'][1]}")],
             ["modes", _html(", ".join(settings["modes"]))],
             ["Cycles sweep", _html(", ".join(map(str, settings["cycles_samples"])) + " spp")],
             ["pixel filter", _html(f"Blackman-Harris, {settings['pixel_filter']['width']} px" + (
                 "; point-sampled, so Lantern renders without anti-aliasing"
                 if point_sampled(settings["pixel_filter"]["width"]) else ""))],
             ["seeds", _html(f"reference {settings['seeds']['reference']}, "
                          f"sweep {settings['seeds']['sweep']}")],
             ["foreground mask", _html(results["mask"]["source"])],
             ["images shown through", _html(f"view {scene['view']['transform']}, look "
                                         f"{scene['view']['look'] or 'none'}, exposure "
                                         f"{scene['view']['exposure']:g}")],
             ["machine", _html(f"{results['machine']['cpus']} CPUs, {results['machine']['platform']}, "
                            f"Blender {results['machine']['blender']}, "
                            f"Lantern {results['machine']['lantern']}")],
             ["created", _html(results["created"])]]
    parts.append(_table(["", ""], facts))
    parts.append("<h2>What the times include</h2><ul>" + "".join(
        f"<li><b>{_html(k)}</b>: {_html(v)}</li>" for k, v in results["timing"].items()) + "</ul>")
    if results["broken_links"]:
        parts.append("<h2 class=bad>Broken links (the renders went on without them)</h2><ul>" +
                     "".join(f"<li>{_html(l['kind'])} <code>{_html(l['name'])}</code>: "
                             f"<code>{_html(l['path'])}</code> ({_html(l['resolved'])}) is missing</li>"
                             for l in results["broken_links"]) + "</ul>")
    if results["failures"]:
        parts.append("<h2 class=bad>Failed renders</h2><ul>" + "".join(
            f"<li>{_html(f['job'])}: {_html(f['error'])} (<a href=\"{_html(f['log'])}\">log</a>)</li>"
            for f in results["failures"]) + "</ul>")
    if results["warnings"]:
        parts.append("<h2>Warnings</h2><ul>" + "".join(
            f"<li>{_html(w)}</li>" for w in results["warnings"]) + "</ul>")
    for mode in settings["modes"]:
        parts.append(_mode_section(results, mode, plots.get(mode)))
    parts.append("<p>Every number above is in <a href=\"results.json\">results.json</a> "
                 "(schema: <code>compare/results.schema.json</code>), with the path of "
                 "every image it scores, so anyone can recompute the metrics.</p>")
    parts.append("</body></html>\n")
    return "\n".join(parts)


def write(out: str, results: dict) -> None:
    """Draws the plots, validates results (with the plots' paths), then writes
    results.json and index.html."""
    results["plots"] = {}
    for mode in results["settings"]["modes"]:
        path = plot(out, results, mode)
        results["plots"][mode] = os.path.relpath(path, out) if path else None
    validate(results)
    write_json(os.path.join(out, "results.json"), results)
    write_text(os.path.join(out, "index.html"), html_page(results, results["plots"]))
