"""Area lights by linearly transformed cosines (shaders/ltc.glsl, engine/ltc.py): the
shaders' share of the GGX lobe that a polygon covers, evaluated in GLSL by a compute
harness, against the lobe integrated over the polygon by sampling (numpy, 2^20
directions), at roughness 0.05, 0.15, 0.4 and 1, for several views and placements;
the diffuse form factor against its closed form; the stored table against the fit."""
import math

import numpy as np
import pytest

from lantern.engine import ltc
from lantern.engine.gpu.context import run_gl
from lantern.engine.lighting import ggx_alpha

HARNESS = """#version 430 core
#include "lib.glsl"
#include "ltc.glsl"
layout(local_size_x = 1) in;
// Per case: (n.v, roughness, lobe: 0 Lambert, 1 GGX; unused), then 4 vertices about the
// shaded point in the lobe's frame.
layout(std430, binding = 0) readonly buffer Cases { vec4 cases[]; };
layout(std430, binding = 1) writeonly buffer Shares { float shares[]; };
void main() {
    int k = int(gl_GlobalInvocationID.x);
    vec4 head = cases[k * 5];
    ltc_in_n = 4;
    for (int i = 0; i < 4; ++i) ltc_in[i] = cases[k * 5 + 1 + i].xyz;
    set_polygon();
    shares[k] = ltc_share(head.z > 0.5 ? ltc_inverse(head.x, head.y) : mat3(1.0));
}
"""


def glsl_shares(cases):
    """ltc.glsl's share for each (n.v, roughness, ggx, polygon (4, 3))."""
    rows = []
    for nov, roughness, ggx, poly in cases:
        rows.append([nov, roughness, 1.0 if ggx else 0.0, 0.0])
        rows.extend([*vertex, 0.0] for vertex in poly)
    data = np.asarray(rows, np.float32)

    def job(gl):
        from lantern.engine.gpu.environment import Environment   # noqa: F401  (units)
        from lantern.engine.gpu.programs import UNITS
        ctx = gl.ctx
        prog = gl.programs.get("ltc_harness.comp", compute=True,
                               generated=(("ltc_harness.comp", HARNESS),))
        table = ltc.ltc_lut()
        tex = ctx.texture(table.shape[1::-1], 4, np.ascontiguousarray(table), dtype="f4")
        tex.filter = (ctx.LINEAR, ctx.LINEAR)
        tex.repeat_x = tex.repeat_y = False
        src = ctx.buffer(data.tobytes())
        dst = ctx.buffer(reserve=4 * len(cases))
        try:
            tex.use(UNITS["ltc_lut"])
            src.bind_to_storage_buffer(0)
            dst.bind_to_storage_buffer(1)
            prog.run(len(cases))
            ctx.finish()
            return np.frombuffer(dst.read(), np.float32).copy()
        finally:
            for obj in (tex, src, dst):
                obj.release()
    return run_gl(job)


def rect(centre, u, w, half_u, half_w):
    """A rectangle's 4 corners, counter-clockwise seen along -(u x w)."""
    centre, u, w = (np.asarray(x, float) for x in (centre, u, w))
    return np.array([centre - half_u * u - half_w * w, centre + half_u * u - half_w * w,
                     centre + half_u * u + half_w * w, centre - half_u * u + half_w * w])


def mirror(nov):
    """The mirror direction of the view of n.v in the lobe's frame."""
    v = ltc.view_direction(nov)
    return np.array([-v[0], 0.0, v[2]])


def placements(nov):
    """Rectangles facing the shaded point: on the mirror direction (the highlight inside),
    with an edge through it, off to the side (the lobe's tail), a long thin light beside
    the mirror direction as a floor reflects it, and one straddling the horizon."""
    r = mirror(nov)
    side = np.array([0.0, 1.0, 0.0])
    up = np.cross(r, side)
    up /= np.linalg.norm(up)
    return {
        "centred": rect(2.0 * r, side, up, 0.3, 0.2),
        "edge through": rect(2.0 * r + 0.3 * side, side, up, 0.3, 0.2),
        "beside": rect(2.0 * r + 0.9 * side + 0.3 * up, side, up, 0.4, 0.3),
        "long, offset": rect(3.0 * r + 0.25 * up, side, up, 1.0, 0.2),
        "horizon": rect(np.array([0.0, 1.5, 0.1]), np.array([1.0, 0.0, 0.0]),
                        np.array([0.0, 0.0, 1.0]), 0.8, 0.5),
    }


