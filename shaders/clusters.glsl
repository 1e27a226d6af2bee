// Clusters for the clustered light pass (engine/gpu/passes/light_cull.py): the screen
// in TILE x TILE pixel tiles, each tile's depth range (of the surfaces it shows) in
// SLICES slices, geometric where the range is positive. light_tiles.comp finds each
// tile's range and which slices hold a surface, light_cull.comp lists each cluster's
// lights (and groups of the light tree), lights.comp shades each pixel with its
// cluster's list. Both constants match engine/gpu/passes/light_cull.py.
#define TILE 16
#define SLICES 8

// Per tile: view depth range of its surfaces, slices holding one (bits), surfaces.
layout(std430, binding = 4) buffer TileBounds { vec4 tile_bounds[]; };
// A cluster's list: its first item, how many light-table rows (lights shaded one by
// one) then how many light-tree nodes follow, and 1 where the list did not fit
// (lights.comp then walks every light).
layout(std430, binding = 5) buffer ClusterRanges { uvec4 cluster_ranges[]; };
layout(std430, binding = 6) buffer ClusterItems { uint cluster_items[]; };
// The frame's counts: items the lists asked for, clusters whose list did not fit, and
// of the light tree (lights.comp) the pixels that walked it, the most steps (nodes
// visited) of one pixel, and the steps of all, in two words (low, high).
layout(std430, binding = 7) buffer CullCounts {
    uint items_asked; uint clusters_overflowed;
    uint tree_pixels; uint tree_steps_max; uint tree_steps_low; uint tree_steps_high;
};
uniform ivec2 cluster_tiles;        // tiles across, down

// Where depth z lies in a tile's range [b.x, b.y]: 0 at b.x, 1 at b.y.
float slice_t(float z, vec2 b) {
    if (b.y <= b.x) return 0.0;
    if (b.x > 0.0) return log(z / b.x) / log(b.y / b.x);
    return (z - b.x) / (b.y - b.x);
}

int slice_of(float z, vec2 b) {
    return clamp(int(floor(slice_t(z, b) * float(SLICES))), 0, SLICES - 1);
}

// The view depth where slice k begins (k = SLICES: where the last ends).
float slice_depth(int k, vec2 b) {
    float t = float(k) / float(SLICES);
    if (b.y <= b.x) return k == 0 ? b.x : b.y;
    if (b.x > 0.0) return b.x * pow(b.y / b.x, t);
    return mix(b.x, b.y, t);
}

int cluster_of(ivec2 px, float z) {
    ivec2 tile = px / TILE;
    int t = tile.y * cluster_tiles.x + tile.x;
    return t * SLICES + slice_of(z, tile_bounds[t].xy);
}
