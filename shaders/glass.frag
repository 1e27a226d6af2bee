#version 330 core
// The glass pass without compute (GL 3.3, 4.1): one interface, in screen space
// (shaders/glass.glsl).
#include "lib.glsl"
#include "glass.glsl"
