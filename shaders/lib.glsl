// Shared by every pass: constants, the depth convention, the BRDF, SH irradiance.
const float PI = 3.14159265358979;

// --- Depth: read it only through these (engine/view.py states the convention) ----
// Depth is a 32-bit float, reversed: 1 at the near plane, towards 0 far away (an
// infinite far plane for perspective cameras), cleared to 0. Positions are
// camera-relative: world axes, origin at the camera's eye. `inv_view_proj` is the
// inverse of the window matrix (camera-relative -> x, y in [0, 1], window depth), the
// same whatever the GL's clip convention.

// Nothing was drawn at this pixel (the cleared value).
bool is_background(float depth) { return depth <= 0.0; }

// Whether depth a is nearer the camera than depth b.
bool nearer(float a, float b) { return a > b; }

// The camera-relative position of the surface at window uv (pixel centre: (px + 0.5) /
// size) with stored depth `depth`.
vec3 position_from_depth(vec2 uv, float depth, mat4 inv_view_proj) {
    vec4 p = inv_view_proj * vec4(uv, depth, 1.0);
    return p.xyz / p.w;
}

// The unit direction of the camera ray through window uv (for the background; an
// orthographic camera's rays all run along its forward axis).
vec3 pixel_ray(vec2 uv, mat4 inv_view_proj, bool ortho, vec3 forward) {
    return ortho ? forward : normalize(position_from_depth(uv, 1.0, inv_view_proj));
}

// The centre of the pixel being shaded, in window coordinates: gl_FragCoord in a
// fragment shader; a compute shader sets shaded_pixel first.
#ifdef COMPUTE
vec2 shaded_pixel;
vec2 pixel_centre() { return shaded_pixel; }
#else
vec2 pixel_centre() { return gl_FragCoord.xy; }
#endif

// How much a neighbour's surface (camera-relative pq, normal nq) is p's own (normal n),
// for depth-aware blurs: nothing off p's plane by more than a few percent of its
// distance, or with a normal turned away, so nothing bleeds across an edge.
float same_surface(vec3 p, vec3 n, vec3 pq, vec3 nq) {
    float plane = abs(dot(pq - p, n)) / max(length(p), 1e-6);   // distance off p's plane
    return exp(-plane * plane / (2.0 * 0.02 * 0.02)) * max(dot(n, nq), 0.0);
}

// Each of a 4 x 4 block's 16 cells its own index 0..15, neighbours far apart (a Bayer
// matrix): p's cell is p mod 4.
uint bayer4(uvec2 p) {
    uint x = p.x & 3u, y = p.y & 3u;
    return ((x ^ y) & 1u) << 3 | (y & 1u) << 2 | ((x ^ y) & 2u) | (y & 2u) >> 1;
}

// --- BRDF (Filament's model, layered as Cycles' Principled BSDF) ----------------
// GGX / Trowbridge-Reitz, alpha = roughness^2.
float d_ggx(float NoH, float a) {
    float a2 = a * a;
    float d = NoH * NoH * (a2 - 1.0) + 1.0;
    return a2 / max(PI * d * d, 1e-12);
}

// Height-correlated Smith visibility, G / (4 NoL NoV).
float v_smith(float NoV, float NoL, float a) {
    float a2 = a * a;
    float gv = NoL * sqrt(NoV * NoV * (1.0 - a2) + a2);
    float gl = NoV * sqrt(NoL * NoL * (1.0 - a2) + a2);
    return 0.5 / max(gv + gl, 1e-8);
}

float ggx_alpha(float roughness) {
    return max(roughness * roughness, 2e-3);
}

