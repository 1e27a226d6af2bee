#version 330 core
#include "lib.glsl"
// G-buffer: RT0 base colour + alpha, RT1 world normal, RT2 metallic / roughness /
// dielectric F0 / 1, RT3 emission.
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
layout(location = 0) out vec4 rt_base;
layout(location = 1) out vec4 rt_normal;
layout(location = 2) out vec4 rt_mat;
layout(location = 3) out vec4 rt_emit;
#ifdef WRITE_INDEX
// Render passes IndexOB and IndexMA (asked for only).
layout(location = 4) out vec2 rt_index;
flat in float v_object_index;
uniform float u_material_index;
#endif

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

void main() {
    float alpha = u_opacity;
#ifdef HAS_OPACITY_MAP
    alpha = sample_map(t_opacity, m_opacity, v_uv).x;
#endif
    if (u_opacity_threshold > 0.0 && alpha < u_opacity_threshold) discard;

    vec3 base = u_diffuse;
#ifdef HAS_DIFFUSE_MAP
    base = sample_map(t_diffuse, m_diffuse, v_uv).rgb;
#endif
    float metallic = u_metallic;
#ifdef HAS_METALLIC_MAP
    metallic = sample_map(t_metallic, m_metallic, v_uv).x;
#endif
    float roughness = u_roughness;
#ifdef HAS_ROUGHNESS_MAP
    roughness = sample_map(t_roughness, m_roughness, v_uv).x;
#endif
    vec3 emissive = u_emissive;
#ifdef HAS_EMISSIVE_MAP
    emissive = sample_map(t_emissive, m_emissive, v_uv).rgb;
#endif

    // Back faces only reach here on double-sided meshes: face the viewer.
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
#ifdef HAS_NORMAL_MAP
    vec3 t = v_tangent.xyz - n * dot(n, v_tangent.xyz);
    if (dot(t, t) > 1e-12) {
        t = normalize(t);
        vec3 b = cross(n, t) * (v_tangent.w < 0.0 ? -1.0 : 1.0);
        vec3 ts = sample_map(t_normal, m_normal, v_uv).xyz;
        vec3 mapped = t * ts.x + b * ts.y + n * ts.z;
        if (dot(mapped, mapped) > 1e-12) n = normalize(mapped);
    }
#endif
    float f = (u_ior - 1.0) / (u_ior + 1.0);
    rt_base = vec4(clamp(base, 0.0, 1.0), alpha);
    rt_normal = vec4(n, 1.0);
    rt_mat = vec4(clamp(metallic, 0.0, 1.0), clamp(roughness, 0.0, 1.0), f * f, 1.0);
    rt_emit = vec4(clamp(emissive, 0.0, 60000.0), 1.0);  // float16 target
#ifdef WRITE_INDEX
    rt_index = vec2(v_object_index, u_material_index);
#endif
}
