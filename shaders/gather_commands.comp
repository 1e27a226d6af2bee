#version 430
// The GL 4.3 path's view: copies the visible draw commands, in draw order, from the
// buffer of all commands into the indirect buffer (engine/gpu/geometry.py), so a view
// uploads 4 bytes per visible command instead of the 20 of the command itself.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer AllCommands { uint all_commands[]; };
layout(std430, binding = 1) readonly buffer Order { uint order[]; };
layout(std430, binding = 2) writeonly buffer Indirect { uint indirect[]; };
uniform uint n;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= n) return;
    uint src = order[i] * 5u;
    for (uint k = 0u; k < 5u; ++k) indirect[i * 5u + k] = all_commands[src + k];
}
