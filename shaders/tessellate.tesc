#version 410 core
// Tessellation levels from the camera's view: each patch edge's two corners projected
// to pixels, its length over the target, rounded up, at most u_cap. A corner is the
// same three floats in every patch that shares it, and the length is symmetric in the
// two, so both patches along an edge cut it alike: the surface has no cracks. A corner
// behind the camera takes the cap (shadow maps see what the camera does not).
layout(vertices = 16) out;
in vec3 c_pos[];
in vec2 c_uv[];
out vec3 e_pos[];
out vec2 e_uv[];
uniform mat4 u_mvp;          // object -> the camera's clip space
uniform vec2 u_half_size;    // half the image, pixels
uniform float u_target_px;   // pixels per segment of an edge
uniform float u_cap;

float edge_level(int a, int b) {
    vec4 pa = u_mvp * vec4(c_pos[a], 1.0);
    vec4 pb = u_mvp * vec4(c_pos[b], 1.0);
    if (pa.w <= 1e-6 || pb.w <= 1e-6)
        return u_cap;
    float px = length((pa.xy / pa.w - pb.xy / pb.w) * u_half_size);
    return clamp(ceil(px / u_target_px), 1.0, u_cap);
}

void main() {
    e_pos[gl_InvocationID] = c_pos[gl_InvocationID];
    e_uv[gl_InvocationID] = c_uv[gl_InvocationID];
    if (gl_InvocationID == 0) {
        // Corners: 0 (u 0, v 0), 3 (1, 0), 15 (1, 1), 12 (0, 1). Outer 0..3 are the
        // edges u = 0, v = 0, u = 1, v = 1.
        float left = edge_level(0, 12), bottom = edge_level(0, 3);
        float right = edge_level(3, 15), top = edge_level(12, 15);
        gl_TessLevelOuter[0] = left;
        gl_TessLevelOuter[1] = bottom;
        gl_TessLevelOuter[2] = right;
        gl_TessLevelOuter[3] = top;
        gl_TessLevelInner[0] = max(bottom, top);
        gl_TessLevelInner[1] = max(left, right);
    }
}
