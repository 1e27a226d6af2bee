#version 430 core
#include "skinning.glsl"
// The skinning pass's compute form (GL 4.3): one invocation per vertex of a skinned
// mesh, deformed by skinning.glsl (the body skin.vert shares) and written straight into
// the mesh's place in the dynamic store (or a skinned cage's buffer), 12 floats a vertex
// in the static layout: position, normal, uv, tangent. With SKIN_SURFACE_NORMALS it runs
// again on the deformed vertices in place, rewriting only normals and tangents (the
// positions it reads from other vertices are not written by any invocation).
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Deformed { float deformed[]; };
layout(std430, binding = 1) readonly buffer Rest { float rest[]; };
layout(std430, binding = 2) readonly buffer Attributes { int attributes[]; };
uniform int u_vertices;
uniform int u_first;              // the mesh's first float in `deformed`
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
vec3 deformed_position(int v) {
    int i = u_first + 12 * v;
    return vec3(deformed[i], deformed[i + 1], deformed[i + 2]);
}
#endif

void main() {
    // Two dimensions: past 65,535 groups of 64 (4.2 million vertices) a row is full.
    int v = int(gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x +
                gl_GlobalInvocationID.x);
    if (v >= u_vertices) return;
    vertex_index = v;
    int point = attributes[v * u_attribute_stride];
    int o = u_first + 12 * v;
#ifdef SKIN_SURFACE_NORMALS
    vec3 n;
    vec3 t = vec3(deformed[o + 8], deformed[o + 9], deformed[o + 10]);
    surface_frame(point, n, t);
    deformed[o + 3] = n.x; deformed[o + 4] = n.y; deformed[o + 5] = n.z;
    deformed[o + 8] = t.x; deformed[o + 9] = t.y; deformed[o + 10] = t.z;
#else
    int r = 12 * v;
    vec3 p = vec3(rest[r], rest[r + 1], rest[r + 2]);
    vec3 n = vec3(rest[r + 3], rest[r + 4], rest[r + 5]);
    vec3 t = vec3(rest[r + 8], rest[r + 9], rest[r + 10]);
    skin_vertex(point, p, n, t);
    deformed[o] = p.x; deformed[o + 1] = p.y; deformed[o + 2] = p.z;
    deformed[o + 3] = n.x; deformed[o + 4] = n.y; deformed[o + 5] = n.z;
    deformed[o + 6] = rest[r + 6]; deformed[o + 7] = rest[r + 7];
    deformed[o + 8] = t.x; deformed[o + 9] = t.y; deformed[o + 10] = t.z;
    deformed[o + 11] = rest[r + 11];
#endif
}
