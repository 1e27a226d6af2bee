#version 330 core
// Points prims (particles, point clouds) as spheres, expanded on the GPU: one
// camera-facing quad per point (instanced: 4 vertices from gl_VertexID, the point
// from an instanced attribute; GL 3.3, no geometry shader), sized to cover the
// sphere's silhouette; points.frag ray-casts the sphere in it and writes its true
// depth and normal. The quad faces the frame's origin (the eye, or a radial shadow
// map's light), or, with u_face_axis, runs across u_axis (an orthographic camera, a
// sun's cascade).
#define OBJECT_SINGLE
#include "objects.glsl"
in vec4 in_point;             // position (the prim's space), radius
#ifdef POINTS_COLOUR
in vec3 in_colour;
flat out vec3 v_colour;
#endif
uniform mat4 view_proj;
uniform float u_far;
uniform bool u_face_axis;
uniform vec3 u_axis;          // unit direction from the viewer into the scene
out vec3 v_pos;               // origin-relative position on the quad
flat out vec3 v_center;
flat out float v_radius;
void main() {
    mat4 model = object_model();
    vec3 c = (model * vec4(in_point.xyz, 1.0)).xyz;
    float scale = max(length(model[0].xyz), max(length(model[1].xyz), length(model[2].xyz)));
    float r = in_point.w * scale;
    vec3 f = u_face_axis ? u_axis : c;
    float dist = length(f);
    f = dist > 0.0 ? f / dist : vec3(0.0, 0.0, -1.0);
    vec3 up = abs(f.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
    vec3 right = normalize(cross(f, up));
    up = cross(right, f);
    // The silhouette of a sphere seen from a point at `dist` is a circle of radius
    // r dist / sqrt(dist^2 - r^2) in the plane through its centre.
    float h = r;
    if (!u_face_axis)
        h = dist > r ? r * dist / sqrt(dist * dist - r * r) : 0.0;   // viewer inside: nothing
    vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1)) * 2.0 - 1.0;
    v_pos = c + (right * corner.x + up * corner.y) * h;
    v_center = c;
    v_radius = r;
#ifdef POINTS_COLOUR
    v_colour = in_colour;
#endif
    gl_Position = view_proj * vec4(v_pos, 1.0);
    gl_ClipDistance[0] = u_far - gl_Position.w;
}
