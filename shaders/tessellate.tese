#version 410 core
// A point of a bicubic Bezier patch, its normal from the two partial derivatives, and
// its UV from the UVs' own patch (smoothed by the mesh's faceVaryingLinearInterpolation,
// or bilinear per face for `all`).
// Written by transform feedback in the vertex layout every mesh uses
// (engine/gpu/stores.py), so every pass draws the result as plain triangles.
layout(quads, equal_spacing, ccw) in;
in vec3 e_pos[];
in vec2 e_uv[];
out vec3 out_pos;
out vec3 out_normal;
out vec2 out_uv;
out vec4 out_tangent;

void bernstein(float t, out vec4 b, out vec4 d) {
    float s = 1.0 - t;
    b = vec4(s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t);
    d = 3.0 * vec4(-s * s, s * s - 2.0 * s * t, 2.0 * s * t - t * t, t * t);
}

void patch_point(vec2 t, out vec3 p, out vec3 pu, out vec3 pv) {
    vec4 bu, du, bv, dv;
    bernstein(t.x, bu, du);
    bernstein(t.y, bv, dv);
    p = vec3(0.0);
    pu = vec3(0.0);
    pv = vec3(0.0);
    for (int j = 0; j < 4; ++j) {
        vec3 row = vec3(0.0), row_du = vec3(0.0);
        for (int i = 0; i < 4; ++i) {
            row += bu[i] * e_pos[4 * j + i];
            row_du += du[i] * e_pos[4 * j + i];
        }
        p += bv[j] * row;
        pu += bv[j] * row_du;
        pv += dv[j] * row;
    }
}

vec2 patch_uv(vec2 t) {
    vec4 bu, du, bv, dv;
    bernstein(t.x, bu, du);
    bernstein(t.y, bv, dv);
    vec2 uv = vec2(0.0);
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i)
            uv += bv[j] * bu[i] * e_uv[4 * j + i];
    return uv;
}

void main() {
    vec2 t = gl_TessCoord.xy;
    vec3 p, pu, pv;
    patch_point(t, p, pu, pv);
    vec3 n = cross(pu, pv);
    if (dot(n, n) == 0.0) {
        // A corner where the patch pinches (a cage with coincident points): the
        // normal of the surface just inside the patch.
        vec3 q;
        patch_point(mix(t, vec2(0.5), 1e-3), q, pu, pv);
        n = cross(pu, pv);
    }
    out_pos = p;
    out_normal = normalize(n);
    out_uv = patch_uv(t);
    out_tangent = vec4(0.0);
}
