#version 410 core
// Tessellation levels from the camera's view: each patch edge's two corners projected
// to pixels, its length over the target, rounded up, at most u_cap. A curved edge is
// cut finer, into pieces that turn by at most u_turn radians (its Bezier curve's end
// tangents), but none shorter than a pixel: shading interpolates the normals across
// a triangle, and on a fold a few pixels wide a 4-pixel triangle shows. An edge's
// four control points are the same floats in every patch that shares it, and length
// and turn are symmetric in its two ends, so both patches along an edge cut it alike:
// the surface has no cracks. A corner behind the camera takes the cap (shadow maps
// see what the camera does not).
layout(vertices = 16) out;
in vec3 c_pos[];
in vec2 c_uv[];
out vec3 e_pos[];
out vec2 e_uv[];
uniform mat4 u_mvp;          // object -> the camera's clip space
uniform vec2 u_half_size;    // half the image, pixels
uniform float u_target_px;   // pixels per segment of an edge
uniform float u_cap;
uniform float u_turn;        // radians an edge's piece may turn

// The angle between two tangents; 0 where one vanishes (an edge that pinches).
float turn(vec3 s, vec3 t) {
    float l = length(s) * length(t);
    return l > 0.0 ? acos(clamp(dot(s, t) / l, -1.0, 1.0)) : 0.0;
}

// The edge from corner a to corner b, a1 and b1 its inner control points.
float edge_level(int a, int a1, int b1, int b) {
    vec4 pa = u_mvp * vec4(c_pos[a], 1.0);
    vec4 pb = u_mvp * vec4(c_pos[b], 1.0);
    if (pa.w <= 1e-6 || pb.w <= 1e-6)
        return u_cap;
    float px = length((pa.xy / pa.w - pb.xy / pb.w) * u_half_size);
    float curved = min(ceil(turn(c_pos[a1] - c_pos[a], c_pos[b] - c_pos[b1]) / u_turn), ceil(px));
    return clamp(max(ceil(px / u_target_px), curved), 1.0, u_cap);
}

void main() {
    e_pos[gl_InvocationID] = c_pos[gl_InvocationID];
    e_uv[gl_InvocationID] = c_uv[gl_InvocationID];
    if (gl_InvocationID == 0) {
        // Corners: 0 (u 0, v 0), 3 (1, 0), 15 (1, 1), 12 (0, 1). Outer 0..3 are the
        // edges u = 0, v = 0, u = 1, v = 1.
        float left = edge_level(0, 4, 8, 12), bottom = edge_level(0, 1, 2, 3);
        float right = edge_level(3, 7, 11, 15), top = edge_level(12, 13, 14, 15);
        gl_TessLevelOuter[0] = left;
        gl_TessLevelOuter[1] = bottom;
        gl_TessLevelOuter[2] = right;
        gl_TessLevelOuter[3] = top;
        gl_TessLevelInner[0] = max(bottom, top);
        gl_TessLevelInner[1] = max(left, right);
    }
}
