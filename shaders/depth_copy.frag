#version 330 core
// Copies the G-buffer depth into the light pass's depth attachment, so light volumes
// can depth-test against the scene while the shaders sample the original.
uniform sampler2D g_depth;
out vec4 frag;
void main() {
    gl_FragDepth = texelFetch(g_depth, ivec2(gl_FragCoord.xy), 0).r;
    frag = vec4(0.0);
}
