// A UsdPreviewSurface material at one fragment: its constants (uniforms), its maps
// (UsdUVTexture: wrap, scale, bias, channel; one sampler per mapped input, present
// only in the variants that map it: HAS_*_MAP), and the shading normal. Shared by the
// G-buffer, the transparency pass and the shadow casters' alpha test, so a material
// reads the same wherever it is drawn.
uniform vec3 u_diffuse;
uniform float u_metallic;
uniform float u_roughness;
uniform float u_ior;
uniform vec3 u_emissive;
uniform float u_opacity;
uniform float u_opacity_threshold;

// A UsdUVTexture: wrap (0 repeat, 1 mirror, 2 clamp, 3 black), scale, bias, channel
// (-1 rgb, 0..3 r g b a).
struct Map { ivec2 wrap; vec4 scale; vec4 bias; int channel; };

float wrap1(float x, int mode) {
    if (mode == 1) return 1.0 - abs(mod(x, 2.0) - 1.0);
    return x;
}

vec4 sample_map(sampler2D t, Map m, vec2 uv) {
    // Gradients from the unwrapped st so mirror folds do not spike the mip level.
    vec2 dx = dFdx(uv), dy = dFdy(uv);
    vec2 w = vec2(wrap1(uv.x, m.wrap.x), wrap1(uv.y, m.wrap.y));
    vec4 c = textureGrad(t, w, dx, dy);
    bool outside = (m.wrap.x == 3 && (uv.x < 0.0 || uv.x > 1.0)) ||
                   (m.wrap.y == 3 && (uv.y < 0.0 || uv.y > 1.0));
    if (outside) c = vec4(0.0);
    c = c * m.scale + m.bias;
    if (m.channel >= 0) return vec4(c[m.channel]);
    return c;
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
    return alpha;
}

struct MaterialSample {
    vec3 base;        // clamped to [0, 1]
    float metallic;   // clamped to [0, 1]
    float roughness;  // clamped to [0, 1]
    float f0;         // dielectric F0 from the IOR
    vec3 emissive;    // clamped to the float16 range
    vec3 n;           // world shading normal, facing the viewer
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
#ifdef HAS_NORMAL_MAP
    vec3 t = tangent.xyz - n * dot(n, tangent.xyz);
    if (dot(t, t) > 1e-12) {
        t = normalize(t);
        vec3 b = cross(n, t) * (tangent.w < 0.0 ? -1.0 : 1.0);
        vec3 ts = sample_map(t_normal, m_normal, uv).xyz;
        vec3 mapped = t * ts.x + b * ts.y + n * ts.z;
        if (dot(mapped, mapped) > 1e-12) n = normalize(mapped);
    }
#endif
    float f = (u_ior - 1.0) / (u_ior + 1.0);
    MaterialSample m;
    m.base = clamp(base, 0.0, 1.0);
    m.metallic = clamp(metallic, 0.0, 1.0);
    m.roughness = clamp(roughness, 0.0, 1.0);
    m.f0 = f * f;
    m.emissive = clamp(emissive, 0.0, 60000.0);  // float16 targets
    m.n = n;
    return m;
}
