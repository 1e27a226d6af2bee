// Rays against the scene's triangles (GL 4.3). engine/gpu/raytracer.py fills the arrays'
// texture and binds it (Raytracer.bind); engine/bvh.py builds the trees.
//
// Two levels: a top tree over the instances, in world space; at a leaf the ray goes
// into that instance's object space and walks its mesh's bottom tree (one per mesh,
// shared by every instance of it). Both trees are laid out depth first with a miss
// link per node (engine/bvh.py), so the walk needs no stack: one loop, one node an
// iteration. llvmpipe ends an invocation's loops after 65,535 iterations in all
// (docs/status.md): trace a few rays an invocation, not hundreds.
//
//   bool rt_closest_hit(vec3 origin, vec3 direction, float tmin, float tmax, out RtHit hit)
//   bool rt_any_hit(vec3 origin, vec3 direction, float tmin, float tmax)
//
// direction need not be unit length (never zero): t is in its units, hits lie at
// origin + t direction with tmin < t <= tmax. Both sides of every triangle are hit.
// Of hits at the same t the lowest (instance, triangle) is the closest, so the
// closest hit does not depend on the order of the walk.

#define RT_NO_HIT (-1)
#define RT_FAR 3.0e38

// Every array in one texture of 32-bit words (engine/gpu/raytracer.py RtData), 4,096
// (1 << RT_WIDTH_BITS) vec4 a line: a walk's reads are lane-divergent gathers, which llvmpipe serves from a
// texture about 6 times faster than from a storage buffer when they are all a loop does
// (in the walk: any-hit rays 10-35% faster, closest-hit ones the same, the field's
// build 15%). Words, not floats: ints ride in them as bits, read unconverted.
// Its first vec4 holds where each array starts (in vec4): the bottom trees' nodes, the
// triangles, the instances, the top tree's nodes.
uniform usampler2D rt_data;
#define RT_WIDTH_BITS 12             // raytracer.py WIDTH = 4096
uvec4 rt_words(int e) {
    return texelFetch(rt_data, ivec2(e & ((1 << RT_WIDTH_BITS) - 1), e >> RT_WIDTH_BITS), 0);
}
vec4 rt_vec4(int e) { return uintBitsToFloat(rt_words(e)); }
ivec4 rt_bases() { return ivec4(rt_words(0)); }

struct RtNode { vec3 lo; int miss; vec3 hi; int prim; };   // prim: its leaf's (-1: inner)
RtNode rt_node(int first, int i) {                         // node i of the array at `first`
    uvec4 a = rt_words(first + 2 * i), b = rt_words(first + 2 * i + 1);
    return RtNode(uintBitsToFloat(a.xyz), int(a.w), uintBitsToFloat(b.xyz), int(b.w));
}

// A triangle: 3 vec4, its corners in object space; v0.w its material (an index into
// Raytracer.materials), v1.w its index in its mesh (MeshData.indices / 3), as int bits.
// An instance: RT_INSTANCE_VEC4 vec4: world to object (3 rows), object to world (3
// rows), then (bottom tree's root node, first triangle, triangles, object id) as int
// bits; the object id indexes the object table (shaders/objects.glsl).
#define RT_INSTANCE_VEC4 7

struct RtHit {
    float t;
    int instance;      // index into rt_instances, RT_NO_HIT for none
    int triangle;      // index into rt_triangles (3 vec4 each)
    vec2 barycentric;  // weights of the triangle's v1 and v2
};

// A ray prepared for the watertight triangle test (Woop, Benthin and Wald 2013): the
// shear that takes its direction to +z along its largest axis kz, as three rows, so a
// corner's sheared coordinates are three dot products (a lane-varying index into a
// vector, a[kx], costs llvmpipe a trip through memory); and the box test's inverse
// direction.
struct RtRay { vec3 origin; vec3 inv_dir; vec3 row_x; vec3 row_y; vec3 row_z; };

