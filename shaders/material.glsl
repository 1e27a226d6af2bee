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
uniform float u_transmission;      // Material.transmission: glass (the base colour tints it)
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
// Texture lookups (sample_map): the most probes one takes along a long footprint (the
// preset's anisotropy), and the pixel filter that lookups of an image not
// supersampled filter with: Cycles' (engine/gpu/passes/antialias.py BLACKMAN_HARRIS,
// its cosine terms, and its reach in pixels); reach 0 in a supersampled image, whose
// pixel filter comes after (passes/antialias.py downsample_taps).
uniform float u_max_anisotropy = 16.0;
uniform vec4 u_pixel_filter = vec4(0.0);
uniform float u_pixel_filter_reach = 0.0;

float pixel_filter(float x) {
    float t = 3.14159265 * (x / u_pixel_filter_reach + 1.0);
    return dot(u_pixel_filter, vec4(1.0, cos(t), cos(2.0 * t), cos(3.0 * t)));
}

// A UsdUVTexture: wrap (0 repeat, 1 mirror, 2 clamp, 3 black), scale, bias, channel
// (-1 rgb, 0..3 r g b a), filtertype (0 linear, 1 closest, 2 cubic, 3 smart:
// core/images.py FILTERTYPES). srgb: an 8-bit sRGB image, which Cycles interpolates
// in its stored (encoded) values and then decodes (engine/gpu/textures.py).
struct Map { ivec2 wrap; vec4 scale; vec4 bias; int channel; bool srgb; int filtertype; };

float wrap1(float x, int mode) {
    if (mode == 1) return 1.0 - abs(mod(x, 2.0) - 1.0);
    return x;
}

// Repeat without integer division, which CPU rasterisers (llvmpipe) run lane by lane:
// i + 0.5 keeps the quotient off whole numbers, so floor cannot round across one.
int wrap_texel(int i, int n, int mode) {
    return mode == 0 ? i - n * int(floor((float(i) + 0.5) / float(n))) : clamp(i, 0, n - 1);
}

// The 8-bit value an sRGB image stores, from GL's decoding of it: the encoding as a
// cubic in the fourth root (within 0.06 of a step of the exact curve, 1.055 c^(1/2.4)
// - 0.055, over every 8-bit value), rounded to the step. Exact, and cheaper than pow,
// which the probes below would take 36 times a lookup. Values of 10 and under are on
// the curve's linear segment.
vec3 stored_value(vec3 c) {
    vec3 q = sqrt(sqrt(c));
    vec3 e = ((-0.13683543 * q + 0.95259386) * q + 0.2557853) * q - 0.07175894;
    e = mix(e, 12.92 * c, vec3(lessThanEqual(c, vec3(0.0031308))));
    return floor(e * 255.0 + 0.5) * (1.0 / 255.0);
}

// Texel i of `level` (of n texels), wrapped; `encoded`: as stored in an sRGB image
// (GL's fetch decodes it). Probes below fetch texels rather than filter: on llvmpipe a
// sampler with anisotropy filters textureLod and textureGrad with derivatives of its
// own, whatever level or gradients they name.
vec4 texel(sampler2D t, Map m, ivec2 i, ivec2 n, int level, bool encoded) {
    vec4 c = texelFetch(t, ivec2(wrap_texel(i.x, n.x, m.wrap.x), wrap_texel(i.y, n.y, m.wrap.y)), level);
    if (encoded) c.rgb = stored_value(c.rgb);
    return c;
}

vec4 decoded(vec4 c, bool encoded) { return encoded ? vec4(srgb_to_linear(c.rgb), c.a) : c; }

