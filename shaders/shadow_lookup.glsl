// Shadow lookup for light.frag (variant HAS_SHADOW); the maps are made by
// engine/shadows.py, which documents the layouts.
//
// Bias, in three parts (seed 000 §8.5.1, surface acne):
//  * normal offset: the receiver is moved off its surface by ~1 texel, more at grazing
//    angles (sin theta), so its own texel's depth never covers it;
//  * receiver-plane depth: every PCF/blocker tap compares against the depth the
//    receiver's own plane has at that tap (ref + dot(offset, n) / NoL), not the centre
//    depth, so wide kernels on slopes do not self-shadow;
//  * slope-scaled constant: texel * (1 + tan theta) for the depth quantisation and
//    the bilinear compare footprint, plus 1e-4 relative for float precision.
// Soft shadows (PCSS): a blocker search over the region that can occlude the light,
// then PCF with a kernel of the penumbra width: radius * (d_recv - d_block) / d_block
// for sphere/area lights, (d_recv - d_block) * tan(angle / 2) for the sun.
uniform sampler2DShadow shadow_cmp;
uniform sampler2D shadow_raw;
uniform bool shadow_radial;
uniform int shadow_tiles;
uniform mat4 shadow_mats[6];    // camera-relative position -> tile uv, depth in [0, 1]
uniform vec4 shadow_rects[6];   // atlas offset xy, scale zw
uniform float shadow_far;       // radial: stored depth = distance / far
uniform float shadow_texel;     // radial: world texel size per unit distance
uniform vec4 shadow_splits;     // sun: far view depth of each cascade
uniform vec4 shadow_ranges;     // sun: world depth range of each cascade
uniform vec4 shadow_texels;     // sun: world texel size of each cascade
uniform float shadow_size;      // light radius, or tan(sun half angle)
uniform int pcf_taps;
uniform int blocker_taps;

const float MAX_KERNEL_TEXELS = 48.0;
const float GOLDEN_ANGLE = 2.39996323;

int cube_face(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0 : 1;
    if (a.y >= a.z) return d.y > 0.0 ? 2 : 3;
    return d.z > 0.0 ? 4 : 5;
}

// Atlas uv of camera-relative point w; false when it falls outside its tile.
bool shadow_uv(vec3 w, vec3 light_pos, int cascade, out vec2 uv, out float z) {
    int k = shadow_radial ? (shadow_tiles == 6 ? cube_face(w - light_pos) : 0) : cascade;
    vec4 c = shadow_mats[k] * vec4(w, 1.0);
    if (c.w <= 0.0) return false;
    vec3 s = c.xyz / c.w;
    z = s.z;
    vec2 t = s.xy;
    uv = shadow_rects[k].xy + t * shadow_rects[k].zw;
    return all(greaterThanEqual(t, vec2(0.0))) && all(lessThanEqual(t, vec2(1.0)));
}

vec2 vogel(int i, int n, float rot) {
    float r = sqrt((float(i) + 0.5) / float(n));
    float th = float(i) * GOLDEN_ANGLE + rot;
    return r * vec2(cos(th), sin(th));
}

// 1 = lit, 0 = shadowed. p, n: receiver; light_pos: radial lights; dir: direction the
// sun's light travels; view_depth: the receiver's depth along the camera axis.
float shadow_factor(vec3 p, vec3 n, vec3 light_pos, vec3 dir, float view_depth) {
    int cascade = 0;
    float texel, scale;
    vec3 axis;
    if (shadow_radial) {
        float dist = length(p - light_pos);
        if (dist < 1e-5) return 1.0;           // a light on the surface: nothing between
        axis = (p - light_pos) / dist;
        texel = shadow_texel * dist;
        scale = shadow_far;
    } else {
        cascade = shadow_tiles;
        for (int i = shadow_tiles - 1; i >= 0; --i)
            if (view_depth <= shadow_splits[i]) cascade = i;
        if (cascade >= shadow_tiles) return 1.0;
        axis = dir;
        texel = shadow_texels[cascade];
        scale = shadow_ranges[cascade];
    }
    float NoL = clamp(-dot(n, axis), 0.0, 1.0);
    if (NoL <= 0.0) return 1.0;                // unlit anyway: no shadow to add
    float sin_t = sqrt(max(1.0 - NoL * NoL, 0.0));
    float tan_t = min(sin_t / max(NoL, 1e-3), 20.0);
    vec3 q = p + n * texel * (0.5 + 1.5 * sin_t);
    float ref;
    vec2 uv;
    if (shadow_radial) ref = length(q - light_pos);
    else {
        float z;
        if (!shadow_uv(q, light_pos, cascade, uv, z)) return 1.0;
        ref = z * scale;
    }
    float bias = texel * (1.0 + tan_t) + 1e-4 * ref;
    float inv_NoL = 1.0 / max(NoL, 0.05);
    vec3 t = normalize(cross(axis, abs(axis.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0)));
    vec3 b = cross(axis, t);
    // Interleaved gradient noise: rotates the tap pattern per pixel (noise, not bands).
    float rot = 6.2831853 * fract(52.9829189 * fract(dot(gl_FragCoord.xy, vec2(0.06711056, 0.00583715))));
    float max_kernel = MAX_KERNEL_TEXELS * texel;

    // Blocker search.
    float search = shadow_radial ? 2.0 * shadow_size : shadow_size * ref;
    search = clamp(search, texel, max_kernel);
    float blockers = 0.0, block_sum = 0.0;
    if (shadow_size > 0.0) {
        for (int i = 0; i < blocker_taps; ++i) {
            vec3 o = (t * vogel(i, blocker_taps, rot).x + b * vogel(i, blocker_taps, rot).y) * search;
            float z;
            if (!shadow_uv(q + o, light_pos, cascade, uv, z)) continue;
            float d = texture(shadow_raw, uv).r * scale;
            float plane = ref + clamp(dot(o, n) * inv_NoL, -search * 20.0, search * 20.0);
            if (d < plane - bias) { blockers += 1.0; block_sum += d; }
        }
        if (blockers == 0.0) return 1.0;
    }
    float kernel = texel * 1.5;
    if (blockers > 0.0) {
        float d_block = max(block_sum / blockers, 1e-6);
        float pen = shadow_radial ? shadow_size * (ref - d_block) / d_block
                                  : (ref - d_block) * shadow_size;
        kernel = clamp(pen, kernel, max_kernel);
    }

    // PCF, each tap a hardware bilinear compare.
    float lit = 0.0;
    for (int i = 0; i < pcf_taps; ++i) {
        vec2 v2 = vogel(i, pcf_taps, rot);
        vec3 o = (t * v2.x + b * v2.y) * kernel;
        float z;
        if (!shadow_uv(q + o, light_pos, cascade, uv, z)) { lit += 1.0; continue; }
        float plane = ref + clamp(dot(o, n) * inv_NoL, -kernel * 20.0, kernel * 20.0);
        lit += texture(shadow_cmp, vec3(uv, (plane - bias) / scale));
    }
    return lit / float(pcf_taps);
}
