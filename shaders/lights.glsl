// One light from the packed light table (engine/gpu/lights.py documents the row), as
// the globals the light shaders read. Call load_light(row) first. Positions come out
// camera-relative (origin.glsl), as the surfaces they light.
#include "origin.glsl"
uniform sampler2D u_lights;

vec3 light_pos;             // camera-relative
float light_range;          // volume radius: nothing is added beyond it
vec3 light_color;           // I [W/sr], L [W/(sr m2)] or E [W/m2]
float light_radius;
vec3 light_axis;            // direction of emission (light's -Z)
float cos_half;
float spot_blend;
float light_diffuse;
float light_specular;
bool soft_falloff;
bool is_spot;
bool is_disk;
vec3 light_x;
vec3 light_y;
vec2 half_size;             // rect half extents; disk: (radius, 0)
int n_poly;
float light_area;
int light_row;

vec4 light_texel(int k) { return texelFetch(u_lights, ivec2(k, light_row), 0); }

// Camera-relative vertex i of an area light's polygon (stored about its centre).
vec3 light_poly(int i) { return light_pos + light_texel(8 + i).xyz; }

void load_light(int row, vec3 view_forward) {
    light_row = row;
    vec4 t0 = light_texel(0), t1 = light_texel(1), t2 = light_texel(2), t3 = light_texel(3);
    light_pos = rebase(t0.xyz, light_texel(7).xyz); light_range = t0.w;
    light_color = t1.rgb; light_radius = t1.w;
    light_axis = t2.xyz; cos_half = t2.w;
    spot_blend = t3.x; light_diffuse = t3.y; light_specular = t3.z;
    int flags = int(t3.w);
    soft_falloff = (flags & 1) != 0;
    is_spot = (flags & 2) != 0;
    is_disk = (flags & 4) != 0;
    if ((flags & 8) != 0) light_axis = view_forward;   // a headlight follows the view
    vec4 t4 = light_texel(4), t5 = light_texel(5), t6 = light_texel(6);
    light_x = t4.xyz; light_y = t5.xyz;
    half_size = vec2(t4.w, t5.w);
    n_poly = int(t6.x); light_area = t6.y;
}