// Cycles' closest (the texel of level 0 under w) averaged over a box reaching `box`
// texels either way, as the pixel filter averages its many point lookups: the texels'
// sides stay sharp where the box is a point, and blend by how much of each texel the
// box covers (reaching half a texel, bilinear).
vec4 closest0(sampler2D t, Map m, vec2 w, vec2 box) {
    ivec2 n = textureSize(t, 0);
    vec2 f = w * vec2(n) - 0.5;
    ivec2 i = ivec2(floor(f));
    vec2 a = clamp((f - vec2(i) - 0.5) / max(2.0 * box, 1e-6) + 0.5, 0.0, 1.0);
    return mix(mix(texel(t, m, i, n, 0, false), texel(t, m, i + ivec2(1, 0), n, 0, false), a.x),
               mix(texel(t, m, i + ivec2(0, 1), n, 0, false), texel(t, m, i + ivec2(1, 1), n, 0, false), a.x),
               a.y);
}

// Cycles' linear lookup at w in `level`: bilinear over four texels; of an 8-bit sRGB
// image's level 0, over the stored (encoded) values, then decoded.
vec4 bilinear(sampler2D t, Map m, vec2 w, int level) {
    bool e = m.srgb && level == 0;
    ivec2 n = textureSize(t, level);
    vec2 f = w * vec2(n) - 0.5;
    ivec2 i = ivec2(floor(f));
    vec2 a = f - vec2(i);
    return decoded(mix(mix(texel(t, m, i, n, level, e), texel(t, m, i + ivec2(1, 0), n, level, e), a.x),
                       mix(texel(t, m, i + ivec2(0, 1), n, level, e), texel(t, m, i + ivec2(1, 1), n, level, e), a.x),
                       a.y), e);
}

// Cycles' cubic B-spline weights of the taps i - 1 .. i + 2 at fraction a.
vec4 bspline_weights(float a) {
    float b = 1.0 - a;
    return vec4(b * b * b, 4.0 - 6.0 * a * a + 3.0 * a * a * a,
                4.0 - 6.0 * b * b + 3.0 * b * b * b, a * a * a) * (1.0 / 6.0);
}

// Cycles' cubic lookup at w in `level`: the B-spline over 4 x 4 texels (of an sRGB
// image's level 0, over the stored values, then decoded).
vec4 bspline(sampler2D t, Map m, vec2 w, int level) {
    bool e = m.srgb && level == 0;
    ivec2 n = textureSize(t, level);
    vec2 f = w * vec2(n) - 0.5;
    vec2 i = floor(f);
    vec4 wx = bspline_weights(f.x - i.x), wy = bspline_weights(f.y - i.y);
    vec4 c = vec4(0.0);
    for (int y = 0; y < 4; ++y) {
        vec4 row = vec4(0.0);
        for (int x = 0; x < 4; ++x)
            row += wx[x] * texel(t, m, ivec2(i) + ivec2(x - 1, y - 1), n, level, e);
        c += wy[y] * row;
    }
    return decoded(c, e);
}

// The image's interpolation at w in `level`: Closest (level 0 only, averaged over
// `box`), Cubic, else Linear. Closest and Cubic are compiled in only where one of the
// program's images has them (FILTER_CLOSEST, FILTER_CUBIC: engine/gpu/passes/gbuffer.py
// FILTER_DEFINES): llvmpipe runs every branch, masked, so a Linear image's probes
// would pay for the other two.
vec4 interpolated(sampler2D t, Map m, vec2 w, int level, vec2 box, bool cubic) {
#ifdef FILTER_CLOSEST
    if (m.filtertype == 1 && level == 0) return closest0(t, m, w, box);
#endif
#ifdef FILTER_CUBIC
    if (cubic) return bspline(t, m, w, level);
#endif
    return bilinear(t, m, w, level);
}

// One probe at w, of a lookup whose footprint is under two texels (`minified`: over
// one): the image's interpolation at level 0, blended towards level 1 by `lod` (in
// [0, 1)) as trilinear filtering blends (levels 1 and deeper of an sRGB image hold
// averages of Cycles' own lookups: engine/gpu/textures.py cycles_srgb_mips), Linear
// there but for Cubic. `box`: how far the probe's box reaches either way, in texels of
// level 0, which Closest averages its nearest texels over (sharp where magnified).
// Smart is Cubic where magnified and Linear where not.
vec4 near_probe(sampler2D t, Map m, vec2 w, float lod, vec2 box, bool minified) {
    bool cubic = m.filtertype == 2 || (m.filtertype == 3 && !minified);
    vec4 c = interpolated(t, m, w, 0, min(box, vec2(0.5)), cubic);
    if (lod <= 0.0) return c;
    return mix(c, interpolated(t, m, w, 1, box, m.filtertype == 2), lod);
}

