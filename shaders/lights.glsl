// One light from the packed light table (engine/gpu/lights.py documents the row), as
// the globals the light shaders read, and what it reflects off a surface. Call
// load_light(row) first. Positions come out camera-relative (origin.glsl), as the
// surfaces they light. Include after lib.glsl (Surface, the BRDF).
#include "origin.glsl"
#include "light_table.glsl"
#include "ltc.glsl"

// The light kinds a program shades: those it defines (core/lights.py KINDS' shader
// defines: LIGHT_DISTANT, LIGHT_SPHERE for points, LIGHT_SPOT for spots, LIGHT_AREA),
// else every kind (the transparency pass). Only theirs are compiled: llvmpipe runs
// every branch of a shader, masked.
#if !defined(LIGHT_DISTANT) && !defined(LIGHT_SPHERE) && !defined(LIGHT_SPOT) && !defined(LIGHT_AREA)
#define LIGHT_DISTANT
#define LIGHT_SPOT
#define LIGHT_AREA
#endif
#ifdef LIGHT_SPOT
#define LIGHT_SPHERE            // a spot is a sphere light with a cone
#endif

vec3 light_pos;             // camera-relative
float light_range;          // volume radius: nothing is added beyond it
vec3 light_color;           // I [W/sr], L [W/(sr m2)] or E [W/m2]
float light_radius;
vec3 light_axis;            // direction of emission (light's -Z)
float cos_half;
float spot_blend;
float light_diffuse;
float light_specular;
bool soft_falloff;
bool is_spot;
bool is_disk;
bool is_distant;
int first_extra;            // an emissive mesh's polygons past the first: their rows
int n_extra;
vec3 light_x;
vec3 light_y;
vec2 half_size;             // rect half extents; disk: its semi-axes (an ellipse's differ)
int n_poly;
int light_row;
uniform float light_error;  // the light tree's and emitter groups' bound (RenderSettings)
uint area_steps = 0u;       // emitter groups' nodes visited (lights.comp counts them)

vec4 light_texel(int k) { return light_table(light_row, k); }

// Camera-relative vertex i of an area light's polygon (stored about its centre).
vec3 light_poly(int i) { return light_pos + light_texel(8 + i).xyz; }

void load_light(int row, vec3 view_forward) {
    light_row = row;
    vec4 t0 = light_texel(0), t1 = light_texel(1), t2 = light_texel(2), t3 = light_texel(3);
    light_pos = rebase(t0.xyz, light_texel(7).xyz); light_range = t0.w;
    light_color = t1.rgb; light_radius = t1.w;
    light_axis = t2.xyz; cos_half = t2.w;
    spot_blend = t3.x; light_diffuse = t3.y; light_specular = t3.z;
    int flags = int(t3.w);
    soft_falloff = (flags & 1) != 0;
    is_spot = (flags & 2) != 0;
    is_disk = (flags & 4) != 0;
    is_distant = (flags & 16) != 0;
    if ((flags & 8) != 0) light_axis = view_forward;   // a headlight follows the view
    vec4 t4 = light_texel(4), t5 = light_texel(5), t6 = light_texel(6);
    light_x = t4.xyz; light_y = t5.xyz;
    half_size = vec2(t4.w, t5.w);
    n_poly = int(t6.x);
    first_extra = int(t6.z); n_extra = int(t6.w);
}

// --- What the loaded light reflects off a surface, unshadowed, as its diffuse and
// glossy (base lobe and clearcoat) parts. The light pass's variants (one kind each)
// call their kind's function; the transparency pass calls light_reflected, any kind
// by its row. 0 wherever the light adds nothing (beyond its range, behind an area
// light, below the horizon).

// Blender's spot cone, smoothstep over (cos phi - cos(size/2)) / ((1 - cos(size/2)) blend).
float cone(vec3 from_light) {
    float t = dot(from_light, light_axis) - cos_half;
    float width = (1.0 - cos_half) * spot_blend;
    return width > 0.0 ? smoothstep(0.0, 1.0, t / width) : step(0.0, t);
}

// Cycles evaluates the cone from each sampled point of a spot with a radius, which
// softens its edge; average over the light's disk as seen from p (7-point disk rule:
// centre 1/4, six points at radius sqrt(2/3) of 1/8 each).
float spot_mask(vec3 p, vec3 l, float d) {
    if (light_radius <= 0.0 || d <= light_radius) return cone(-l);
    vec3 e1 = normalize(abs(l.z) < 0.9 ? cross(l, vec3(0, 0, 1)) : cross(l, vec3(1, 0, 0)));
    vec3 e2 = cross(l, e1);
    float mask = 0.25 * cone(-l);
    float rr = light_radius * 0.8164966;
    for (int i = 0; i < 6; ++i) {
        float ang = float(i) * 1.0471976;
        vec3 q = light_pos + rr * (cos(ang) * e1 + sin(ang) * e2);
        mask += 0.125 * cone(normalize(p - q));
    }
    return mask;
}

