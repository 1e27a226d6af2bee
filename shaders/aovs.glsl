#include "lib.glsl"
// Render passes from the G-buffer, one per variant (engine/gpu/passes/aovs.py; a screen
// pass's body, engine/gpu/screen.py):
// AOV_DEPTH   distance from the camera plane along the view axis (Blender's Depth)
// AOV_NORMAL  world normal
// AOV_EMIT    emitted radiance
uniform sampler2D g_depth;
uniform sampler2D g_normal;
uniform sampler2D g_emit;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform float background_depth;

void screen_pixel(ivec2 px, out vec4 frag, out vec4 unused1, out vec4 unused2,
                  out vec4 unused3) {
    unused1 = unused2 = unused3 = vec4(0.0);
    float depth = texelFetch(g_depth, px, 0).r;
    bool background = is_background(depth);
#ifdef AOV_DEPTH
    vec2 uv = (vec2(px) + 0.5) / vec2(textureSize(g_depth, 0));
    vec3 p = position_from_depth(uv, depth, inv_view_proj);     // camera-relative
    frag = vec4(background ? background_depth : dot(p, cam_forward), 0.0, 0.0, 0.0);
#endif
#ifdef AOV_NORMAL
    vec3 n = texelFetch(g_normal, px, 0).xyz;
    frag = vec4(background ? vec3(0.0) : normalize(n), 0.0);
#endif
#ifdef AOV_EMIT
    frag = vec4(background ? vec3(0.0) : texelFetch(g_emit, px, 0).rgb, 0.0);
#endif
}