// A texture lookup at uv, as Cycles' pixel filter averages the image's interpolation
// (Cycles reads textures at points, without mip levels). A linear lookup of data (not
// an 8-bit sRGB colour) is GL's: GL filters in linear values as Cycles does. Else,
// where the footprint is two texels or more along its shorter side (or its share of
// the longer), GL filters levels 1 and deeper, trilinear and anisotropic: their
// texels are the averages Cycles would make (an sRGB image's: engine/gpu/textures.py
// cycles_srgb_mips), and the sampler keeps GL off level 0 (textures.py sampler).
// Under that the shader reads level 0 itself, through the image's interpolation
// (near_probe): in an image not supersampled, with the pixel filter's weights on a
// grid of probes a texel or less apart; in a supersampled one, over its sub-pixel,
// with probes along the footprint's longer side as GL's anisotropic filter takes
// them (EXT_texture_filter_anisotropic), and the pixel filter after.
vec4 sample_map(sampler2D t, Map m, vec2 uv) {
    // Gradients from the unwrapped st so mirror folds do not spike the level.
    vec2 dx = dFdx(uv), dy = dFdy(uv);
    vec2 n = vec2(textureSize(t, 0));
    float lx = length(dx * n), ly = length(dy * n);            // texels per fragment
    float major = max(lx, ly), minor = min(lx, ly);
    float cap = max(u_max_anisotropy, 1.0);
    float count = clamp(ceil(major / max(minor, 1e-8)), 1.0, cap);
    float lod = log2(max(major / count, 1e-8));
    vec4 c = vec4(0.0);
    if (lod >= 1.0 || (m.filtertype == 0 && !m.srgb)) {
        c = textureGrad(t, vec2(wrap1(uv.x, m.wrap.x), wrap1(uv.y, m.wrap.y)), dx, dy);
    } else if (u_pixel_filter_reach > 0.0) {
        // Closest's texels are squares with sharp sides, which the pixel filter
        // blurs over its reach however large the texels: four probes at least.
        float reach = u_pixel_filter_reach;
        float least = m.filtertype == 1 ? 4.0 : 1.0;
        // (Two probes would sit at +-0.75 px, twice the filter's spread: three.)
        ivec2 k = ivec2(clamp(ceil(2.0 * reach * vec2(lx, ly)), vec2(least), vec2(4.0 * cap)));
        k += ivec2(equal(k, ivec2(2)));
        vec2 cell = reach / vec2(k);               // how far a probe's box reaches, pixels
        vec2 box = (abs(dx) * cell.x + abs(dy) * cell.y) * n;
        float total = 0.0;
        for (int j = 0; j < k.y; ++j)
            for (int i = 0; i < k.x; ++i) {
                vec2 o = reach * ((2.0 * vec2(i, j) + 1.0) / vec2(k) - 1.0);   // in pixels
                float weight = pixel_filter(o.x) * pixel_filter(o.y);
                vec2 p = uv + dx * o.x + dy * o.y;
                c += weight * near_probe(t, m, vec2(wrap1(p.x, m.wrap.x), wrap1(p.y, m.wrap.y)),
                                         0.0, box, lod > 0.0);
                total += weight;
            }
        c /= total;
    } else {
        bool along_x = lx >= ly;
        vec2 axis = along_x ? dx : dy;
        vec2 box = 0.5 * (abs(axis) / count + abs(along_x ? dy : dx)) * n;
        for (int i = 0; i < int(count); ++i) {
            vec2 p = uv + axis * ((float(i) + 0.5) / count - 0.5);
            c += near_probe(t, m, vec2(wrap1(p.x, m.wrap.x), wrap1(p.y, m.wrap.y)),
                            max(lod, 0.0), box, lod > 0.0);
        }
        c /= count;
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
