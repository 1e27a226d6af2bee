#version 330 core
// The skinning pass's surface-normal sum: each deformed triangle sends its area
// normal (unnormalised cross product, as engine/usd/mesh.py's smooth normals) to the
// texel of each of its three points, where additive blending sums them. The texture
// is laid out as the flat per-point textures (engine/skin.py FLAT_TEX_W wide).
layout(triangles) in;
layout(points, max_vertices = 3) out;
in vec3 v_pos[];
flat in int v_point[];
out vec3 g_area_normal;
uniform vec2 u_texels;   // the target's width and height
const int FLAT_TEX_W = 4096;
void main() {
    vec3 area_normal = cross(v_pos[1] - v_pos[0], v_pos[2] - v_pos[0]);
    for (int i = 0; i < 3; ++i) {
        int k = v_point[i];
        vec2 texel = vec2(k % FLAT_TEX_W, k / FLAT_TEX_W) + 0.5;
        gl_Position = vec4(texel / u_texels * 2.0 - 1.0, 0.0, 1.0);
        g_area_normal = area_normal;
        EmitVertex();
        EndPrimitive();
    }
}
