// Per-object data (engine/gpu/geometry.py ObjectTable): 8 texels per object in a flat
// RGBA32F texture OBJECT_TEX_W wide: the model matrix's columns (the fourth holding
// the translation's hi float), the normal matrix's columns (the first one's w holding
// the object's render-pass index), the translation's lo float. The object is an
// instanced attribute read at each indirect command's
// baseInstance (OBJECT_ATTRIBUTE, the GL 4.3 multi-draw path) or a uniform set per
// draw (the GL 3.3 path). The instances of an instanced draw (a PointInstancer's)
// have consecutive ids: the attribute steps per instance, the uniform adds
// gl_InstanceID.
#include "origin.glsl"
uniform sampler2D u_objects;
#if defined(OBJECT_SINGLE)
uniform int u_object;           // one object, whatever the instancing (point sprites)
#define OBJECT_ID u_object
#elif defined(OBJECT_ATTRIBUTE)
in int in_object;
#define OBJECT_ID in_object
#else
uniform int u_object;
#define OBJECT_ID (u_object + gl_InstanceID)
#endif
const int OBJECT_TEX_W = 4096;
vec4 object_texel(int k) {
    int i = OBJECT_ID * 8 + k;
    return texelFetch(u_objects, ivec2(i % OBJECT_TEX_W, i / OBJECT_TEX_W), 0);
}
// The model matrix relative to the frame's origin (origin.glsl).
mat4 object_model() {
    vec3 t = rebase(object_texel(3).xyz, object_texel(7).xyz);
    return mat4(object_texel(0), object_texel(1), object_texel(2), vec4(t, 1.0));
}
mat3 object_normal_matrix() { return mat3(object_texel(4).xyz, object_texel(5).xyz, object_texel(6).xyz); }
float object_pass_index() { return object_texel(4).w; }