ROUGHNESS = (0.05, 0.15, 0.4, 1.0)
VIEWS = (0.95, 0.7, 0.4, 0.15)


def reference_share(nov, roughness, poly):
    v = ltc.view_direction(nov)
    albedo = ltc.ggx_samples(v, float(ggx_alpha(roughness)), 1 << 20)[2].mean()
    return ltc.lobe_over_polygon(v, roughness, poly) / albedo


@pytest.fixture(scope="module")
def ggx_cases():
    cases = [(nov, r, True, poly) for r in ROUGHNESS for nov in VIEWS
             for poly in placements(nov).values()]
    names = [(nov, r, name) for r in ROUGHNESS for nov in VIEWS for name in placements(nov)]
    got = glsl_shares(cases)
    want = np.array([reference_share(nov, r, poly) for nov, r, _, poly in cases])
    return names, got, want


# The largest error allowed in the share of the lobe (1: all it reflects), by
# roughness, and relative to the share where it is over 5% and the view is not grazing
# (n.v >= 0.4). Measured 2026-11-28: 0.0012, 0.036, 0.055 and 0.0058 (all at n.v 0.15,
# where the lobe leans so far over the horizon that no LTC follows it closely: 21% of
# a share of 0.23 too much at roughness 0.4), and 5.6% relative at n.v >= 0.4.
BOUND = {0.05: 0.004, 0.15: 0.05, 0.4: 0.07, 1.0: 0.01}
REL_BOUND = 0.08


@pytest.mark.parametrize("roughness", ROUGHNESS)
def test_ltc_share_matches_the_lobe_integrated_over_the_polygon(ggx_cases, roughness):
    names, got, want = ggx_cases
    pick = [k for k, name in enumerate(names) if name[1] == roughness]
    report = "\n".join(f"{names[k]}: {got[k]:.4f} vs {want[k]:.4f}" for k in pick)
    assert np.abs(got[pick] - want[pick]).max() <= BOUND[roughness], report
    large = [k for k in pick if want[k] > 0.05 and names[k][0] >= 0.4]
    rel = np.abs(got[large] - want[large]) / want[large]
    assert (rel <= REL_BOUND).all(), report


def test_form_factor_is_lamberts():
    """The identity lobe is Lambert's: a square straight above the normal, and one
    straddling the horizon, against their closed-form form factors."""
    h = 1.0
    square = rect([0.0, 0.0, h], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 0.5, 0.5)
    # A unit square centred above the point at height h (Hottel's crossed strings):
    # F = (2 / pi) (a / sqrt(1 + a^2) atan(b / sqrt(1 + a^2)) + (b <-> a)), a = b = 1/(2h).
    a = b = 0.5 / h
    ff = 2.0 / math.pi * (a / math.sqrt(1 + a * a) * math.atan(b / math.sqrt(1 + a * a))
                          + b / math.sqrt(1 + b * b) * math.atan(a / math.sqrt(1 + b * b)))
    # Half of a square standing across the horizon is clipped away: the rest is the
    # same as the upper half alone (4 corners of it).
    upper = rect([0.0, 1.0, 0.25], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.5, 0.25)
    across = rect([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.5, 0.5)
    got = glsl_shares([(1.0, 1.0, False, square), (1.0, 1.0, False, across),
                       (1.0, 1.0, False, upper)])
    assert abs(got[0] - ff) <= 1e-5, (got[0], ff)
    assert abs(got[1] - got[2]) <= 1e-6 and got[1] > 0.01, got


def test_stored_table_is_the_fit():
    """shaders/tables/ltc_ggx.npy is what shaders/tables/fit_ltc.py fits for the lobe as
    engine/ltc.py evaluates it now (one row, roughness 0.4: the fit is deterministic)."""
    j = round(0.4 * (ltc.LTC_SIZE - 1))
    np.testing.assert_allclose(ltc.fit_row(j), ltc.ltc_lut()[j], rtol=1e-4, atol=1e-5)