RtRay rt_ray(vec3 origin, vec3 dir) {
    vec3 a = abs(dir);
    int kz = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (dir[kz] < 0.0) { int s = kx; kx = ky; ky = s; }   // keeps the winding
    vec3 ex = vec3(equal(ivec3(0, 1, 2), ivec3(kx))), ey = vec3(equal(ivec3(0, 1, 2), ivec3(ky)));
    vec3 ez = vec3(equal(ivec3(0, 1, 2), ivec3(kz)));
    RtRay r;
    r.origin = origin;
    // ax = a[kx] - (d[kx] / d[kz]) a[kz], ay likewise, az = a[kz] / d[kz].
    r.row_x = ex - (dot(dir, ex) / dot(dir, ez)) * ez;
    r.row_y = ey - (dot(dir, ey) / dot(dir, ez)) * ez;
    r.row_z = ez / dot(dir, ez);
    // A zero component would make 0 * inf (NaN) where the origin lies on a slab.
    vec3 safe = mix(dir, vec3(1.0e-30), lessThan(a, vec3(1.0e-30)));
    r.inv_dir = 1.0 / safe;
    return r;
}

// Whether the ray enters the box within [tmin, tmax]. The far distance is widened by
// 1 + 2 gamma(3) (Ize 2013), so rounding never loses a box a triangle inside is hit in.
bool rt_box(RtRay r, vec3 lo, vec3 hi, float tmin, float tmax) {
    vec3 t0 = (lo - r.origin) * r.inv_dir, t1 = (hi - r.origin) * r.inv_dir;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    float near = max(max(tn.x, tn.y), max(tn.z, tmin));
    float far = min(min(tf.x, tf.y), min(tf.z, tmax)) * 1.0000003576;
    return near <= far;
}

// The watertight test: each edge's function is computed from the sheared corners
// alone, so two triangles sharing an edge get exactly opposite values and a ray
// through the edge (or a vertex) hits at least one of them. `precise`: no fused
// multiply-add may round one side differently. Exact zeros are computed again in
// double, as the paper does. t in (tmin, tmax].
bool rt_triangle(RtRay r, vec3 p0, vec3 p1, vec3 p2, float tmin, float tmax,
                 out float t, out vec2 barycentric) {
    precise vec3 a = p0 - r.origin, b = p1 - r.origin, c = p2 - r.origin;
    precise float ax = dot(a, r.row_x), ay = dot(a, r.row_y);
    precise float bx = dot(b, r.row_x), by = dot(b, r.row_y);
    precise float cx = dot(c, r.row_x), cy = dot(c, r.row_y);
    precise float u = cx * by - cy * bx;
    precise float v = ax * cy - ay * cx;
    precise float w = bx * ay - by * ax;
    if (u == 0.0 || v == 0.0 || w == 0.0) {
        u = float(double(cx) * double(by) - double(cy) * double(bx));
        v = float(double(ax) * double(cy) - double(ay) * double(cx));
        w = float(double(bx) * double(ay) - double(by) * double(ax));
    }
    t = 0.0;
    barycentric = vec2(0.0);
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
    float det = u + v + w;
    if (det == 0.0) return false;                 // seen edge on, or degenerate
    precise float tt = (u * dot(a, r.row_z) + v * dot(b, r.row_z) + w * dot(c, r.row_z)) / det;
    if (!(tt > tmin && tt <= tmax)) return false;
    t = tt;
    barycentric = vec2(v, w) / det;
    return true;
}

// Whether a hit at t on (instance, triangle) comes before `hit`.
bool rt_before(float t, int instance, int triangle, RtHit hit) {
    return t < hit.t || (t == hit.t && (hit.instance == RT_NO_HIT || instance < hit.instance ||
                                        (instance == hit.instance && triangle < hit.triangle)));
}

// Instance i: its record's vec4 number j (`base`: rt_bases()).
vec4 rt_instance_in(ivec4 base, int i, int j) { return rt_vec4(base.z + i * RT_INSTANCE_VEC4 + j); }
vec4 rt_instance(int i, int j) { return rt_instance_in(rt_bases(), i, j); }
ivec4 rt_instance_info(ivec4 base, int i) {
    return ivec4(rt_words(base.z + i * RT_INSTANCE_VEC4 + 6));
}
// Triangle tri's corner k, in object space.
vec3 rt_corner(ivec4 base, int tri, int k) { return rt_vec4(base.y + 3 * tri + k).xyz; }

// Instance i's ray in its object space: the same t (the direction is not renormalised).
void rt_enter(ivec4 base, int i, vec3 origin, vec3 dir, out vec3 o, out vec3 d) {
    vec4 r0 = rt_instance_in(base, i, 0), r1 = rt_instance_in(base, i, 1),
         r2 = rt_instance_in(base, i, 2);
    o = vec3(dot(r0.xyz, origin) + r0.w, dot(r1.xyz, origin) + r1.w, dot(r2.xyz, origin) + r2.w);
    d = vec3(dot(r0.xyz, dir), dot(r1.xyz, dir), dot(r2.xyz, dir));
}

