#version 410 core
// A subdivision surface's Bezier control points (engine/bezier_patches.py), 16 per
// patch, each with its UV control point (the UVs' own patch).
in vec3 in_pos;
in vec2 in_uv;
out vec3 c_pos;
out vec2 c_uv;
void main() {
    c_pos = in_pos;
    c_uv = in_uv;
}
