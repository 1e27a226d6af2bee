#version 330 core
// Stencil marking of a light volume: writes nothing (colour writes are off).
out vec4 frag;
void main() { frag = vec4(0.0); }