// The split-sum table (engine/lighting.py dfg_lut), by n.v (s) and perceptual
// roughness (t), texel i at i / (size - 1), in DFG_BLOCKS blocks of rows one under
// the other. Block 0: x = integral of Fc G_vis, y = integral of G_vis (the GGX albedo
// with F = 1), z = integral of F G_vis with the exact Fresnel of IOR 1.5, w = y
// averaged over the hemisphere. Blocks 1 and 2: the moments of the directions the
// lobe reflects (engine/lighting.py lobe_moments, E[l_t] and E[l_t l_n] over
// sin(theta_v); environment.glsl dome_specular);
// blocks 3 and 4 the same for a lobe weighted by the exact Fresnel of IOR 1.5.
// Every program that shades a Surface binds it.
uniform sampler2D dfg_lut;
const int DFG_BLOCKS = 5;
// The coordinates of (s, t) in [0, 1]^2 in a table of `size` texels stored at texel
// centres, as engine/lighting.py makes them (the split-sum and velvet tables).
vec2 table_uv(ivec2 size, float s, float t) {
    vec2 n = vec2(size);
    return (clamp(vec2(s, t), 0.0, 1.0) * (n - 1.0) + 0.5) / n;
}
vec4 dfg_block(int block, float NoV, float roughness) {
    ivec2 size = textureSize(dfg_lut, 0);
    vec2 uv = table_uv(ivec2(size.x, size.y / DFG_BLOCKS), NoV, roughness);
    return texture(dfg_lut, vec2(uv.x, (uv.y + float(block)) / float(DFG_BLOCKS)));
}
vec2 dfg(float NoV, float roughness) { return dfg_block(0, NoV, roughness).xy; }
float dfg_ior15(float NoV, float roughness) { return dfg_block(0, NoV, roughness).z; }
float dfg_e_avg(float roughness) { return dfg_block(0, 0.5, roughness).w; }

// A GGX lobe of perceptual roughness r reflecting towards v off normal n, each light
// direction weighted as the lobe reflects it (f cos, normalised), its Fresnel F = 1
// (a metal's, near enough) for a share 1 - dielectric of its light and a dielectric's
// exact one for the rest: its frame (t, the tangent towards v; n) and the moments of
// its directions in that frame (dfg_lut blocks 1 and 2, and 3 and 4 for the
// dielectric part, mixed by their shares: first = E[l_t], 0, E[l_n], E[l_t l_n];
// second = E[l_t^2], E[l_b^2], E[l_n^2]). A dielectric's Fresnel leans its lobe
// towards grazing directions. The dome's reflections (environment.glsl dome_specular)
// and their occlusion (ao.glsl) read it.
struct Lobe {
    vec3 n, v, t;
    float roughness;
    vec4 first;
    vec3 second;
};

Lobe make_lobe(vec3 n, vec3 v, float r, float dielectric) {
    Lobe lobe;
    lobe.n = n; lobe.v = v; lobe.roughness = r;
    float NoV = dot(n, v);
    vec3 t = v - n * NoV;
    float len = length(t);
    lobe.t = len > 1e-5 ? t / len
                        : normalize(cross(n, abs(n.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0)));
    lobe.first = mix(dfg_block(1, NoV, r), dfg_block(3, NoV, r), dielectric);
    lobe.second = mix(dfg_block(2, NoV, r), dfg_block(4, NoV, r), dielectric).xyz;
    float c = clamp(NoV, 0.0, 1.0);
    lobe.first.xw *= sqrt(1.0 - c * c);     // stored over sin(theta_v): engine/lighting.py
    return lobe;
}

// The direction a GGX lobe of roughness r about n, seen along v, reflects most: from the
// mirror direction towards n as it roughens (Lagarde and de Rousiers 2014,
// getSpecularDominantDir).
vec3 specular_dominant(vec3 n, vec3 v, float r) {
    float a = r * r;
    return mix(n, reflect(-v, n), (1.0 - a) * (sqrt(1.0 - a) + a));
}

// The lobe's mean direction, E[l] (shorter than 1 by its spread).
vec3 lobe_mean(Lobe lobe) { return lobe.first.x * lobe.t + lobe.first.z * lobe.n; }

// The half-angle of the cap about the lobe's mean direction that stands for it: a
// uniform cap whose mean direction is as short, cos = 2 |E[l]| - 1 (0 for a mirror).
float lobe_cone(Lobe lobe) { return acos(clamp(2.0 * length(lobe_mean(lobe)) - 1.0, -1.0, 1.0)); }

// A dielectric's exact (unpolarised) Fresnel reflectance, relative IOR eta >= 1, as
// Cycles' fresnel_dielectric_cos: its Principled BSDF's dielectric lobes and coat use
// it, and Schlick's form falls short of it between 40 and 70 degrees (IOR 1.5: 0.070
// against 0.089 at 60), 10-15% of a dielectric's reflection in a white furnace.
float fresnel_dielectric(float cos_i, float eta) {
    float c = abs(cos_i);
    float g2 = eta * eta - 1.0 + c * c;
    if (g2 <= 0.0) return 1.0;
    float g = sqrt(g2);
    float a = (g - c) / (g + c);
    float b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * a * a * (1.0 + b * b);
}

