// A UsdPreviewSurface material at one fragment: its constants (uniforms), its maps
// (UsdUVTexture: wrap, scale, bias, channel; one sampler per mapped input, present
// only in the variants that map it: HAS_*_MAP), and the shading normal. Shared by the
// G-buffer, the transparency pass and the shadow casters' alpha test, so a material
// reads the same wherever it is drawn. Include after lib.glsl (srgb_to_linear).
uniform vec3 u_diffuse;
uniform float u_metallic;
uniform float u_roughness;
uniform float u_ior;
uniform vec3 u_emissive;
uniform float u_opacity;
uniform float u_opacity_threshold;
uniform float u_clearcoat;
uniform float u_base_occlusion;    // 1: the base colour takes the frame's occlusion
uniform float u_clearcoat_roughness;
// A sheen: the G-buffer writes it (WRITE_SHEEN), the transparency pass shades it (SHEEN).
#if defined(WRITE_SHEEN) || defined(SHEEN)
#define MATERIAL_SHEEN
uniform vec4 u_sheen;   // what g_sheen holds (engine/gpu/passes/gbuffer.py sheen_texel)
#endif
// Cycles' bump map correction (Material > Settings), for a normal-mapped material.
uniform bool u_bump_correction = true;
// The footprint a lookup filters over, as a fraction of the fragment's own
// (engine/gpu/passes/antialias.py texture_footprint): 1 but in supersampled images.
uniform float u_texture_footprint = 1.0;


// A UsdUVTexture: wrap (0 repeat, 1 mirror, 2 clamp, 3 black), scale, bias, channel
// (-1 rgb, 0..3 r g b a). srgb: an 8-bit sRGB image filtered as Cycles filters it
// (engine/gpu/textures.py): magnified, its stored values are interpolated and then
// decoded; minified, its mips (averages of that in linear light) are filtered by GL.
struct Map { ivec2 wrap; vec4 scale; vec4 bias; int channel; bool srgb; };

float wrap1(float x, int mode) {
    if (mode == 1) return 1.0 - abs(mod(x, 2.0) - 1.0);
    return x;
}

int wrap_texel(int i, int n, int mode) {
    return mode == 0 ? ((i % n) + n) % n : clamp(i, 0, n - 1);
}

vec3 linear_to_srgb(vec3 c) {
    bvec3 low = lessThanEqual(c, vec3(0.0031308));
    return mix(1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, 12.92 * c, vec3(low));
}

// Cycles' 8-bit sRGB lookup at w: bilinear over the four stored (encoded) texels, then
// decoded. The texture is an sRGB format, so fetched texels come decoded: encode them
// again (exact for 8-bit values).
vec4 bilinear_encoded(sampler2D t, Map m, vec2 w) {
    ivec2 n = textureSize(t, 0);
    vec2 f = w * vec2(n) - 0.5;
    ivec2 i = ivec2(floor(f));
    vec2 a = f - vec2(i);
    int x0 = wrap_texel(i.x, n.x, m.wrap.x), x1 = wrap_texel(i.x + 1, n.x, m.wrap.x);
    int y0 = wrap_texel(i.y, n.y, m.wrap.y), y1 = wrap_texel(i.y + 1, n.y, m.wrap.y);
    vec4 c00 = texelFetch(t, ivec2(x0, y0), 0), c10 = texelFetch(t, ivec2(x1, y0), 0);
    vec4 c01 = texelFetch(t, ivec2(x0, y1), 0), c11 = texelFetch(t, ivec2(x1, y1), 0);
    c00.rgb = linear_to_srgb(c00.rgb); c10.rgb = linear_to_srgb(c10.rgb);
    c01.rgb = linear_to_srgb(c01.rgb); c11.rgb = linear_to_srgb(c11.rgb);
    vec4 c = mix(mix(c00, c10, a.x), mix(c01, c11, a.x), a.y);
    return vec4(srgb_to_linear(c.rgb), c.a);
}

