#version 430 core
// The glass pass on GL 4.3+: the ray followed through the object's own surfaces with
// the ray tracer (shaders/glass.glsl).
#define TRACED
#include "lib.glsl"
#include "raytrace.glsl"
#include "glass.glsl"
