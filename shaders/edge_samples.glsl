#include "lib.glsl"
// Geometric edges of a supersampled image where its edge samples put them
// (engine/gpu/passes/antialias.py): a screen pass's body (engine/gpu/screen.py). The
// image's sub-pixels ("cells") were each shaded once at their centre, and the G-buffer
// pass drew the same geometry's depth again at four places in every cell
// (edge_depth, multisampled). A cell whose samples all lie on its own surface is one
// sample at its centre, as in the separable filter; a cell that an edge crosses is its
// samples, each at its own place, a quarter of the cell, with the colour of the
// neighbouring cell whose surface it lies on. Cycles' pixel filter weighs them all
// where they lie, so an edge along the pixel rows falls where the geometry puts it,
// not on the nearest line between cell centres.
//   EDGE_MARK    at the cells: 0 where every sample lies on the cell's own surface, else
//                1 + the cell each sample takes its colour from (0-8: the 3 x 3 cells
//                around it, 4 itself), 4 bits a sample.
//   EDGE_PIXELS  at the pixels: 1 where one of the pixel's cells is crossed, else 0.
//   EDGE_GATHER  at the pixels: the separable filter's result, with each crossed cell
//                within the filter's reach as its samples (only near a crossed pixel:
//                a pixel's cells are factor^2 reads, its reach's many more).
#define SAMPLES 4                  // edge_depth's (engine/gpu/resources.py depth_ms4)
#ifdef EDGE_MARK
uniform sampler2D g_depth;         // the cells' depth (reversed: 0 is the background)
uniform sampler2DMS edge_depth;    // the same geometry's depth at the samples' places
#endif
#if defined(EDGE_PIXELS) || defined(EDGE_GATHER)
uniform sampler2D edge_marks;      // EDGE_MARK's output
uniform int factor;                // cells a pixel, along each axis
#endif
#ifdef EDGE_GATHER
uniform sampler2D edge_pixels;     // EDGE_PIXELS' output
uniform sampler2D post_src;        // the supersampled image
uniform sampler2D separable;       // the separable filter's result
// The filter's weights along one axis (engine/gpu/passes/antialias.py edge_taps), over
// the cells within its reach: cell i is factor * pixel + first + i; at the cell's centre
// (the separable filter's), and at each sample's place in it.
uniform int first;
uniform float centre_weight[CELLS];
uniform vec4 sample_weight_x[CELLS];
uniform vec4 sample_weight_y[CELLS];
#endif

ivec2 neighbour(int i) { return ivec2(i % 3 - 1, i / 3 - 1); }

#ifdef EDGE_MARK
// A cell's depth; beyond the image's border as far as can be (no sample's nearest,
// nor a step).
float depth_at(ivec2 c) {
    bool inside = all(greaterThanEqual(c, ivec2(0))) && all(lessThan(c, textureSize(g_depth, 0)));
    return inside ? texelFetch(g_depth, c, 0).r : 3.4e38;
}

float mark(ivec2 c) {
    float around[9];
    for (int i = 1; i < 9; i += 2) around[i] = depth_at(c + neighbour(i));   // the four sides
    float d = around[4] = texelFetch(g_depth, c, 0).r;
    // Window depth is affine across a plane, so on the cell's own surface a sample (at
    // most 3/8 of a cell from the centre along each axis) lies within half a depth
    // step along each axis of the centre's depth. A step is the smaller of the
    // one-sided differences, so an edge beside the cell does not widen it; the
    // relative term covers rounding (the two drawings rasterise the same triangle at
    // different places).
    float step_x = min(abs(around[5] - d), abs(d - around[3]));
    float step_y = min(abs(around[7] - d), abs(d - around[1]));
    float reach = 0.5 * ((step_x < 1e38 ? step_x : 0.0) + (step_y < 1e38 ? step_y : 0.0)) + 1e-5 * d;
    vec4 ds;
    for (int s = 0; s < SAMPLES; ++s) ds[s] = texelFetch(edge_depth, c, s).r;
    if (all(lessThanEqual(abs(ds - d), vec4(reach)))) return 0.0;
    // A sample off the cell's surface takes the colour of the cell, of the 3 x 3,
    // whose depth is nearest its own. (Extending each cell's plane to the sample
    // instead measured the same on the reference scenes: docs/compare.md.)
    for (int i = 0; i < 9; i += 2) if (i != 4) around[i] = depth_at(c + neighbour(i));
    int code = 0;
    for (int s = 0; s < SAMPLES; ++s) {
        int from = 4;
        if (abs(ds[s] - d) > reach)
            for (int i = 0; i < 9; ++i)
                if (abs(around[i] - ds[s]) < abs(around[from] - ds[s])) from = i;
        code += from << (4 * s);
    }
    return float(1 + code);
}
#endif

void screen_pixel(ivec2 px, out vec4 frag, out vec4 unused1, out vec4 unused2,
                  out vec4 unused3) {
    unused1 = unused2 = unused3 = vec4(0.0);
#ifdef EDGE_MARK
    frag = vec4(mark(px));
#endif
#ifdef EDGE_PIXELS
    bool crossed = false;
    for (int i = 0; i < factor * factor; ++i)
        crossed = crossed || texelFetch(edge_marks, px * factor + ivec2(i % factor, i / factor), 0).r > 0.0;
    frag = vec4(crossed ? 1.0 : 0.0);
#endif
#ifdef EDGE_GATHER
    // Nothing to do where no pixel the filter reaches (1.5 pixels: the 3 x 3 around)
    // has a crossed cell.
    ivec2 pixels = textureSize(edge_pixels, 0);
    bool near = false;
    for (int i = 0; i < 9; ++i)
        near = near || texelFetch(edge_pixels, clamp(px + neighbour(i), ivec2(0), pixels - 1), 0).r > 0.0;
    if (!near) {
        frag = texelFetch(separable, px, 0);
        return;
    }
    // The separable filter's sum, with each crossed cell's centre taken out and its
    // samples put in (the weights of a whole pixel sum to 1).
    vec4 sum = texelFetch(separable, px, 0);
    float total = 1.0;
    ivec2 size = textureSize(edge_marks, 0);
    ivec2 base = px * factor + first;
    for (int j = 0; j < CELLS; ++j) {
        for (int i = 0; i < CELLS; ++i) {
            ivec2 c = clamp(base + ivec2(i, j), ivec2(0), size - 1);
            int code = int(texelFetch(edge_marks, c, 0).r);
            if (code == 0) continue;
            code -= 1;
            float centre = centre_weight[i] * centre_weight[j];
            sum -= centre * texelFetch(post_src, c, 0);
            total -= centre;
            vec4 w = 0.25 * sample_weight_x[i] * sample_weight_y[j];
            for (int s = 0; s < SAMPLES; ++s)
                sum += w[s] * texelFetch(post_src, c + neighbour((code >> (4 * s)) & 15), 0);
            total += w.x + w.y + w.z + w.w;
        }
    }
    frag = sum / total;
#endif
}
