#version 330 core
// Points prims (particles, point clouds) as spheres, and curves as round tubes,
// expanded on the GPU: one quad per point or per straight piece of a curve
// (instanced: 4 vertices from gl_VertexID, the primitive from instanced attributes;
// GL 3.3, no geometry shader), sized to cover its silhouette; points.frag ray-casts
// the sphere, or the spheres swept between a piece's two ends (POINTS_SEGMENT), in it
// and writes their true depth and normal. Each end's corners face the frame's origin
// (the eye, or a radial shadow map's light), or, with u_face_axis, run across u_axis
// (an orthographic camera, a sun's cascade).
#define OBJECT_SINGLE
#include "objects.glsl"
in vec4 in_point;             // position (the prim's space), radius
#ifdef POINTS_SEGMENT
in vec4 in_point_b;           // the piece's other end
#endif
#ifdef POINTS_COLOUR
in vec3 in_colour;
flat out vec3 v_colour;
#endif
uniform mat4 view_proj;
uniform float u_far;
uniform bool u_face_axis;
uniform vec3 u_axis;          // unit direction from the viewer into the scene
out vec3 v_pos;               // origin-relative position on the quad
flat out vec4 v_a;            // origin-relative centre and radius of the first end
flat out vec4 v_b;            // of the second (a point: the same)

// Half the width a sphere of radius r at c covers, measured in the plane through c
// that faces the viewer: its silhouette seen from a point at distance d is a circle
// of radius r d / sqrt(d^2 - r^2) there (0 when the viewer is inside).
float silhouette(vec3 c, float r) {
    if (u_face_axis) return r;
    float d = length(c);
    return d > r ? r * d / sqrt(d * d - r * r) : 0.0;
}

vec3 facing(vec3 c) {
    vec3 f = u_face_axis ? u_axis : c;
    float d = length(f);
    return d > 0.0 ? f / d : vec3(0.0, 0.0, -1.0);
}

void main() {
    mat4 model = object_model();
    float scale = max(length(model[0].xyz), max(length(model[1].xyz), length(model[2].xyz)));
    vec3 a = (model * vec4(in_point.xyz, 1.0)).xyz;
    float ra = in_point.w * scale;
#ifdef POINTS_SEGMENT
    vec3 b = (model * vec4(in_point_b.xyz, 1.0)).xyz;
    float rb = in_point_b.w * scale;
#else
    vec3 b = a;
    float rb = ra;
#endif
    // Vertex 0, 2 at the first end, 1, 3 at the second; 0, 1 on one side, 2, 3 on
    // the other. Each end's corners lie in the plane facing the viewer there, pushed
    // out past the end along the piece and to the wider end's width on both sides,
    // so the quad holds both ends' silhouettes and the cone between them.
    bool second = (gl_VertexID & 1) == 1;
    float side = float(gl_VertexID >> 1) * 2.0 - 1.0;
    vec3 c = second ? b : a;
    vec3 f = facing(c);
    vec3 across = cross(f, b - a);
    if (dot(across, across) <= 1e-12 * max(dot(b - a, b - a), 1e-30)) {
        vec3 up = abs(f.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
        across = cross(f, up);           // a point, or a piece seen end on
    }
    across = normalize(across);
    vec3 along = cross(across, f);       // the piece's direction, in the facing plane
    float ha = silhouette(a, ra), hb = silhouette(b, rb);
    float h = max(ha, hb);
    if (ha == 0.0 || hb == 0.0) h = 0.0; // viewer inside an end: nothing
    v_pos = c + along * (second ? h : -h) + across * side * h;
    v_a = vec4(a, ra);
    v_b = vec4(b, rb);
#ifdef POINTS_COLOUR
    v_colour = in_colour;
#endif
    gl_Position = view_proj * vec4(v_pos, 1.0);
    gl_ClipDistance[0] = u_far - gl_Position.w;
}