vec4 sample_map(sampler2D t, Map m, vec2 uv) {
    // Gradients from the unwrapped st so mirror folds do not spike the mip level.
    vec2 dx = dFdx(uv) * u_texture_footprint, dy = dFdy(uv) * u_texture_footprint;
    vec2 w = vec2(wrap1(uv.x, m.wrap.x), wrap1(uv.y, m.wrap.y));
    vec4 c = textureGrad(t, w, dx, dy);
    if (m.srgb) {
        // Magnified (the footprint under a texel along its longer axis) one lookup is
        // the pixel; from two texels on GL's filtering averages the footprint.
        vec2 n = vec2(textureSize(t, 0));
        float major = max(length(dx * n), length(dy * n));
        c = mix(bilinear_encoded(t, m, w), c, clamp(log2(max(major, 1e-8)), 0.0, 1.0));
    }
    bool outside = (m.wrap.x == 3 && (uv.x < 0.0 || uv.x > 1.0)) ||
                   (m.wrap.y == 3 && (uv.y < 0.0 || uv.y > 1.0));
    if (outside) c = vec4(0.0);
    c = c * m.scale + m.bias;
    if (m.channel >= 0) return vec4(c[m.channel]);
    return c;
}

// The surface a pattern graph is evaluated on, for its nodes that bend the shading
// normal (pattern_lib.glsl pt_bump, pt_normal_map); material_sample sets it.
vec3 pt_N = vec3(0.0, 0.0, 1.0);   // the interpolated normal, facing the viewer
vec3 pt_P = vec3(0.0);             // camera-relative position
vec4 pt_T = vec4(0.0);             // tangent (world) and bitangent sign; 0: none

// A tangent-space vector in the MikkTSpace frame of pt_T and pt_N (bitangent N x T times
// the sign), normalised: a normal map's normal. pt_N without tangents, or for 0.
vec3 tangent_space_normal(vec3 ts) {
    if (!(dot(pt_T.xyz, pt_T.xyz) > 1e-12)) return pt_N;
    vec3 t = normalize(pt_T.xyz);
    vec3 b = cross(pt_N, t) * (pt_T.w < 0.0 ? -1.0 : 1.0);
    vec3 n = t * ts.x + b * ts.y + pt_N * ts.z;
    return dot(n, n) > 1e-12 ? normalize(n) : pt_N;
}
#ifdef PATTERN_NORMAL
in vec3 v_position;                // gbuffer.vert
#endif
#ifdef COLOR_ATTRIBUTE
in vec4 v_color;                   // gbuffer.vert: the mesh's attribute, and its alpha
vec3 pt_color_attribute() { return v_color.rgb; }
float pt_color_alpha() { return v_color.a; }
#else
vec3 pt_color_attribute() { return vec3(0.0); }
float pt_color_alpha() { return 0.0; }
#endif
#ifdef PATTERN_GENERATED
in vec3 v_generated;               // gbuffer.vert: Blender's Generated coordinates
vec3 pt_generated() { return v_generated; }
#else
vec3 pt_generated() { return vec3(0.0); }
#endif

#include "pattern.glsl"

// The surface inputs a pattern graph feeds replace the constants and maps
// (engine/gpu/pattern.py); without one this is the constants.
void pattern_inputs(vec2 uv, inout vec3 diffuse, inout float metallic, inout float roughness,
                    inout float opacity, inout vec3 emissive, inout vec3 normal,
                    inout vec3 sheen, inout float sheen_roughness) {
#ifdef HAS_PATTERN
    pattern_eval(uv, diffuse, metallic, roughness, opacity, emissive, normal, sheen,
                 sheen_roughness);
#endif
}

#ifdef HAS_DIFFUSE_MAP
uniform sampler2D t_diffuse; uniform Map m_diffuse;
#endif
#ifdef HAS_METALLIC_MAP
uniform sampler2D t_metallic; uniform Map m_metallic;
#endif
#ifdef HAS_ROUGHNESS_MAP
uniform sampler2D t_roughness; uniform Map m_roughness;
#endif
#ifdef HAS_EMISSIVE_MAP
uniform sampler2D t_emissive; uniform Map m_emissive;
#endif
#ifdef HAS_OPACITY_MAP
uniform sampler2D t_opacity; uniform Map m_opacity;
#endif
#ifdef HAS_NORMAL_MAP
uniform sampler2D t_normal; uniform Map m_normal;
#endif

