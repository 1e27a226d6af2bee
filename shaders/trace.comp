#version 430 core
#include "raytrace.glsl"
// A batch of rays traced (Raytracer.trace: tests, the bench, tools): one ray an
// invocation. BRUTE_FORCE tests every triangle of every instance instead of walking
// the trees, with the same test and order of hits: the trees' reference (a walk over
// all triangles is one loop of that many iterations, so at most 65,535 on llvmpipe).
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Rays { vec4 rays[]; };   // origin, tmin; direction, tmax
// Per ray: t (-1: none), instance, triangle, object id; barycentric, material; normal.
layout(std430, binding = 1) writeonly buffer Hits { vec4 hits[]; };
uniform int u_rays;
uniform int u_instances;

#ifdef BRUTE_FORCE
bool brute_force(vec3 origin, vec3 dir, float tmin, float tmax, bool any, out RtHit hit) {
    hit = RtHit(tmax, RT_NO_HIT, RT_NO_HIT, vec2(0.0));
    int i = 0, tri = 0, end = 0;
    RtRay local;
    bool entered = false;
    ivec4 base = rt_bases();
    while (i < u_instances) {
        if (!entered) {
            vec3 o, d;
            rt_enter(base, i, origin, dir, o, d);
            local = rt_ray(o, d);
            ivec4 info = rt_instance_info(base, i);
            tri = info.y;
            end = info.y + info.z;
            entered = true;
        }
        if (tri == end) { i += 1; entered = false; continue; }
        float t;
        vec2 bc;
        if (rt_triangle(local, rt_corner(base, tri, 0), rt_corner(base, tri, 1),
                        rt_corner(base, tri, 2), tmin, hit.t, t, bc) &&
                rt_before(t, i, tri, hit)) {
            hit = RtHit(t, i, tri, bc);
            if (any) return true;
        }
        tri += 1;
    }
    return hit.instance != RT_NO_HIT;
}
#endif

void main() {
    int ray = int(gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u);
    if (ray >= u_rays) return;
    vec4 a = rays[2 * ray], b = rays[2 * ray + 1];
#ifdef ANY_HIT
    bool any = true;
#else
    bool any = false;
#endif
    RtHit hit;
#ifdef BRUTE_FORCE
    bool found = brute_force(a.xyz, b.xyz, a.w, b.w, any, hit);
#else
    bool found = rt_walk(a.xyz, b.xyz, a.w, b.w, any, hit);
#endif
    hits[3 * ray] = vec4(found ? hit.t : -1.0, intBitsToFloat(hit.instance),
                         intBitsToFloat(hit.triangle),
                         intBitsToFloat(found ? rt_hit_object(hit) : RT_NO_HIT));
    hits[3 * ray + 1] = vec4(hit.barycentric, intBitsToFloat(found ? rt_hit_material(hit)
                                                                  : RT_NO_HIT), 0.0);
    hits[3 * ray + 2] = vec4(found ? rt_hit_normal(hit) : vec3(0.0), 0.0);
}