// What an emitter in direction l (unit) from s sends towards the viewer: Ed and Es,
// the irradiance its diffuse and specular parts bring (the bump's visibility taken),
// and its specular lobes widened by `widen` (a sphere's size, Karis 2013; 0 for the
// sun and points, whose roughness at most 1 the min leaves as it is). Suns, points and
// the light tree's lights and groups (light_tree.glsl) all end here, so a pass that
// shades any of them evaluates the BRDF once; sphere lights one by one have the
// sphere form (sphere_light).
void point_reflected(Surface s, vec3 l, vec3 Ed, vec3 Es, float widen,
                     out vec3 diffuse, out vec3 glossy) {
    float a = ggx_alpha(s.roughness), ac = ggx_alpha(s.coat_roughness);
    diffuse = Ed * brdf_diffuse(s) * bump_shadowing(s, l);
#ifdef SHEEN
    diffuse += Ed * brdf_sheen(s, l);
#endif
    glossy = Es * (brdf_specular(s, l, min(1.0, a + widen)) + brdf_coat(s, l, min(1.0, ac + widen)));
}

void distant_light(Surface s, out vec3 diffuse, out vec3 glossy) {
    diffuse = glossy = vec3(0.0);
    vec3 l = -light_axis;
    float NoL = dot(s.n, l);
    if (NoL <= 0.0) return;
    vec3 E = light_color * NoL * bump_visible(s, l);
    point_reflected(s, l, E * light_diffuse, E * light_specular, 0.0, diffuse, glossy);
}

// The loaded sphere light (point or spot) seen from s as a point, for point_reflected
// (a point, and the light tree's lights): its direction l, its diffuse and specular
// irradiance and its lobes' widening by its size; false where it adds nothing (beyond
// its range, below the horizon).
bool sphere_emitter(Surface s, out vec3 l, out vec3 Ed, out vec3 Es, out float widen) {
    vec3 to_light = light_pos - s.p;
    float d2 = dot(to_light, to_light);
    float d = sqrt(d2);
    // A light sitting on the surface: take it as straight overhead, never 0/0.
    l = d > 1e-6 ? to_light / d : s.n;
    float NoL = dot(s.n, l);
    Ed = Es = vec3(0.0);
    widen = light_radius / max(2.0 * d, 1e-6);
    if (d > light_range || NoL <= 0.0) return false;
    float falloff = soft_falloff ? d2 + light_radius * light_radius : d2;
    vec3 E = light_color * NoL / max(falloff, 1e-8);
#ifdef LIGHT_SPOT
    if (is_spot) E *= spot_mask(s.p, l, d);
#endif
    E *= bump_visible(s, l);
    Ed = E * light_diffuse;
    Es = E * light_specular;
    return true;
}

// The frame (t, b, n) of s's lobes (lib.glsl Lobe), from world directions.
mat3 lobe_frame(Surface s) {
    vec3 t = s.v - s.n * dot(s.n, s.v);
    float len = length(t);
    t = len > 1e-5 ? t / len
                   : normalize(cross(s.n, abs(s.n.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0)));
    return transpose(mat3(t, cross(s.n, t), s.n));
}

// Polygon k of the loaded area light about s, in the frame (t, b, n) of s's lobes
// (lib.glsl Lobe), clipped to s's horizon: ltc_poly (ltc.glsl). `row`: the table row
// that holds it (the light's own, or one of its polygon rows), n its corners.
void area_polygon(Surface s, int row, int n) {
    mat3 to_frame = lobe_frame(s);
    ltc_in_n = n;
    for (int i = 0; i < n; ++i)
        ltc_in[i] = to_frame * (light_pos + light_table(row, 8 + i).xyz - s.p);
    set_polygon();
}

