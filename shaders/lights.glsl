// One light from the packed light table (engine/gpu/lights.py documents the row), as
// the globals the light shaders read, and what it reflects off a surface. Call
// load_light(row) first. Positions come out camera-relative (origin.glsl), as the
// surfaces they light. Include after lib.glsl (Surface, the BRDF).
#include "origin.glsl"
#include "light_table.glsl"

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
vec3 light_x;
vec3 light_y;
vec2 half_size;             // rect half extents; disk: (radius, 0)
int n_poly;
float light_area;
int light_row;

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
    n_poly = int(t6.x); light_area = t6.y;
}

// --- What the loaded light reflects off a surface, unshadowed, as its diffuse and
// glossy (base lobe and clearcoat) parts. The light pass's variants (one kind each)
// call their kind's function; the transparency pass calls light_reflected, any kind
// by its row. 0 wherever the light adds nothing (beyond its range, behind an area
// light, below the horizon).

#define MAX_VERTS 32

// Projected solid angle of the polygon seen from p with normal n, after clipping the
// polygon to the upper hemisphere (Lambert's edge integral): E = L * this.
float polygon_irradiance_factor(vec3 p, vec3 n) {
    vec3 clipped[MAX_VERTS + 1];
    int m = 0;
    vec3 prev = light_poly(n_poly - 1) - p;
    float dprev = dot(prev, n);
    for (int i = 0; i < n_poly; ++i) {
        vec3 cur = light_poly(i) - p;
        float dcur = dot(cur, n);
        if ((dprev >= 0.0) != (dcur >= 0.0)) {
            float t = dprev / (dprev - dcur);
            clipped[m++] = mix(prev, cur, t);
        }
        if (dcur >= 0.0) clipped[m++] = cur;
        prev = cur; dprev = dcur;
    }
    if (m < 3) return 0.0;
    float sum = 0.0;
    for (int i = 0; i < m; ++i) {
        vec3 a = normalize(clipped[i]);
        vec3 b = normalize(clipped[(i + 1) % m]);
        vec3 c = cross(a, b);
        float len = length(c);
        if (len > 1e-9) {
            float theta = acos(clamp(dot(a, b), -1.0, 1.0));
            sum += theta * dot(n, c / len);
        }
    }
    return abs(0.5 * sum);
}

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
// sun, whose roughness at most 1 the min leaves as it is). Suns, sphere lights and the
// light tree's groups (light_tree.glsl) all end here, so a pass that shades any of
// them evaluates the BRDF once.
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

// The loaded sphere light (point or spot) seen from s, for point_reflected: its
// direction l, its diffuse and specular irradiance and its lobes' widening; false
// where it adds nothing (beyond its range, below the horizon).
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

void sphere_light(Surface s, out vec3 diffuse, out vec3 glossy) {
    diffuse = glossy = vec3(0.0);
    vec3 l, Ed, Es;
    float widen;
    if (sphere_emitter(s, l, Ed, Es, widen)) point_reflected(s, l, Ed, Es, widen, diffuse, glossy);
}

void area_light(Surface s, out vec3 diffuse, out vec3 glossy) {
    diffuse = glossy = vec3(0.0);
    vec3 rel = s.p - light_pos;
    if (dot(rel, light_axis) <= 0.0) return;   // one-sided
    if (length(rel) > light_range) return;
    vec3 E = light_color * polygon_irradiance_factor(s.p, s.n);
    // Specular: a representative point, the reflection ray's hit on the light plane
    // clamped to the shape, with roughness widened by the light's size.
    vec3 r = reflect(-s.v, s.n);
    float denom = dot(r, light_axis);
    vec3 hit = light_pos;
    if (denom < -1e-6) {
        float t = dot(light_pos - s.p, light_axis) / denom;
        if (t > 0.0) hit = s.p + r * t;
    }
    vec2 local = vec2(dot(hit - light_pos, light_x), dot(hit - light_pos, light_y));
    if (is_disk) {
        float lr = length(local);
        if (lr > half_size.x) local *= half_size.x / lr;
    } else {
        local = clamp(local, -half_size, half_size);
    }
    vec3 q = light_pos + light_x * local.x + light_y * local.y;
    vec3 lq = q - s.p;
    float dq = length(lq);
    vec3 l = dq > 1e-6 ? lq / dq : s.n;
    float a = ggx_alpha(s.roughness), ac = ggx_alpha(s.coat_roughness);
    float widen = sqrt(light_area / PI) / max(2.0 * dq, 1e-6);
    // The bump map correction towards the light's centre for the diffuse integral.
    vec3 to_centre = normalize(light_pos - s.p);
    diffuse = E * light_diffuse * brdf_diffuse(s) * bump_visible(s, to_centre)
        * bump_shadowing(s, to_centre);
#ifdef SHEEN
    diffuse += E * light_diffuse * brdf_sheen(s, to_centre) * bump_visible(s, to_centre);
#endif
    glossy = E * light_specular * step(0.0, dot(s.n, l)) * bump_visible(s, l)
        * (brdf_specular(s, l, min(1.0, a + widen)) + brdf_coat(s, l, min(1.0, ac + widen)));
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
