#version 430 core
// A skinned subdivision cage's Bezier control points, made again after each pose: each
// a weighted sum of the cage's deformed points (engine/bezier_patches.py
// patch_stencils, CSR). The cage is the skinning pass's output (12 floats a vertex,
// position first); the control points go where the tessellation pass reads them.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Cage { float cage[]; };
layout(std430, binding = 1) readonly buffer Rows { int row_start[]; };
layout(std430, binding = 2) readonly buffer Points { int point[]; };
layout(std430, binding = 3) readonly buffer Weights { float weight[]; };
layout(std430, binding = 4) writeonly buffer Control { float control[]; };
uniform int n;

void main() {
    int k = int(gl_GlobalInvocationID.x);
    if (k >= n)
        return;
    vec3 p = vec3(0.0);
    for (int j = row_start[k]; j < row_start[k + 1]; ++j) {
        int i = 12 * point[j];
        p += weight[j] * vec3(cage[i], cage[i + 1], cage[i + 2]);
    }
    control[3 * k] = p.x;
    control[3 * k + 1] = p.y;
    control[3 * k + 2] = p.z;
}
