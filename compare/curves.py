"""Equal error: the time a progressive renderer needs to reach a target error,
read off its error-against-time curve.

A sweep gives points (samples, seconds, error). Between two neighbouring points
error and time both follow power laws closely (Monte Carlo error falls as a power of
the sample count, and time grows linearly with it), so the curve is interpolated as a
straight line in log-log. The answer is honest about the ends of the sweep:
- "reached": the first segment that crosses the target gives the time (and the
  sample count, interpolated the same way);
- "already_below": the cheapest point is already at or below the target, so the
  equal-error time is at most that point's time (`bound_seconds`);
- "not_reached": no point gets there, so it is more than the last point's time;
- "no_curve": the sweep has no usable point (it failed or was not run)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

ERROR_FLOOR = 1e-12  # an error of exactly 0 still has a logarithm


@dataclass(frozen=True)
class EqualError:
    status: str                    # reached | already_below | not_reached | no_curve
    seconds: float | None = None   # interpolated time, when reached
    samples: float | None = None   # interpolated sample count, when reached
    bound_seconds: float | None = None  # at most (already_below) / more than (not_reached)
    bound_samples: int | None = None

    def as_dict(self):
        return asdict(self)


def hdr_flip(render: dict, mode: str):
    """A results.json render's mean HDR-FLIP against `mode`'s reference, or None when
    it was not scored (a failed render, non-finite pixels, another mode's sweep)."""
    return ((render["metrics"].get(mode) or {}).get("all") or {}).get("hdr_flip")


def sweep_points(renders, renderer: str, mode: str) -> list:
    """(samples, seconds, HDR-FLIP) of `renderer`'s scored renders against `mode`'s
    reference: its error-against-time curve. Cycles' sweeps belong to one mode each;
    EEVEE's images are scored against every mode's reference."""
    return sorted((r["samples"], r["seconds"], hdr_flip(r, mode)) for r in renders
                  if r["renderer"] == renderer and hdr_flip(r, mode) is not None
                  and (renderer == "eevee" or r.get("mode") == mode))


def _log(x):
    return math.log(max(float(x), ERROR_FLOOR))


def _usable(point):
    samples, seconds, error = point
    return (error is not None and seconds is not None and math.isfinite(error)
            and math.isfinite(seconds) and seconds > 0 and samples > 0)


def time_to_reach(points, target: float) -> EqualError:
    """points: iterable of (samples, seconds, error); target: the error to reach."""
    curve = sorted((p for p in points if _usable(p)), key=lambda p: p[0])
    if not curve or target is None or not math.isfinite(target):
        return EqualError("no_curve")
    first_samples, first_seconds, first_error = curve[0]
    if first_error <= target:
        return EqualError("already_below", bound_seconds=first_seconds,
                          bound_samples=int(first_samples))
    for (s0, t0, e0), (s1, t1, e1) in zip(curve, curve[1:]):
        if e1 > target:
            continue
        # e0 > target >= e1: u is where the straight log-log segment meets the target.
        u = (_log(target) - _log(e0)) / (_log(e1) - _log(e0))
        seconds = math.exp(_log(t0) + u * (_log(t1) - _log(t0)))
        samples = math.exp(_log(s0) + u * (_log(s1) - _log(s0)))
        return EqualError("reached", seconds=seconds, samples=samples)
    last_samples, last_seconds, _ = curve[-1]
    return EqualError("not_reached", bound_seconds=last_seconds, bound_samples=int(last_samples))


def describe(result: EqualError, renderer: str) -> str:
    """A few words for tables and the summary line."""
    if result.status == "reached":
        return f"{result.seconds:.3g} s ({result.samples:.3g} spp)"
    if result.status == "already_below":
        return f"already below at {result.bound_samples} spp (≤ {result.bound_seconds:.3g} s)"
    if result.status == "not_reached":
        return f"not reached by {result.bound_samples} spp (> {result.bound_seconds:.3g} s)"
    return f"no {renderer} curve"