float material_alpha(vec2 uv) {
    float alpha = u_opacity;
#ifdef HAS_OPACITY_MAP
    alpha = sample_map(t_opacity, m_opacity, uv).x;
#endif
#ifdef HAS_PATTERN
    vec3 d = vec3(0.0), e = vec3(0.0), n = vec3(0.0), sh = vec3(0.0);
    float mt = 0.0, r = 0.0, sr = 0.0;
    pattern_eval(uv, d, mt, r, alpha, e, n, sh, sr);
#endif
    return alpha;
}

// The material as the G-buffer stores it (float16 ranges: base colour not clamped at 1,
// Cycles takes any value).
struct MaterialSample {
    vec3 base;        // [0, 65000]
    vec3 n;           // world shading normal, facing the viewer
    vec3 smooth_n;    // the same before the normal map; n where no correction applies
    vec4 mat;         // metallic, roughness, dielectric F0, clearcoat
    float coat_roughness;
    vec3 emissive;    // [0, 60000]
    vec4 sheen;       // what g_sheen holds (passes/gbuffer.py sheen_texel): 0 without
};

// normal, tangent: the interpolated vertex attributes (world); front: gl_FrontFacing.
MaterialSample material_sample(vec2 uv, vec3 normal, vec4 tangent, bool front) {
    vec3 base = u_diffuse;
#ifdef HAS_DIFFUSE_MAP
    base = sample_map(t_diffuse, m_diffuse, uv).rgb;
#endif
    float metallic = u_metallic;
#ifdef HAS_METALLIC_MAP
    metallic = sample_map(t_metallic, m_metallic, uv).x;
#endif
    float roughness = u_roughness;
#ifdef HAS_ROUGHNESS_MAP
    roughness = sample_map(t_roughness, m_roughness, uv).x;
#endif
    vec3 emissive = u_emissive;
#ifdef HAS_EMISSIVE_MAP
    emissive = sample_map(t_emissive, m_emissive, uv).rgb;
#endif
    // Back faces only reach here on double-sided meshes: face the viewer.
    vec3 n = normalize(normal);
    if (!front) n = -n;
    vec3 smooth_n = n;
    pt_N = n;
    pt_T = vec4(tangent.xyz - n * dot(n, tangent.xyz), tangent.w);
#ifdef PATTERN_NORMAL
    pt_P = v_position;
#endif
    float opacity = 1.0;
#ifdef MATERIAL_SHEEN
    vec3 sheen = u_sheen.rgb;
    float sheen_mode = sheen_mode_of(u_sheen.a);
    float sheen_roughness = sheen_roughness_of(u_sheen.a);
#else
    vec3 sheen = vec3(0.0);
    float sheen_mode = -1.0, sheen_roughness = 0.0;
#endif
    pattern_inputs(uv, base, metallic, roughness, opacity, emissive, n, sheen, sheen_roughness);
#ifdef HAS_NORMAL_MAP
    n = tangent_space_normal(sample_map(t_normal, m_normal, uv).xyz);
#endif
    if (!u_bump_correction) smooth_n = n;
    float f = (u_ior - 1.0) / (u_ior + 1.0);
    MaterialSample m;
    m.base = clamp(base, 0.0, 65000.0);
    m.n = n;
    m.smooth_n = smooth_n;
    m.mat = vec4(clamp(metallic, 0.0, 1.0), clamp(roughness, 0.0, 1.0), f * f,
                 clamp(u_clearcoat, 0.0, 1.0));
    m.coat_roughness = clamp(u_clearcoat_roughness, 0.0, 1.0);
    m.emissive = clamp(emissive, 0.0, 60000.0);
    // A material without a sheen (alpha < 0) writes none, whatever its network says.
    m.sheen = sheen_mode < 0.0 ? vec4(0.0, 0.0, 0.0, -1.0) :
        vec4(max(sheen, vec3(0.0)), clamp(sheen_roughness, 0.0, 1.0) + 2.0 * sheen_mode);
    return m;
}