// The walk of both levels, closest hit or (any) the first found.
bool rt_walk(vec3 origin, vec3 dir, float tmin, float tmax, bool any, out RtHit hit) {
    hit.t = tmax;
    hit.instance = RT_NO_HIT;
    hit.triangle = RT_NO_HIT;
    hit.barycentric = vec2(0.0);
    RtRay world = rt_ray(origin, dir);
    RtRay local = world;
    ivec4 base = rt_bases();
    int top = 0, top_end = rt_node(base.w, 0).miss;
    int node = 0, node_end = 0, instance = RT_NO_HIT, first = 0;
    while (true) {
        if (instance != RT_NO_HIT) {                    // in an instance's bottom tree
            if (node == node_end) { instance = RT_NO_HIT; continue; }
            RtNode n = rt_node(base.x, node);
            if (n.prim >= 0) {                          // a leaf: its triangle
                int tri = first + n.prim;
                float t;
                vec2 bc;
                if (rt_triangle(local, rt_corner(base, tri, 0), rt_corner(base, tri, 1),
                                rt_corner(base, tri, 2), tmin, hit.t, t, bc) &&
                        rt_before(t, instance, tri, hit)) {
                    hit = RtHit(t, instance, tri, bc);
                    if (any) return true;
                }
                node += 1;
            } else {
                node = rt_box(local, n.lo, n.hi, tmin, hit.t) ? node + 1 : n.miss;
            }
        } else {                                        // in the top tree
            if (top == top_end) break;
            RtNode n = rt_node(base.w, top);
            if (!rt_box(world, n.lo, n.hi, tmin, hit.t)) {
                top = n.miss;
                continue;
            }
            top += 1;
            if (n.prim >= 0) {                          // an instance: into its tree
                vec3 o, d;
                rt_enter(base, n.prim, origin, dir, o, d);
                local = rt_ray(o, d);
                ivec4 info = rt_instance_info(base, n.prim);
                instance = n.prim;
                node = info.x;
                node_end = rt_node(base.x, node).miss;
                first = info.y;
            }
        }
    }
    return hit.instance != RT_NO_HIT;
}

// A ray from a point the camera sees (a G-buffer position, camera-relative q): it starts
// at q pulled towards the camera by RT_SEEN_PULL of its distance, along the line of
// sight, which is free, since the camera sees the point: a point the G-buffer gives just
// past a seam's wall (outside a closed room) starts inside again. World space.
const float RT_SEEN_PULL = 1e-3;
vec3 rt_seen_origin(vec3 q, vec3 eye) { return q * (1.0 - RT_SEEN_PULL) + eye; }

bool rt_closest_hit(vec3 origin, vec3 dir, float tmin, float tmax, out RtHit hit) {
    return rt_walk(origin, dir, tmin, tmax, false, hit);
}

bool rt_any_hit(vec3 origin, vec3 dir, float tmin, float tmax) {
    RtHit hit;
    return rt_walk(origin, dir, tmin, tmax, true, hit);
}

// What a shader shades at a hit: the object id (the object table's), the material
// (Raytracer.materials), the world position and the unit geometric normal (facing
// either way: the triangle's winding, v0 v1 v2 counter-clockwise).
int rt_hit_object(RtHit hit) { return rt_instance_info(rt_bases(), hit.instance).w; }
int rt_hit_material(RtHit hit) { return int(rt_words(rt_bases().y + 3 * hit.triangle).w); }

vec3 rt_hit_normal(RtHit hit) {
    ivec4 base = rt_bases();
    vec3 p0 = rt_corner(base, hit.triangle, 0);
    vec3 n = cross(rt_corner(base, hit.triangle, 1) - p0, rt_corner(base, hit.triangle, 2) - p0);
    // Normals go to world space by the inverse transpose: the world-to-object rows.
    vec4 r0 = rt_instance_in(base, hit.instance, 0), r1 = rt_instance_in(base, hit.instance, 1),
         r2 = rt_instance_in(base, hit.instance, 2);
    return normalize(n.x * r0.xyz + n.y * r1.xyz + n.z * r2.xyz);
}
