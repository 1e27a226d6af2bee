#version 330 core
#include "lib.glsl"
// One light, added into the HDR target (blend ONE, ONE). Variants: LIGHT_DISTANT
// (full-screen), LIGHT_SPHERE (point and spot, drawn as a light volume), LIGHT_AREA
// (rect and disk as a polygon, drawn as a light volume). See engine/usd/lights.py for
// the light forms; the light itself comes from the light table (lights.glsl).
uniform sampler2D g_base;
uniform sampler2D g_normal;
uniform sampler2D g_mat;
uniform sampler2D g_depth;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;

#include "lights.glsl"
#ifdef LIGHTS_INSTANCED
flat in int v_light;        // many shadowless sphere lights in one draw (volume.vert)
#else
uniform int light_index;
#endif
#ifdef LIGHT_AREA
#define MAX_VERTS 32
#endif

#ifdef HAS_SHADOW
#include "shadow_lookup.glsl"
#endif

out vec4 frag;

#ifdef LIGHT_AREA
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
#endif

#ifdef LIGHT_SPHERE
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
#endif

void main() {
#ifdef LIGHTS_INSTANCED
    load_light(v_light, cam_forward);
#else
    load_light(light_index, cam_forward);
#endif
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) discard;
    vec2 uv = (vec2(px) + 0.5) / vec2(textureSize(g_depth, 0));
    vec3 p = position_from_depth(uv, depth, inv_view_proj);   // camera-relative
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    Surface s = make_surface(p, n, v, texelFetch(g_base, px, 0), texelFetch(g_mat, px, 0));
    float a = ggx_alpha(s.roughness);
    vec3 radiance = vec3(0.0);

#ifdef LIGHT_DISTANT
    vec3 l = -light_axis;
    float NoL = dot(n, l);
    if (NoL <= 0.0) discard;
    vec3 E = light_color * NoL;
    radiance = E * (light_diffuse * brdf_diffuse(s) + light_specular * brdf_specular(s, l, a));
#endif

#ifdef LIGHT_SPHERE
    vec3 to_light = light_pos - p;
    float d2 = dot(to_light, to_light);
    float d = sqrt(d2);
    if (d > light_range) discard;
    // A light sitting on the surface: take it as straight overhead, never 0/0.
    vec3 l = d > 1e-6 ? to_light / d : n;
    float NoL = dot(n, l);
    if (NoL <= 0.0) discard;
    float falloff = soft_falloff ? d2 + light_radius * light_radius : d2;
    vec3 E = light_color * NoL / max(falloff, 1e-8);
    if (is_spot) E *= spot_mask(p, l, d);
    // A sphere source widens the highlight (Karis 2013); a point keeps alpha.
    float a_spec = min(1.0, a + light_radius / max(2.0 * d, 1e-6));
    radiance = E * (light_diffuse * brdf_diffuse(s) + light_specular * brdf_specular(s, l, a_spec));
#endif

#ifdef LIGHT_AREA
    vec3 rel = p - light_pos;
    if (dot(rel, light_axis) <= 0.0) discard;   // one-sided
    if (length(rel) > light_range) discard;
    vec3 E = light_color * polygon_irradiance_factor(p, n);
    // Specular: a representative point, the reflection ray's hit on the light plane
    // clamped to the shape, with roughness widened by the light's size.
    vec3 r = reflect(-v, n);
    float denom = dot(r, light_axis);
    vec3 hit = light_pos;
    if (denom < -1e-6) {
        float t = dot(light_pos - p, light_axis) / denom;
        if (t > 0.0) hit = p + r * t;
    }
    vec2 local = vec2(dot(hit - light_pos, light_x), dot(hit - light_pos, light_y));
    if (is_disk) {
        float lr = length(local);
        if (lr > half_size.x) local *= half_size.x / lr;
    } else {
        local = clamp(local, -half_size, half_size);
    }
    vec3 q = light_pos + light_x * local.x + light_y * local.y;
    vec3 lq = q - p;
    float dq = length(lq);
    vec3 l = dq > 1e-6 ? lq / dq : n;
    float a_spec = min(1.0, a + sqrt(light_area / PI) / max(2.0 * dq, 1e-6));
    radiance = E * light_diffuse * brdf_diffuse(s)
             + E * light_specular * brdf_specular(s, l, a_spec) * step(0.0, dot(n, l));
#endif

#ifdef HAS_SHADOW
    if (max(radiance.r, max(radiance.g, radiance.b)) > 0.0)
        radiance *= shadow_factor(p, n, light_pos, light_axis, dot(p, cam_forward));
#endif
    frag = vec4(radiance, 0.0);   // NaN or Inf goes through: the resolve pass counts it
}
