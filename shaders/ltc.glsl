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

// Polygons about the shaded point, in its lobes' frame (z the normal), as private
// globals worked on in place: llvmpipe copies an array passed or returned by value
// whole (all MAX_CLIP entries, each time), which cost more than the integrals.
vec3 ltc_in[MAX_CLIP];           // a polygon to clip
int ltc_in_n;
vec3 ltc_out[MAX_CLIP];          // clip_to_horizon's result
int ltc_out_n;
vec3 ltc_poly[MAX_CLIP];         // the light's polygon, clipped to the surface's horizon
int ltc_poly_n;

// ltc_in's part above the plane z = 0 into ltc_out (Sutherland-Hodgman).
void clip_to_horizon() {
    ltc_out_n = 0;
    if (ltc_in_n == 0) return;
    vec3 prev = ltc_in[ltc_in_n - 1];
    for (int i = 0; i < ltc_in_n; ++i) {
        vec3 cur = ltc_in[i];
        if ((prev.z >= 0.0) != (cur.z >= 0.0))
            ltc_out[ltc_out_n++] = mix(prev, cur, prev.z / (prev.z - cur.z));
        if (cur.z >= 0.0) ltc_out[ltc_out_n++] = cur;
        prev = cur;
    }
}

// ltc_in clipped to the surface's horizon, kept as ltc_poly for ltc_share.
void set_polygon() {
    clip_to_horizon();
    ltc_poly_n = ltc_out_n;
    for (int i = 0; i < ltc_out_n; ++i) ltc_poly[i] = ltc_out[i];
}

// A cone of directions about the shaded point as ltc_poly: the light of a sphere, or of
// a disk facing the point (lights.glsl sphere_light), is the light of the cone it fills,
// of axis c (unit, in the lobes' frame) and half-angle a. Taken as the disk at unit
// distance that fills it (Heitz and Hill 2017), drawn as the SPHERE_SIDES-gon of its
// area: on the cone's edge within 1% of the disk's radius, so a highlight's outline is
// the disk's within 1%.
#define SPHERE_SIDES 16
// The 16-gon's corners about a unit disk's centre, scaled to the disk's area by
// sqrt(2 pi / (n sin(2 pi / n))) = 1.0130016: written out, each corner one product
// with the frame, so that every program puts them on the same floats. Stepped round by
// a rotation at run time (a chain the compiler may fold and reorder as it likes in each
// program), they came out an ulp apart between the light volumes' and the clustered
// pass's programs, and the form factor of a small cone (edges that nearly cancel)
// magnified that a thousandfold and more.
#define RIM_1 1.0130016
#define RIM_2 0.93589139
#define RIM_3 0.71630025
#define RIM_4 0.38765892
const vec2 SPHERE_RIM[SPHERE_SIDES] = vec2[SPHERE_SIDES](
    vec2(RIM_1, 0.0), vec2(RIM_2, RIM_4), vec2(RIM_3, RIM_3), vec2(RIM_4, RIM_2),
    vec2(0.0, RIM_1), vec2(-RIM_4, RIM_2), vec2(-RIM_3, RIM_3), vec2(-RIM_2, RIM_4),
    vec2(-RIM_1, 0.0), vec2(-RIM_2, -RIM_4), vec2(-RIM_3, -RIM_3), vec2(-RIM_4, -RIM_2),
    vec2(0.0, -RIM_1), vec2(RIM_4, -RIM_2), vec2(RIM_3, -RIM_3), vec2(RIM_2, -RIM_4));
void set_cone(vec3 c, float sin_a, float cos_a) {
    vec3 u = normalize(cross(c, abs(c.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0)));
    vec3 e1 = sin_a * u, e2 = sin_a * cross(c, u), centre = cos_a * c;
    ltc_in_n = SPHERE_SIDES;
    for (int i = 0; i < SPHERE_SIDES; ++i)
        ltc_in[i] = centre + SPHERE_RIM[i].x * e1 + SPHERE_RIM[i].y * e2;
    set_polygon();
}

// The form factor of ltc_out (above the horizon): the clamped cosine's share of it,
// (1 / 2 pi) sum over edges of the angle they span times their plane's normal's z.
// atan(|a x b|, a.b) keeps small angles exact, as acos does not.
float form_factor() {
    if (ltc_out_n < 3) return 0.0;
    float sum = 0.0;
    vec3 a = normalize(ltc_out[ltc_out_n - 1]);
    for (int i = 0; i < ltc_out_n; ++i) {
        vec3 b = normalize(ltc_out[i]);
        vec3 c = cross(a, b);
        float s = length(c);
        if (s > 1e-12) sum += c.z * (atan(s, dot(a, b)) / s);
        a = b;
    }
    return abs(sum) / (2.0 * PI);
}

// The share of a lobe of inverse transform minv that ltc_poly covers: its form factor
// once taken through minv and clipped to the cosine's horizon. The identity gives
// Lambert's: the polygon's own form factor.
float ltc_share(mat3 minv) {
    ltc_in_n = ltc_poly_n;
    for (int i = 0; i < ltc_poly_n; ++i) ltc_in[i] = minv * ltc_poly[i];
    clip_to_horizon();
    return form_factor();
}