// What ltc_poly, of radiance L, reflects off s: diffuse the exact form factor
// (Lambert's lobe), the base's GGX lobe and the coat's each their share of the polygon
// by their LTC (ltc.glsl) times their albedo at n.v (their Fresnel averaged over the
// lobe, as the split-sum's), the microfiber sheen its own LTC exactly (sheen.glsl).
// The lobes' shares come from one loop, as many turns as s has lobes: one copy of the
// integral in a program. With a copy a lobe, straight after a sphere light's cone
// (set_cone), llvmpipe took 40 s, not 1.4, to compile the sphere light's volume.
void polygon_reflected(Surface s, vec3 L, inout vec3 diffuse, inout vec3 glossy) {
    // The bump map correction towards the light's centre for the diffuse integral, and
    // along the mirror direction for the glossy lobes.
    vec3 to_centre = normalize(light_pos - s.p);
    float visible = bump_visible(s, to_centre);
    // Lobe k: 0 Lambert's, 1 the base's GGX, 2 the coat's, 3 the sheen's.
    mat3 inverses[4] = mat3[4](mat3(1.0), ltc_inverse(s.NoV, s.roughness),
                               ltc_inverse(s.NoV, s.coat_roughness), mat3(1.0));
    int last = s.coat > 0.0 ? 2 : 1;
#ifdef SHEEN
    if (s.sheen_mode != 2 && max(s.sheen.r, max(s.sheen.g, s.sheen.b)) > 0.0) {
        inverses[3] = mat3(vec3(s.sheen_a, 0.0, 0.0), vec3(0.0, s.sheen_a, 0.0),
                           vec3(s.sheen_b, 0.0, 1.0));
        last = 3;
    }
#endif
#ifdef LIGHTS_DIFFUSE_ONLY
    last = 0;     // a program that reads the diffuse light alone: Lambert's lobe only
#endif
    vec4 share = vec4(0.0);
    for (int k = 0; k <= last; ++k)
        if (k != 2 || s.coat > 0.0) share[k] = ltc_share(inverses[k]);
    vec3 E = L * (PI * share[0]) * light_diffuse * visible;
    diffuse += E * brdf_diffuse(s) * bump_shadowing(s, to_centre);
#ifdef SHEEN
    if (s.sheen_mode == 2)
        diffuse += E * brdf_sheen(s, to_centre);
    else
        diffuse += L * light_diffuse * visible * s.sheen * s.sheen_albedo * share[3];
#endif
    vec3 lobes = s.under_coat * s.spec_albedo * share[1] + vec3(s.coat_albedo * share[2]);
    glossy += L * light_specular * bump_visible(s, reflect(-s.v, s.n)) * lobes;
}

// A sphere light (point or spot) of radius r > 0, by the light of the cone it fills
// seen from s (ltc.glsl set_cone) through the area lights' LTC (polygon_reflected):
// Blender's sphere (soft falloff off) fills the cone of its visible cap, sin a = r / d;
// with soft falloff, Cycles' disk of radius r at the light facing s, tan a = r / d.
// Either sends radiance I / (pi r^2), so wherever the cone is above s's horizon the
// diffuse light is I cos / d^2 and I cos / (d^2 + r^2), Blender's two falloffs, and its
// highlight is the sphere's disk, not a widened lobe. Inside the sphere, the half-space
// towards its centre. A point (r = 0) is its limit: f cos I / d^2 (point_reflected).
void sphere_light(Surface s, out vec3 diffuse, out vec3 glossy) {
    diffuse = glossy = vec3(0.0);
    vec3 l, Ed, Es;
    float widen;
    if (light_radius <= 0.0) {
        if (sphere_emitter(s, l, Ed, Es, widen)) point_reflected(s, l, Ed, Es, widen, diffuse, glossy);
        return;
    }
    vec3 to_light = light_pos - s.p;
    float d = length(to_light), r = light_radius;
    if (d > light_range) return;
    l = d > 1e-6 ? to_light / d : s.n;
    float h = soft_falloff ? sqrt(d * d + r * r) : max(d, r);
    float sin_a = r / h;
    float cos_a = soft_falloff ? d / h : sqrt(max(1.0 - sin_a * sin_a, 0.0));
    vec3 L = light_color / (PI * r * r);
#ifdef LIGHT_SPOT
    if (is_spot) L *= spot_mask(s.p, l, d);
#endif
    set_cone(lobe_frame(s) * l, sin_a, cos_a);
    if (ltc_poly_n >= 3) polygon_reflected(s, L, diffuse, glossy);
}

// The node after i in a depth-first walk of an implicit complete tree (children 2i+1,
// 2i+2) once i's own subtree is done; -1 when the walk is over: numbered from 1, right
// children are odd, so climb past the trailing ones to the nearest left child, whose
// right sibling is next (light_tree.glsl tree_next, with findLSB: GL 4 only).
int next_in_tree(int i) {
    int k = i + 1;
    while ((k & 1) != 0) k >>= 1;
    return k == 0 ? -1 : k;
}

