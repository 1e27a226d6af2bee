// Shared by every pass: constants, the BRDF, the depth convention, SH irradiance.
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

struct Surface {
    vec3 p;       // world position
    vec3 n;       // world normal
    vec3 v;       // towards the viewer
    vec3 base;
    float metallic;
    float roughness;
    vec3 f0;      // specular colour at normal incidence
    vec3 f90;     // clamp(50 f0): f0 = 0 means no specular at all
};

Surface make_surface(vec3 p, vec3 n, vec3 v, vec4 base, vec4 mat) {
    Surface s;
    s.p = p; s.n = n; s.v = v;
    s.base = base.rgb;
    s.metallic = mat.x;
    s.roughness = clamp(mat.y, 0.0, 1.0);
    s.f0 = mix(vec3(mat.z), s.base, s.metallic);
    s.f90 = clamp(50.0 * s.f0, 0.0, 1.0);
    return s;
}

vec3 brdf_diffuse(Surface s) {
    return s.base * (1.0 - s.metallic) / PI;
}

vec3 brdf_specular(Surface s, vec3 l, float a) {
    vec3 h = normalize(l + s.v);
    float NoL = max(dot(s.n, l), 0.0);
    float NoV = max(dot(s.n, s.v), 1e-4);
    float NoH = max(dot(s.n, h), 0.0);
    float VoH = max(dot(s.v, h), 0.0);
    vec3 F = s.f0 + (s.f90 - s.f0) * pow(1.0 - VoH, 5.0);
    return F * d_ggx(NoH, a) * v_smith(NoV, NoL, a);
}

float ggx_alpha(float roughness) {
    return max(roughness * roughness, 2e-3);
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

// No shader hides NaN or Inf: the resolve pass counts the pixels that hold them and
// names the prims they lie on (engine/gpu/passes/resolve.py).
