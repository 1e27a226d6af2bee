// Polygonal lights by linearly transformed cosines (Heitz, Dupuy, Hill and Neubelt 2016):
// a lobe's share of what a polygon sends is the clamped cosine's over the polygon taken
// through the lobe's M^-1 (engine/ltc.py fits it for lib.glsl's GGX lobe), in closed
// form: Lambert's edge integral once the polygon is clipped to the horizon. The
// identity is Lambert's own lobe (the exact form factor), so diffuse and glossy light
// of an area light come from one integral (lights.glsl area_light). Include after
// lib.glsl.

#define MAX_VERTS 32                 // engine/gpu/lights.py MAX_POLY
#define MAX_CLIP (MAX_VERTS + 2)     // one clip to the surface's horizon, one to the lobe's

// M^-1 by n.v (s) and perceptual roughness (t), in the frame (t, b, n) of lib.glsl's
// Lobe: channels (m00, m02, m20, m22), its middle entry 1 (engine/ltc.py). It shares
// the unit of post-processing's source, which no shading program reads.
uniform sampler2D ltc_lut;

mat3 ltc_inverse(float NoV, float roughness) {
    vec4 m = texture(ltc_lut, table_uv(textureSize(ltc_lut, 0), NoV, roughness));
    return mat3(vec3(m.x, 0.0, m.z), vec3(0.0, 1.0, 0.0), vec3(m.y, 0.0, m.w));
}

// A polygon about the shaded point, in its lobe's frame (z the normal).
struct Polygon {
    vec3 v[MAX_CLIP];
    int n;
};

// The polygon's part above the plane z = 0 (Sutherland-Hodgman).
Polygon clip_to_horizon(Polygon p) {
    Polygon q;
    q.n = 0;
    if (p.n == 0) return q;
    vec3 prev = p.v[p.n - 1];
    for (int i = 0; i < p.n; ++i) {
        vec3 cur = p.v[i];
        if ((prev.z >= 0.0) != (cur.z >= 0.0))
            q.v[q.n++] = mix(prev, cur, prev.z / (prev.z - cur.z));
        if (cur.z >= 0.0) q.v[q.n++] = cur;
        prev = cur;
    }
    return q;
}

// The form factor of a polygon above the horizon: the clamped cosine's share of it,
// (1 / 2 pi) sum over edges of the angle they span times their plane's normal's z.
// atan(|a x b|, a.b) keeps small angles exact, as acos does not.
float form_factor(Polygon p) {
    if (p.n < 3) return 0.0;
    float sum = 0.0;
    vec3 a = normalize(p.v[p.n - 1]);
    for (int i = 0; i < p.n; ++i) {
        vec3 b = normalize(p.v[i]);
        vec3 c = cross(a, b);
        float s = length(c);
        if (s > 1e-12) sum += c.z * (atan(s, dot(a, b)) / s);
        a = b;
    }
    return abs(sum) / (2.0 * PI);
}

// The share of a lobe of inverse transform minv that the polygon (clipped to the
// surface's horizon) covers: its form factor once taken through minv and clipped to
// the cosine's horizon.
float ltc_share(Polygon p, mat3 minv) {
    for (int i = 0; i < p.n; ++i) p.v[i] = minv * p.v[i];
    return form_factor(clip_to_horizon(p));
}
