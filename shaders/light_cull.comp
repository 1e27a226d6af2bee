#version 430 core
#include "lib.glsl"
#include "lights.glsl"
#include "light_tree.glsl"
#include "clusters.glsl"
// One invocation a cluster, in two dispatches (CULL_WRITE the second): the lights that
// reach its box (view space, from its tile's corner rays between its slice's depths), as
// items of its list. Tree nodes go in whole where the box is at least their list
// distance away (engine/light_tree.py: from there a pixel may shade the group as one
// light; lights.comp opens it where its own surface does not), leaves as themselves;
// at error 0 (tree_exact) only leaves, where their volumes reach. Lights shaded
// one by one (exact_rows: spots, area lights, suns, point lights whose shadows have no
// map this frame) go in first, where their volume reaches. A list is counted and its
// place taken within its work group's, which takes its place with one atomic add (the
// first dispatch), then written (the second: each walk in an invocation of its own, as
// llvmpipe ends an invocation's loops after 65,535 iterations in all); a list that does
// not fit marks its cluster (lights.comp then walks every light) and the renderer grows
// the pool.
layout(local_size_x = 64) in;
layout(std430, binding = 8) readonly buffer ExactLights { int exact_rows[]; };
uniform int n_exact;
uniform uint items_capacity;
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform mat3 world_to_view;         // camera-relative world -> view axes
uniform vec2 u_size;                // pixels

vec3 box_lo, box_hi;                // the cluster, view space

float box_distance(vec3 c) {
    return length(max(max(box_lo - c, c - box_hi), vec3(0.0)));
}

// A point at view depth z on the camera ray through window uv.
vec3 at_depth(vec2 uv, float z) {
    vec3 a = position_from_depth(uv, 1.0, inv_view_proj);
    vec3 b = position_from_depth(uv, 0.5, inv_view_proj);
    float za = dot(a, cam_forward), zb = dot(b, cam_forward);
    return a + (b - a) * ((z - za) / (zb - za));
}

// Counts (write false) or writes from `first` the cluster's items: the lights shaded
// one by one, then the tree's nodes; returns how many of each.
uvec2 visit(bool write, uint first) {
    uint n = 0u;
    for (int k = 0; k < n_exact; ++k) {
        int row = exact_rows[k];
        vec4 t0 = light_table(row, 0);
        bool distant = (int(light_table(row, 3).w) & 16) != 0;
        if (!distant && box_distance(world_to_view * rebase(t0.xyz, light_table(row, 7).xyz)) > t0.w)
            continue;
        if (write) cluster_items[first + n] = uint(row);
        ++n;
    }
    uint rows = n;
    int i = tree_leaves > 0 ? 0 : -1;
    while (i >= 0) {
        bool down = false;
        if (node_count(i) > 0.0) {
            float d = box_distance(world_to_view * node_centre(i));
            if (!(tree_exact && d > node_reach(i))) {
                if (node_is_leaf(i) || d >= node_list_distance(i)) {
                    if (write) cluster_items[first + n] = uint(i);
                    ++n;
                } else {
                    down = true;
                }
            }
        }
        i = down ? 2 * i + 1 : tree_next(i, 0);
    }
    return uvec2(rows, n - rows);
}

// Sets the cluster's box: its tile's four corner rays between its slice's depths,
// padded for the rounding of a pixel's slice (clusters.glsl slice_of) at the slice's ends.
void cluster_box(int t, int k, vec4 bounds) {
    ivec2 tile = ivec2(t % cluster_tiles.x, t / cluster_tiles.x);
    float pad = 1e-4 * abs(bounds.y - bounds.x) + 1e-6 * max(abs(bounds.x), abs(bounds.y));
    float z0 = slice_depth(k, bounds.xy) - pad, z1 = slice_depth(k + 1, bounds.xy) + pad;
    box_lo = vec3(3.0e38);
    box_hi = vec3(-3.0e38);
    for (int c = 0; c < 4; ++c) {
        vec2 corner = vec2(tile * TILE + ivec2(c & 1, c >> 1) * TILE);
        vec2 uv = min(corner, u_size) / u_size;
        for (int e = 0; e < 2; ++e) {
            vec3 q = world_to_view * at_depth(uv, e == 0 ? z0 : z1);
            box_lo = min(box_lo, q);
            box_hi = max(box_hi, q);
        }
    }
    vec3 slack = 1e-5 * max(abs(box_lo), abs(box_hi));
    box_lo -= slack;
    box_hi += slack;
}

#ifdef CULL_WRITE
void main() {
    int cluster = int(gl_GlobalInvocationID.x);
    int tiles = cluster_tiles.x * cluster_tiles.y;
    if (cluster >= tiles * SLICES) return;
    uvec4 range = cluster_ranges[cluster];
    if (range.w != 0u || range.y + range.z == 0u) return;
    int t = cluster / SLICES, k = cluster % SLICES;
    cluster_box(t, k, tile_bounds[t]);
    visit(true, range.x);
}
#else
// The work group takes its clusters' places with one atomic add on the pool's counter,
// not one a cluster: every cluster of the screen adding to one address in turn is what
// the count would otherwise wait on.
shared uint group_items;
shared uint group_first;

void main() {
    if (gl_LocalInvocationIndex == 0u) group_items = 0u;
    barrier();
    int cluster = int(gl_GlobalInvocationID.x);
    int tiles = cluster_tiles.x * cluster_tiles.y;
    int t = cluster / SLICES, k = cluster % SLICES;
    bool inside = cluster < tiles * SLICES;
    vec4 bounds = inside ? tile_bounds[t] : vec4(0.0);
    bool lit = inside && (floatBitsToUint(bounds.z) & (1u << uint(k))) != 0u && bounds.w != 0.0;
    uvec2 n = uvec2(0u);
    if (lit) {
        cluster_box(t, k, bounds);
        n = visit(false, 0u);
    }
    uint offset = atomicAdd(group_items, n.x + n.y);
    barrier();
    if (gl_LocalInvocationIndex == 0u) group_first = atomicAdd(items_asked, group_items);
    barrier();
    if (!inside) return;
    uint first = lit ? group_first + offset : 0u;
    bool fits = first + n.x + n.y <= items_capacity;
    if (!fits) atomicAdd(clusters_overflowed, 1u);
    cluster_ranges[cluster] = lit ? uvec4(first, n, fits ? 0u : 1u) : uvec4(0u);
}
#endif