// A Schlick-GGX lobe's albedo of a uniform world, single scattering.
vec3 lobe_albedo(vec2 t, vec3 f0, vec3 f90) { return f0 * (t.y - t.x) + f90 * t.x; }

// The multiple-scattering factor of a GGX lobe whose single-scattering Fresnel averages
// fss over the hemisphere, as Cycles' microfacet_ggx_preserve_energy has it (Kulla and
// Conty's Fms): 1 + Fms (1 - E) / E, Fms = fss E_avg / (1 - fss (1 - E_avg)). A white
// lobe gets 1 / E; a coloured one loses more to the bounces between its microfacets.
vec3 lobe_energy(vec2 t, vec3 fss, float e_avg) {
    vec3 fms = fss * e_avg / max(1.0 - fss * (1.0 - e_avg), 1e-4);
    return 1.0 + fms * (1.0 / max(t.y, 1e-4) - 1.0);
}

// The hemispherical average of Schlick's Fresnel from f0 to f90.
vec3 fresnel_avg(vec3 f0, vec3 f90) { return f0 + (f90 - f0) / 21.0; }

const float COAT_F0 = 0.04;   // UsdPreviewSurface's clearcoat: IOR 1.5, white
const float COAT_IOR = 1.5;

// A sheen texel's alpha (engine/gpu/passes/gbuffer.py sheen_texel): roughness + 2 x
// the mode's number in core/sheen.MODES, or -1 for no sheen. Its mode (-1: none) and
// its roughness.
float sheen_mode_of(float a) { return a < 0.0 ? -1.0 : floor(a * 0.5); }
float sheen_roughness_of(float a) { return a - 2.0 * max(sheen_mode_of(a), 0.0); }

// A shaded point and its layers, top down (Cycles' Principled BSDF): an optional
// clearcoat (white GGX, F0 0.04, on the base normal) takes its directional albedo
// E_coat(n.v) and passes on 1 - E_coat; the base's specular lobe (dielectric F0 from
// the IOR, metals their base colour) takes E_spec(n.v) of what reaches it, and the
// Lambert layer gets the rest, (1 - metallic)(1 - E_dielectric). Albedos include
// multiple scattering, so a white dielectric in a white furnace reflects exactly 1.
// Dielectric lobes take the exact Fresnel: towards a light directly, and in albedos
// the table's IOR 1.5 integral (the coat's own IOR); a base of another IOR scales
// Schlick's albedo by that integral's ratio to Schlick's at IOR 1.5.
struct Surface {
    vec3 p;       // camera-relative position
    vec3 n;       // world normal
    vec3 smooth_n;  // the normal before a normal map (bump_shadowing); n without one
    vec3 v;       // towards the viewer
    vec3 base;
    float metallic;
    float roughness;
    float eta;    // the dielectric's relative IOR (1: no specular), from its F0
    float NoV;
    // Multiple-scattering factors of the base lobe's dielectric and metal parts, each
    // its own: Cycles blends the two lobes by metallic, so a half metal is half of each.
    float energy_d;
    vec3 energy_m;
    vec3 spec_albedo;   // the base lobe's albedo at n.v (multiple scattering included)
    float spec_dielectric;  // the dielectric lobe's share of it (lib.glsl Lobe)
    vec3 diffuse;       // Lambert albedo left to the diffuse layer
    float coat;         // coat weight
    float coat_roughness;
    float coat_energy;
    float coat_albedo;  // coat weight x its albedo at n.v
    float under_coat;   // 1 - coat_albedo: what the layers below receive
    // A sheen lobe (sheen.glsl apply_sheen; none: colour 0): its colour, roughness,
    // mode (core/sheen.MODES), directional albedo at n.v and microfiber LTC terms.
    vec3 sheen;
    float sheen_roughness;
    int sheen_mode;
    float sheen_albedo;
    float sheen_a;
    float sheen_b;
};

