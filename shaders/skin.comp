#version 430 core
#include "skinning.glsl"
// The skinning pass's compute form (GL 4.3): one invocation per vertex of a skinned
// mesh, deformed by skinning.glsl (the body skin.vert shares) and written straight into
// the mesh's place in the dynamic store (or a skinned cage's buffer), 12 floats a vertex
// in the static layout: position, normal, uv, tangent. With SKIN_SURFACE_NORMALS it runs
// again on the deformed vertices in place, rewriting only normals and tangents (the
// positions it reads from other vertices are not written by any invocation).
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Deformed { vec4 deformed[]; };
layout(std430, binding = 1) readonly buffer Rest { vec4 rest[]; };
layout(std430, binding = 2) readonly buffer Attributes { int attributes[]; };
uniform int u_vertices;
uniform int u_first;              // the mesh's first texel (4 floats) in `deformed`
uniform int u_attribute_stride;   // ints per vertex in `attributes`: its point, influences

int vertex_index;                 // this invocation's vertex

#if defined(SKIN_JOINTS) && !defined(SKIN_JOINTS_TEX)
void vertex_influences(int h, out ivec4 j, out vec4 w) {
    int i = vertex_index * u_attribute_stride + 1 + 8 * h;
    j = ivec4(attributes[i], attributes[i + 1], attributes[i + 2], attributes[i + 3]);
    w = intBitsToFloat(ivec4(attributes[i + 4], attributes[i + 5], attributes[i + 6],
                             attributes[i + 7]));
}
#endif

#ifdef SKIN_SURFACE_NORMALS
vec3 deformed_position(int v) { return deformed[u_first + 3 * v].xyz; }
#endif

void main() {
    // Two dimensions: past 65,535 groups of 64 (4.2 million vertices) a row is full.
    int v = int(gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x +
                gl_GlobalInvocationID.x);
    if (v >= u_vertices) return;
    vertex_index = v;
    int point = attributes[v * u_attribute_stride];
    // A vertex is 3 texels: (position, normal.x), (normal.yz, uv), tangent.
    int o = u_first + 3 * v;
#ifdef SKIN_SURFACE_NORMALS
    vec4 a = deformed[o], b = deformed[o + 1], c = deformed[o + 2];
    vec3 n, t = c.xyz;
    surface_frame(point, n, t);
    // Only this vertex's normal and tangent: positions are what the others read.
    deformed[o].w = n.x;
    deformed[o + 1].xy = n.yz;
    deformed[o + 2].xyz = t;
#else
    vec4 a = rest[3 * v], b = rest[3 * v + 1], c = rest[3 * v + 2];
    vec3 p = a.xyz, n = vec3(a.w, b.xy), t = c.xyz;
    skin_vertex(point, p, n, t);
    deformed[o] = vec4(p, n.x);
    deformed[o + 1] = vec4(n.yz, b.zw);
    deformed[o + 2] = vec4(t, c.w);
#endif
}
