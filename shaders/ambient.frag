#version 330 core
#include "lib.glsl"
// Full screen, once: dome lighting (environment.glsl), emission, and the dome as the
// background where nothing was drawn. Positions are camera-relative (lib.glsl): the
// viewer is at the origin.
uniform sampler2D g_base;
uniform sampler2D g_normal;
uniform sampler2D g_mat;
uniform sampler2D g_emit;
uniform sampler2D g_depth;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;
uniform bool transparent;
#include "environment.glsl"

out vec4 frag;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(g_depth, px, 0).r;
    vec2 uv = (vec2(px) + 0.5) / vec2(textureSize(g_depth, 0));
    if (is_background(depth)) {
        vec3 bg = vec3(0.0);
        if (has_dome && !transparent)
            bg = dome(pixel_ray(uv, inv_view_proj, cam_ortho, cam_forward));
        frag = vec4(finite(bg), 0.0);
        return;
    }
    vec3 p = position_from_depth(uv, depth, inv_view_proj);
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    Surface s = make_surface(p, n, v, texelFetch(g_base, px, 0), texelFetch(g_mat, px, 0));
    vec3 c = texelFetch(g_emit, px, 0).rgb + environment_radiance(s);
    frag = vec4(finite(c), 0.0);
}
