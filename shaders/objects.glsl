// Per-object data (engine/gpu/geometry.py ObjectTable): 7 texels per object in a flat
// RGBA32F texture OBJECT_TEX_W wide, the model matrix's columns then the normal
// matrix's. The object is an instanced attribute read at each indirect command's
// baseInstance (OBJECT_ATTRIBUTE, the GL 4.3 multi-draw path) or a uniform set per
// draw (the GL 3.3 path).
uniform sampler2D u_objects;
#ifdef OBJECT_ATTRIBUTE
in int in_object;
#define OBJECT_ID in_object
#else
uniform int u_object;
#define OBJECT_ID u_object
#endif
const int OBJECT_TEX_W = 4095;
vec4 object_texel(int k) {
    int i = OBJECT_ID * 7 + k;
    return texelFetch(u_objects, ivec2(i % OBJECT_TEX_W, i / OBJECT_TEX_W), 0);
}
mat4 object_model() { return mat4(object_texel(0), object_texel(1), object_texel(2), object_texel(3)); }
mat3 object_normal_matrix() { return mat3(object_texel(4).xyz, object_texel(5).xyz, object_texel(6).xyz); }