// Whether the polygon or group at `row` lights s: s on the face it lights from (a
// corner is on its plane; the light's position, an emissive mesh's box's middle, may
// not be). A point in the plane (within the depth's rounding: an emitter's own
// surface) sees it edge on, and nothing: the horizon's clip of a polygon around the
// point is not to be trusted.
bool polygon_faces(Surface s, int row) {
    vec3 to_s = s.p - light_pos - light_table(row, 8).xyz;
    float side = dot(to_s, light_table(row, 2).xyz);
    return abs(side) > 1e-3 * length(to_s)
        && (side > 0.0 || (int(light_table(row, 3).w) & 32) != 0);
}

// Whether the group at `row` (coplanar polygons facing s) stands for its polygons at s
// as its rect of their mean radiance (engine/emitter_groups.py derives the bound): exact
// where they fill it with one radiance; else its whole rect above s's horizon and the
// bound within light_error of the rect's irradiance, per channel.
bool group_stands(Surface s, int row) {
    vec4 t4 = light_table(row, 4), t5 = light_table(row, 5);
    if (max(max(t4.r, t4.g), max(t4.b, max(t5.r, max(t5.g, t5.b)))) <= 0.0) return true;
    vec3 a = light_pos + light_table(row, 8).xyz, c = light_pos + light_table(row, 10).xyz;
    vec3 b = light_pos + light_table(row, 9).xyz, e = light_pos + light_table(row, 11).xyz;
    vec3 u = 0.5 * (a + c) - s.p;
    float d = length(u), r = t4.w, dmin = d - r;
    if (dmin <= 0.0 || min(min(dot(s.n, a - s.p), dot(s.n, b - s.p)),
                           min(dot(s.n, c - s.p), dot(s.n, e - s.p))) <= 0.0) return false;
    vec3 own = light_table(row, 1).rgb * light_table(row, 6).y
             * abs(dot(light_table(row, 2).xyz, u)) * dot(s.n, u) / (d * d * d * d);
    vec3 bound = (6.0 * t4.rgb + 19.0 * r * r * t5.rgb / dmin) / (dmin * dmin * dmin);
    return all(lessThanEqual(bound, light_error * own));
}

// An area light: a rect, a disk's polygon, or an emissive mesh's polygons (its own row
// holds the first, n_extra rows from first_extra the others, each with its radiance,
// its front and whether it lights from both faces, then its groups' rows:
// engine/gpu/lights.py). Each lights s from the face s is on, if it lights from that
// face. A mesh's polygons are the leaves of a tree of groups (engine/emitter_groups.py):
// a group that stands for its polygons at s (group_stands) is shaded as one rect, else
// its parts. The shadow's axis (shadow_lookup.glsl) is the first polygon's, turned to
// s's side.
void area_light(Surface s, out vec3 diffuse, out vec3 glossy) {
    diffuse = glossy = vec3(0.0);
    if (length(s.p - light_pos) > light_range) return;
    vec3 first_axis = light_axis;
    int n = n_extra + 1;
    int leaves = 1;
    while (leaves < n) leaves *= 2;
    int i = 0;
    while (i >= 0) {
        bool down = false;
        int row = -1;
        if (i >= leaves - 1) {
            int k = i - (leaves - 1);
            if (k < n) row = k == 0 ? light_row : first_extra + k - 1;
        } else {
            int group = first_extra + n_extra + i;
            ++area_steps;
            if (light_table(group, 5).w > 0.0) {
                bool coplanar = int(light_table(group, 6).x) > 0;
                if (!coplanar) down = true;
                else if (polygon_faces(s, group)) {
                    if (group_stands(s, group)) row = group;
                    else down = true;
                }
            }
        }
        if (row >= 0 && polygon_faces(s, row)) {
            area_polygon(s, row, int(light_table(row, 6).x));
            if (ltc_poly_n >= 3) polygon_reflected(s, light_table(row, 1).rgb, diffuse, glossy);
        }
        i = down ? 2 * i + 1 : next_in_tree(i);
    }
    if (dot(s.p - light_poly(0), first_axis) <= 0.0) light_axis = -first_axis;
}

// Any of the program's kinds, by the loaded row's flags.
void light_reflected(Surface s, out vec3 diffuse, out vec3 glossy) {
    diffuse = glossy = vec3(0.0);
#ifdef LIGHT_DISTANT
    if (is_distant) {
        distant_light(s, diffuse, glossy);
        return;
    }
#endif
#ifdef LIGHT_AREA
    if (n_poly > 0) {
        area_light(s, diffuse, glossy);
        return;
    }
#endif
#ifdef LIGHT_SPHERE
    sphere_light(s, diffuse, glossy);
#endif
}
