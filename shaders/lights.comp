#version 430 core
#include "lib.glsl"
#include "gbuffer_surface.glsl"
#include "lights.glsl"
#include "light_tree.glsl"
#include "clusters.glsl"
#ifdef HAS_SHADOW
#include "shadow_lookup.glsl"
#endif
// The clustered light pass (engine/gpu/passes/clustered.py): every light a pixel's
// cluster lists (clusters.glsl), shaded with the light volumes' own functions
// (gbuffer_surface.glsl, lights.glsl) and the light tree's groups (light_tree.glsl),
// added once into the HDR target and the lighting render passes. SINGLE_LIGHT: one
// light over a rectangle, with its shadow map (HAS_SHADOW), for the lights whose shadow
// maps this frame made: each map is its own texture, bound by itself.
layout(local_size_x = TILE, local_size_y = TILE) in;
layout(rgba32f, binding = 0) uniform image2D hdr_image;
#ifdef WRITE_AOVS
// Render passes (engine/gpu/passes/ambient.py LIGHTING_AOVS), added like the light.
layout(rgba32f, binding = 1) uniform image2D aov_diffuse_image;
layout(rgba32f, binding = 2) uniform image2D aov_glossy_image;
layout(rgba32f, binding = 3) uniform image2D aov_shadow_image;  // luminance with shadows, without
#endif
layout(std430, binding = 8) readonly buffer ExactLights { int exact_rows[]; };
uniform int n_exact;
uniform ivec2 u_offset;             // the dispatch's first pixel
#ifdef SINGLE_LIGHT
uniform int light_index;
#endif

void add_light(Surface s, inout vec3 sum_d, inout vec3 sum_g) {
    vec3 diffuse, glossy;
    light_reflected(s, diffuse, glossy);
    sum_d += diffuse;
    sum_g += glossy;
}

// Whether the loaded light's volume reaches camera-relative p (a sun's always does; a
// spot's is the cone the light volumes draw, its apex moved back by radius / sin(half
// angle) so that it holds every point of the light's sphere's cones): tested before the
// pixel's surface is read from the G-buffer, which costs more.
bool reaches(vec3 p) {
    if (is_distant) return true;
    if (distance(p, light_pos) > light_range) return false;
    if (!is_spot || cos_half <= 0.0) return true;
    vec3 apex = light_pos - light_axis * light_radius / sqrt(max(1.0 - cos_half * cos_half, 1e-6));
    return dot(normalize(p - apex), light_axis) >= cos_half - 1e-5;
}

// Shades pixel px; returns the light tree's and the emitter groups' steps (nodes
// visited) for it.
uint shade_pixel(ivec2 px) {
    area_steps = 0u;
    if (any(greaterThanEqual(px, imageSize(hdr_image)))) return 0u;
    shaded_pixel = vec2(px) + 0.5;
    float depth = texelFetch(g_depth, px, 0).r;
    if (is_background(depth)) return 0u;
    vec3 p = position_from_depth(shaded_pixel / vec2(textureSize(g_depth, 0)), depth,
                                 inv_view_proj);
    vec3 sum_d = vec3(0.0), sum_g = vec3(0.0);
    vec3 lit = vec3(1.0);        // the shadow, coloured by the glass it passes
    uint steps = 0u;
    Surface s;
#ifdef SINGLE_LIGHT
    load_light(light_index, cam_forward);
    if (!reaches(p)) return 0u;
    s = gbuffer_surface(px, depth);
    add_light(s, sum_d, sum_g);
    vec3 radiance = sum_d + sum_g;
    if (max(radiance.r, max(radiance.g, radiance.b)) <= 0.0) return 0u;
#ifdef HAS_SHADOW
    lit = light_shadow(s.p, s.n, dot(s.p, cam_forward)) *
          light_shadow_colour(s.p, s.n, dot(s.p, cam_forward));
#endif
#else
    // The cluster's list: lights shaded one by one (HAS_EXACT), then the light tree's
    // nodes (HAS_TREE); or, where it did not fit, every light.
    uvec4 range = cluster_ranges[cluster_of(px, dot(p, cam_forward))];
    bool overflow = range.w != 0u;
    uint exact = overflow ? uint(n_exact) : range.y;
    if (exact + range.z == 0u && !overflow) return 0u;
    s = gbuffer_surface(px, depth);
#ifdef HAS_EXACT
    for (uint k = 0u; k < exact; ++k) {
        load_light(overflow ? exact_rows[k] : int(cluster_items[range.x + k]), cam_forward);
        if (reaches(p)) add_light(s, sum_d, sum_g);
    }
#endif
#ifdef HAS_TREE
    // The list's nodes, from the root where it did not fit: first a lower bound of the
    // pixel's light from them (the groups' test is against it), then their light (one
    // inlined walk each: llvmpipe runs a second under its mask even where no pixel
    // takes it).
    uint nodes = overflow ? 1u : range.z;
    uint first = range.x + range.y;
    vec3 total = vec3(0.0);
    if (!tree_exact)
        for (uint k = 0u; k < nodes; ++k)
            total += tree_lower_bound(s, overflow ? 0 : int(cluster_items[first + k]), steps);
    for (uint k = 0u; k < nodes; ++k)
        shade_node(s, overflow ? 0 : int(cluster_items[first + k]), cam_forward, total,
                   sum_d, sum_g, steps);
#endif
    vec3 radiance = sum_d + sum_g;
#endif
    // NaN or Inf goes through: the resolve pass counts it.
    imageStore(hdr_image, px, imageLoad(hdr_image, px) + vec4(radiance * lit, 0.0));
#ifdef WRITE_AOVS
    imageStore(aov_diffuse_image, px, imageLoad(aov_diffuse_image, px) + vec4(sum_d * lit, 0.0));
    imageStore(aov_glossy_image, px, imageLoad(aov_glossy_image, px) + vec4(sum_g * lit, 0.0));
    vec3 weights = vec3(0.2126, 0.7152, 0.0722);
    imageStore(aov_shadow_image, px, imageLoad(aov_shadow_image, px) +
               vec4(dot(radiance * lit, weights), dot(radiance, weights), 0.0, 0.0));
#endif
    return steps + area_steps;
}

// The light tree's steps and the pixels that took one, summed in the work group, then
// added to the frame's counts with one atomic add each (a carry into the high word where
// the low one wraps: passes/light_cull.py reads them).
shared uint group_steps;
shared uint group_pixels;
shared uint group_max;

void main() {
    if (gl_LocalInvocationIndex == 0u) group_steps = group_pixels = group_max = 0u;
    barrier();
    uint steps = shade_pixel(ivec2(gl_GlobalInvocationID.xy) + u_offset);
    if (steps > 0u) {
        atomicAdd(group_steps, steps);
        atomicAdd(group_pixels, 1u);
        atomicMax(group_max, steps);
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u && group_pixels > 0u) {
        atomicAdd(tree_pixels, group_pixels);
        atomicMax(tree_steps_max, group_max);
        uint before = atomicAdd(tree_steps_low, group_steps);
        if (before + group_steps < before) atomicAdd(tree_steps_high, 1u);
    }
}