// mat = (metallic, roughness, dielectric F0, clearcoat), as the G-buffer stores it.
Surface make_surface(vec3 p, vec3 n, vec3 v, vec4 base, vec4 mat, float coat_roughness) {
    Surface s;
    s.p = p; s.n = n; s.smooth_n = n; s.v = v;
    s.base = max(base.rgb, vec3(0.0));
    s.metallic = clamp(mat.x, 0.0, 1.0);
    s.roughness = clamp(mat.y, 0.0, 1.0);
    float f0_d = mat.z;
    float f90_d = clamp(50.0 * f0_d, 0.0, 1.0);
    float root_f0 = min(sqrt(max(f0_d, 0.0)), 0.999);
    s.eta = (1.0 + root_f0) / (1.0 - root_f0);
    s.NoV = clamp(dot(n, v), 1e-4, 1.0);
    vec2 t = dfg(s.NoV, s.roughness);
    float exact_ratio = dfg_ior15(s.NoV, s.roughness) / max(COAT_F0 * (t.y - t.x) + t.x, 1e-6);
    float e_avg = dfg_e_avg(s.roughness);
    vec3 f90_m = clamp(50.0 * s.base, 0.0, 1.0);
    s.energy_d = lobe_energy(t, fresnel_avg(vec3(f0_d), vec3(f90_d)), e_avg).x;
    s.energy_m = lobe_energy(t, fresnel_avg(s.base, f90_m), e_avg);
    // The dielectric lobe's albedo (what its diffuse layer does not get), and the metal's.
    float e_d = lobe_albedo(t, vec3(f0_d), vec3(f90_d)).x * s.energy_d * exact_ratio;
    vec3 e_m = lobe_albedo(t, s.base, f90_m) * s.energy_m;
    s.spec_albedo = mix(vec3(e_d), e_m, s.metallic);
    float dielectric_part = (1.0 - s.metallic) * e_d;
    s.spec_dielectric = dielectric_part / max(dielectric_part + s.metallic * dot(e_m, vec3(1.0 / 3.0)), 1e-6);
    s.coat = clamp(mat.w, 0.0, 1.0);
    s.coat_roughness = clamp(coat_roughness, 0.0, 1.0);
    s.coat_energy = 1.0;
    s.coat_albedo = 0.0;
    if (s.coat > 0.0) {
        vec2 tc = dfg(s.NoV, s.coat_roughness);
        s.coat_energy = lobe_energy(tc, fresnel_avg(vec3(COAT_F0), vec3(1.0)),
                                    dfg_e_avg(s.coat_roughness)).x;
        s.coat_albedo = s.coat * dfg_ior15(s.NoV, s.coat_roughness) * s.coat_energy;
    }
    s.under_coat = 1.0 - s.coat_albedo;
    s.diffuse = s.base * (1.0 - s.metallic) * (1.0 - e_d) * s.under_coat;
    s.sheen = vec3(0.0);
    s.sheen_roughness = 0.0;
    s.sheen_mode = 0;
    s.sheen_albedo = s.sheen_a = s.sheen_b = 0.0;
    return s;
}

Surface make_surface(vec3 p, vec3 n, vec3 v, vec4 base, vec4 mat) {
    return make_surface(p, n, v, base, mat, 0.0);
}

// Lambert, after the layers above took their share.
vec3 brdf_diffuse(Surface s) {
    return s.diffuse / PI;
}

float schlick_weight(float VoH) {
    float x = 1.0 - VoH;
    float x2 = x * x;
    return x2 * x2 * x;
}

// The base's specular lobe towards l (alpha a: a light's size may widen it), under
// the coat, with multiple scattering.
vec3 brdf_specular(Surface s, vec3 l, float a) {
    vec3 h = normalize(l + s.v);
    float NoL = max(dot(s.n, l), 0.0);
    float NoH = max(dot(s.n, h), 0.0);
    float VoH = max(dot(s.v, h), 0.0);
    float w = schlick_weight(VoH);
    vec3 f0_m = s.base, f90_m = clamp(50.0 * s.base, 0.0, 1.0);
    vec3 F = mix(vec3(fresnel_dielectric(VoH, s.eta) * s.energy_d),
                 (f0_m + (f90_m - f0_m) * w) * s.energy_m, s.metallic);
    return s.under_coat * F * d_ggx(NoH, a) * v_smith(s.NoV, NoL, a);
}

// The clearcoat lobe towards l (alpha a).
vec3 brdf_coat(Surface s, vec3 l, float a) {
    if (s.coat <= 0.0) return vec3(0.0);
    vec3 h = normalize(l + s.v);
    float NoL = max(dot(s.n, l), 0.0);
    float NoH = max(dot(s.n, h), 0.0);
    float VoH = max(dot(s.v, h), 0.0);
    float F = fresnel_dielectric(VoH, COAT_IOR);
    return vec3(s.coat * s.coat_energy * F * d_ggx(NoH, a) * v_smith(s.NoV, NoL, a));
}

