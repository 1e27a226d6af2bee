#include "lib.glsl"
// Cryptomatte's ranking filter (engine/gpu/passes/cryptomatte.py; a screen pass's body,
// engine/gpu/screen.py): the ids of the samples (sub-pixels) a pixel's coverage counts,
// weighted by `tap`, summed per id; the ids ranked by that coverage, two (id, coverage)
// pairs per output. One matte per variant: MATTE_OBJECT, MATTE_MATERIAL or MATTE_ASSET.
uniform sampler2D crypto_ids;     // the G-buffer's g_index: .z 1 + object id, .w material id
uniform sampler2D crypto_names;   // per object id: its object id, its asset id
uniform int factor;               // supersampling: sub-pixels per pixel along an axis
uniform int taps;
uniform vec2 tap[64];             // (offset from the pixel's first sample, weight)

// Distinct ids a pixel's filter footprint keeps; a further one's weight is dropped (it
// would rank below the 6 written unless 17 ids share a pixel nearly evenly).
const int SLOTS = 16;
const int NAMES_W = 4096;

float matte_id(vec4 ids) {
#if defined(MATTE_MATERIAL)
    return ids.w;
#else
    int object = int(ids.z) - 1;
    vec4 names = texelFetch(crypto_names, ivec2(object % NAMES_W, object / NAMES_W), 0);
#if defined(MATTE_ASSET)
    return names.y;
#else
    return names.x;
#endif
#endif
}

#if defined(MATTE_MATERIAL)
#define RAW(ids) ids.w
#else
#define RAW(ids) ids.z
#endif

void screen_pixel(ivec2 px, out vec4 rank01, out vec4 rank23, out vec4 rank45,
                  out vec4 unused) {
    unused = vec4(0.0);
#ifdef ONE_SAMPLE
    // One sample a pixel (low, medium): its id, coverage 1; nothing to rank.
    vec4 one = texelFetch(crypto_ids, px, 0);
    rank01 = one.z == 0.0 ? vec4(0.0) : vec4(matte_id(one), 1.0, 0.0, 0.0);
    rank23 = vec4(0.0);
    rank45 = vec4(0.0);
#else
    ivec2 size = textureSize(crypto_ids, 0);
    // Most pixels see one surface, or one and the background: a single id over the
    // footprint needs no list (a list in registers costs llvmpipe dearly).
    vec4 lead = vec4(0.0);          // the first drawn sub-pixel's ids
    float covered = 0.0;
    bool single = true;
    for (int j = 0; j < taps && single; ++j) {
        for (int i = 0; i < taps; ++i) {
            ivec2 q = clamp(px * factor + ivec2(int(tap[i].x), int(tap[j].x)),
                            ivec2(0), size - 1);
            vec4 ids = texelFetch(crypto_ids, q, 0);
            if (ids.z == 0.0) continue;
            if (lead.z == 0.0) lead = ids;
            single = single && RAW(ids) == RAW(lead);
            covered += tap[i].y * tap[j].y;
        }
    }
    if (single) {
        rank01 = vec4(lead.z == 0.0 ? 0.0 : matte_id(lead), covered, 0.0, 0.0);
        rank23 = vec4(0.0);
        rank45 = vec4(0.0);
        return;
    }
    float id[SLOTS];
    float weight[SLOTS];
    int n = 0;
    for (int j = 0; j < taps; ++j) {
        for (int i = 0; i < taps; ++i) {
            ivec2 q = clamp(px * factor + ivec2(int(tap[i].x), int(tap[j].x)),
                            ivec2(0), size - 1);
            vec4 ids = texelFetch(crypto_ids, q, 0);
            if (ids.z == 0.0) continue;            // nothing drawn: no id, no coverage
            float h = matte_id(ids);
            float w = tap[i].y * tap[j].y;
            int k = 0;
            while (k < n && id[k] != h) ++k;
            if (k == n) {
                if (n == SLOTS) continue;
                id[n] = h;
                weight[n] = 0.0;
                ++n;
            }
            weight[k] += w;
        }
    }
    // The six highest coverages, highest first; 0 ids and coverages past the last.
    float out_id[6];
    float out_w[6];
    for (int r = 0; r < 6; ++r) {
        int best = -1;
        for (int k = 0; k < n; ++k)
            if (weight[k] > 0.0 && (best < 0 || weight[k] > weight[best])) best = k;
        out_id[r] = best < 0 ? 0.0 : id[best];
        out_w[r] = best < 0 ? 0.0 : weight[best];
        if (best >= 0) weight[best] = 0.0;
    }
    rank01 = vec4(out_id[0], out_w[0], out_id[1], out_w[1]);
    rank23 = vec4(out_id[2], out_w[2], out_id[3], out_w[3]);
    rank45 = vec4(out_id[4], out_w[4], out_id[5], out_w[5]);
#endif
}