// Cycles' bump map correction (kernel/closure/bsdf.h bump_shadowing_term; on by
// default, Material > Settings) where a normal map bends n away from the smooth normal:
// light from behind the smooth surface adds nothing to any lobe (bump_visible), and the
// diffuse lobe is shadowed by GGX's Smith G1 at a roughness that grows with the bend
// (bump_shadowing; Conty Estevez et al. 2019, "A Microfacet-Based Shadowing Function to
// Solve the Bump Terminator Problem"). Without a map smooth_n == n, and both are 1.
float bump_visible(Surface s, vec3 l) {
    if (s.smooth_n == s.n) return 1.0;
    return dot(s.smooth_n, l) * dot(s.smooth_n, s.n) * dot(s.n, l) < 0.0 ? 0.0 : 1.0;
}

float bump_shadowing(Surface s, vec3 l) {
    if (s.smooth_n == s.n) return 1.0;
    float cos_i = abs(dot(s.smooth_n, l)), cos_d = abs(dot(s.smooth_n, s.n));
    if (cos_d >= 1.0 || cos_i >= 1.0) return 1.0;
    if (cos_i < 1e-6) return 0.0;
    float alpha2 = clamp(0.125 * (1.0 / (cos_d * cos_d) - 1.0), 0.0, 1.0);
    float tan2 = (1.0 - cos_i * cos_i) / (cos_i * cos_i);
    return 2.0 / (1.0 + sqrt(1.0 + alpha2 * tan2));
}

// The share of a uniform dome's diffuse light that the correction keeps, by the cosine
// of the bend at 0, 0.1, ..., 1: bump_visible x bump_shadowing integrated over the bent
// normal's hemisphere (tests/test_bump_correction.py integrates it again). Other domes
// take the same share of their irradiance.
const float BUMP_DOME[11] = float[](0.2732, 0.3128, 0.3541, 0.3973, 0.4752, 0.5655, 0.6525,
                                    0.7377, 0.8224, 0.9080, 1.0);

float bump_dome(Surface s) {
    if (s.smooth_n == s.n) return 1.0;
    float x = clamp(abs(dot(s.smooth_n, s.n)), 0.0, 1.0) * 10.0;
    int i = min(int(x), 9);
    return mix(BUMP_DOME[i], BUMP_DOME[i + 1], x - float(i));
}

// Irradiance from order-2 SH whose coefficients already include the cosine-lobe
// convolution (see lights.py sh_basis / latlong_sh).
vec3 sh_irradiance(vec3 sh[9], vec3 d) {
    return sh[0] * 0.282095
        + sh[1] * 0.488603 * d.y + sh[2] * 0.488603 * d.z + sh[3] * 0.488603 * d.x
        + sh[4] * 1.092548 * d.x * d.y + sh[5] * 1.092548 * d.y * d.z
        + sh[6] * 0.315392 * (3.0 * d.z * d.z - 1.0)
        + sh[7] * 1.092548 * d.x * d.z + sh[8] * 0.546274 * (d.x * d.x - d.y * d.y);
}

// The mean radiance over a distribution of directions l whose first moment is m =
// E[l] and second S = E[l l^T], of the radiance the harmonics above hold (each band's
// cosine-lobe factor A_l = pi, 2pi/3, pi/4 taken out): exact, as a quadratic function of
// l, whatever the distribution. A single direction d is m = d, S = d d^T.
vec3 sh_radiance_mean(vec3 sh[9], vec3 m, mat3 S) {
    const float A1 = 2.0 * PI / 3.0, A2 = PI / 4.0;
    return sh[0] * (0.282095 / PI)
        + (sh[1] * m.y + sh[2] * m.z + sh[3] * m.x) * (0.488603 / A1)
        + (sh[4] * (1.092548 * S[0][1]) + sh[5] * (1.092548 * S[1][2])
           + sh[6] * (0.315392 * (3.0 * S[2][2] - (S[0][0] + S[1][1] + S[2][2])))
           + sh[7] * (1.092548 * S[0][2]) + sh[8] * (0.546274 * (S[0][0] - S[1][1]))) / A2;
}

// The sRGB transfer function, decoded (IEC 61966-2-1), as Cycles decodes 8-bit images.
vec3 srgb_to_linear(vec3 c) {
    bvec3 low = lessThanEqual(c, vec3(0.04045));
    return mix(pow((c + 0.055) / 1.055, vec3(2.4)), c / 12.92, vec3(low));
}

// No shader hides NaN or Inf: the resolve pass counts the pixels that hold them and
// names the prims they lie on (engine/gpu/passes/resolve.py).

#include "sheen.glsl"
