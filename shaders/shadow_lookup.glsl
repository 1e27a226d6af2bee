// Shadow lookup for light.frag and transparent.frag (variant HAS_SHADOW; include
// after lights.glsl); the maps are made by engine/gpu/passes/shadows.py, which
// documents the layouts.
//
// Bias, in three parts (surface acne: docs/design.md, Shadow maps):
//  * normal offset: the receiver is moved off its surface by ~1 texel, more at grazing
//    angles (sin theta), so its own texel's depth never covers it;
//  * receiver-plane depth: every PCF/blocker tap compares against the depth the
//    receiver's own plane has at that tap (ref + dot(offset, n) / NoL), not the centre
//    depth, so wide kernels on slopes do not self-shadow;
//  * slope-scaled constant: texel * (1 + tan theta) for the depth quantisation and
//    the bilinear compare footprint, plus 1e-4 relative for float precision.
// Soft shadows (PCSS): a blocker search over the region that can occlude the light,
// then PCF with a kernel of the penumbra width: radius * (d_recv - d_block) / d_block
// for sphere lights, (d_recv - d_block) * tan(angle / 2) for the sun. Area lights
// (rect, disk) filter over their own extent: area_shadow_factor below.
uniform sampler2DShadow shadow_cmp;
uniform sampler2D shadow_raw;
uniform sampler2D shadow_exit;  // area lights: where the first caster ends (shadow_exits.py)
uniform bool shadow_exits;      // the map has that layer (else its far sides are unknown)
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
// A map with blended casters (stochastic: shadow.frag): the filter spans at least a
// screen pixel's footprint, (x * view depth + y) world units, so a pixel averages
// the texels it covers; (0, 0) otherwise.
uniform vec2 shadow_footprint;
uniform int pcf_taps;
uniform int blocker_taps;
// Glass casters' colour (passes/shadows.py _draw_tint): rgb the product of their faces'
// tints along a texel's ray, a the nearest glass's stored depth; none: shadow_tinted off.
uniform bool shadow_tinted;
uniform sampler2D shadow_tint;

const float MAX_KERNEL_TEXELS = 48.0;

// The stretch, in map-ambiguous lengths (the bias plus the filter's radius): a receiver
// at a distance x of a wall meets it along the light at x over the sun's slope, which
// the filter's lateral reach covers at elevations above about 15 degrees.
const float CONTACT_REACH = 4.0;

#ifdef CONTACT_RAYS
// Contact rays (docs/rendering.md, "Shadow seams"). Where an occluder meets its
// receiver (a wall on a floor, the seams of a room of zero-thickness walls), the bias
// that keeps a surface from shadowing itself, and a filter that reaches past the
// occluder's edge, let light through. In a frame that bounces light the scene's ray
// tracer is built (the irradiance field's), and a short any-hit ray from the receiver
// towards the light decides that stretch from the triangles themselves: a decision on
// the geometry, not on the map's texels, so it does not flip with a transform's last
// bits (it changes only where a ray grazes an edge). Past the stretch the map decides.
#include "raytrace.glsl"
uniform vec3 contact_eye;            // the camera's world position: the tracer's frame
// The ray starts at camera-relative q pulled towards the camera (raytrace.glsl
// rt_seen_origin) and reaches that much further (CONTACT below).
vec3 contact_origin(vec3 q) { return rt_seen_origin(q, contact_eye); }      // world

// `lit` (the map's), or 0 where the ray from camera-relative q (pulled) along
// `to_light` (unit) meets an opaque surface within `reach`.
#ifdef CONTACT_SEE_THROUGH
// A scene with cut-outs, blended surfaces or glass: they cast through the map's tested
// opacity alone, so the ray passes them. Per tracer material, whether it is opaque
// (engine/gpu/passes/shadows.py ContactRays).
layout(std430, binding = 9) readonly buffer ContactOpaque { int contact_opaque[]; };
// See-through surfaces a ray passes before the map decides alone.
const int CONTACT_LAYERS = 4;

float contact_limited(float lit, vec3 q, vec3 to_light, float reach) {
    if (lit <= 0.0) return lit;
    vec3 o = contact_origin(q);
    float tmin = 0.0;
    for (int i = 0; i < CONTACT_LAYERS; ++i) {
        RtHit hit;
        if (!rt_closest_hit(o, to_light, tmin, reach, hit)) return lit;
        int m = rt_hit_material(hit);
        if (m < 0 || contact_opaque[m] != 0) return 0.0;
        tmin = hit.t;
    }
    return lit;
}
#else
float contact_limited(float lit, vec3 q, vec3 to_light, float reach) {
    if (lit <= 0.0) return lit;
    return rt_any_hit(contact_origin(q), to_light, 0.0, reach) ? 0.0 : lit;
}
#endif
#define CONTACT(lit, q, to_light, reach) contact_limited(lit, q, to_light, (reach) + RT_SEEN_PULL * length(q))

// Where the ray is not needed: a sun's ray runs along one column of its map, and an
// occluder within its reach is a surface in front of the receiver there. Where no
// texel the blocker search read (nor q's own) holds a surface in front of the
// receiver's own plane, to float precision, nothing meets the receiver around q (open
// ground; a convex surface, which bends away from its plane), and the map's "lit"
// stands. A wall at a seam, a ball on the floor, a concave corner: in front of the
// plane, so the ray decides. The plane's depth at a texel's centre is
// `own_ref + dot(own_grad, centre - uv_q)`, world units: the map is read nearest, so
// the centre's, not the tap's, depth is what a lone plane leaves there.
bool behind_own_plane(float d, vec2 uv, vec2 uv_q, float own_ref, vec2 own_grad, float tol) {
    vec2 size = vec2(textureSize(shadow_raw, 0));
    vec2 centre = (floor(uv * size) + 0.5) / size;
    return d - own_ref - dot(own_grad, centre - uv_q) >= -tol;
}
#else
#define CONTACT(lit, q, to_light, reach) (lit)
#endif

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

// The sun's cascade a receiver at view_depth reads (shadow_tiles: beyond them all).
int shadow_cascade(float view_depth) {
    int cascade = shadow_tiles;
    for (int i = shadow_tiles - 1; i >= 0; --i)
        if (view_depth <= shadow_splits[i]) cascade = i;
    return cascade;
}

// The colour the glass between p (normal n) and the light gives its light: the tint
// map's where p lies behind the nearest glass along the light's ray, else white. One
// texel, unfiltered: the stochastic depth's filter draws the shadow's edge. Every
// glass face along the texel's ray tints, also those behind p (docs/status.md).
vec3 shadow_colour(vec3 p, vec3 n, vec3 light_pos, float view_depth) {
    if (!shadow_tinted) return vec3(1.0);
    int cascade = shadow_radial ? 0 : shadow_cascade(view_depth);
    if (cascade >= shadow_tiles) return vec3(1.0);
    float texel = shadow_radial ? shadow_texel * length(p - light_pos) : shadow_texels[cascade];
    vec3 q = p + n * texel;
    vec2 uv;
    float z;
    if (!shadow_uv(q, light_pos, cascade, uv, z)) return vec3(1.0);
    if (shadow_radial) z = length(q - light_pos) / shadow_far;
    vec4 t = textureLod(shadow_tint, uv, 0.0);
    return z > t.a + 1e-4 ? t.rgb : vec3(1.0);
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
        cascade = shadow_cascade(view_depth);
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
    vec3 to_light = -axis;
    float reach = CONTACT_REACH * (bias + 1.5 * texel);
    if (shadow_radial) reach = min(reach, 0.99 * length(light_pos - q));
    vec3 t = normalize(cross(axis, abs(axis.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0)));
    vec3 b = cross(axis, t);
    // Interleaved gradient noise: rotates the tap pattern per pixel (noise, not bands).
    float rot = 6.2831853 * fract(52.9829189 * fract(dot(pixel_centre(), vec2(0.06711056, 0.00583715))));
    float max_kernel = MAX_KERNEL_TEXELS * texel;

    // Blocker search.
    float search = shadow_radial ? 2.0 * shadow_size : shadow_size * ref;
    search = clamp(search, texel, max_kernel);
    float blockers = 0.0, block_sum = 0.0;
    // Whether the map holds nothing in front of the receiver's plane around q
    // (behind_own_plane): then a contact ray would meet nothing. Only a sun's search
    // (its rays are its map's columns).
    bool alone = false;
#ifdef CONTACT_RAYS
    vec2 uv_q = uv, own_grad = vec2(0.0);
    float own_ref = ref + texel * (0.5 + 1.5 * sin_t) / NoL;  // p's plane under q
    float own_tol = 0.05 * texel + 1e-5 * scale;
    if (!shadow_radial && shadow_size > 0.0 && NoL >= 0.05) {
        // The plane's depth gradient over the tile's uv, from its gradient over the
        // light's tangent plane (t, b): along o it changes by dot(o, n) / NoL.
        vec2 zw = shadow_rects[cascade].zw;
        mat3 m = mat3(shadow_mats[cascade]);
        mat2 uv_of_tb = mat2((m * t).xy * zw, (m * b).xy * zw);
        own_grad = inverse(transpose(uv_of_tb)) * vec2(dot(t, n), dot(b, n)) / NoL;
        alone = behind_own_plane(texture(shadow_raw, uv_q).r * scale, uv_q, uv_q, own_ref,
                                 own_grad, own_tol);
    }
#endif
    if (shadow_size > 0.0) {
        for (int i = 0; i < blocker_taps; ++i) {
            vec3 o = (t * vogel(i, blocker_taps, rot).x + b * vogel(i, blocker_taps, rot).y) * search;
            float z;
            if (!shadow_uv(q + o, light_pos, cascade, uv, z)) { alone = false; continue; }
            float d = texture(shadow_raw, uv).r * scale;
            float plane = ref + clamp(dot(o, n) * inv_NoL, -search * 20.0, search * 20.0);
            if (d < plane - bias) { blockers += 1.0; block_sum += d; }
#ifdef CONTACT_RAYS
            alone = alone && behind_own_plane(d, uv, uv_q, own_ref, own_grad, own_tol);
#endif
        }
        if (blockers == 0.0) return alone ? 1.0 : CONTACT(1.0, q, to_light, reach);
    }
    float kernel = max(texel * 1.5, 0.75 * (shadow_footprint.x * view_depth + shadow_footprint.y));
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
    return CONTACT(lit / float(pcf_taps), q, to_light, reach);
}

// --- Area lights (rect, disk): PCSS over the light's extent ------------------------
// Every tap, of the blocker search and of the filter, stands for a point l of the
// light itself (a jittered Fibonacci lattice over [-1, 1]^2 for a rect, over the unit
// disk for a disk). The ray from the receiver q to l crosses the distance d (from the
// light's centre c, the map's origin) where the map's ray from c through
// q + (l - c)(D - d) / d does (D = |q - c|): so the taps are the light's own shape,
// scaled by (D - d) / d and laid in the light's own plane, and the penumbra has the
// light's size, shape and orientation, foreshortened as the receiver sees it. Each
// tap is weighted by what its point of the light sends the receiver (the cosines at
// both ends over the squared distance), so the result is the visible fraction of the
// light's irradiance, the quantity Cycles integrates.
//  1. Blocker search over the shape scaled by AREA_SEARCH (blockers from halfway to
//     the receiver on): their mean distance d_b, or fully lit without any.
//  2. Per tap, PCSS at d_b; where its ray meets an occluder at z, the tap looks again
//     at z's own scale (z, not d_b, is where that occluder crosses the segment to l),
//     so an occluder seen at the wrong depth (a floor beside a wall) does not shadow.
//  3. A tap still lit is marched: AREA_MARCH_STEPS points of the segment q -> l
//     between the blockers' nearest and farthest distances. A point up to 1.5 steps
//     behind the surface the map holds there, and at most half a step past that
//     caster's far side (the exit layer, passes/shadow_exits.py), is inside an
//     occluder; so is a segment that crosses a caster between two points (one in
//     front of it, the next past its far side). This finds what one mean depth
//     misses: contact shadows, occluders at several depths. (No thicker: a point just
//     behind an occluder's silhouette seen from c, where its chord is thin, would
//     count as inside it and speckle lit surfaces. Without the far side, a segment
//     passing beside a thin slab did, and a table's penumbra on the floor was 30-60%
//     too dark at its outer edge; with a whole step's margin past it, where the
//     crossing now stands, still 10-35%. Half a step is kept for a box's far side,
//     which one texel reads short by its silhouettes: a margin of none left the
//     penumbra of a box 4-6% too bright.)
// Compares are against the receiver's tangent plane along each ray (receiver-plane
// depth, exact for a planar receiver), never beyond the map's range.
const float AREA_SEARCH = 1.0;
// The last area_shadow_factor's penumbra width on the receiver (world; 0 where no
// blocker was found), the narrowest of the blockers' mean depth's and of what the march
// found (a contact shadow): how far its filter may blur (area_visibility_blur.glsl).
float area_penumbra = 0.0;
const int AREA_MARCH_STEPS = 6;     // 4 missed thin casters once the far side bounds them

vec2 lattice(int i, int n, vec2 jitter) {          // [0, 1)^2
    return fract(vec2((float(i) + 0.5) / float(n), float(i) * 0.6180340) + jitter);
}

// Where a pixel's taps start on the lattice, in [0, 1): AREA_INTERLEAVED (a filtered
// visibility, area_visibility.glsl), the pixel's cell of its 4 x 4 block, so a block's
// 16 pixels take 16 evenly spread offsets of the lattice and their blur averages all
// of them; else interleaved gradient noise (noise, not bands, where nothing filters).
float tap_phase() {
#ifdef AREA_INTERLEAVED
    return (float(bayer4(uvec2(pixel_centre()))) + 0.5) / 16.0;
#else
    return fract(52.9829189 * fract(dot(pixel_centre(), vec2(0.06711056, 0.00583715))));
#endif
}

vec2 shape_point(vec2 u, bool disk) {              // [-1, 1]^2, or the unit disk
    if (disk) {
        float r = sqrt(u.x), a = 6.2831853 * u.y;
        return r * vec2(cos(a), sin(a));
    }
    return 2.0 * u - 1.0;
}

// The depth to compare a map texel with, along the map's ray from c through w: where
// that ray meets the receiver's tangent plane (through q, normal n), less the depth a
// texel spans there at that slope (and 1e-4 relative), and never beyond the map's
// range, whose cleared texels (nothing drawn) are then never blockers. 0 when the
// ray never reaches the plane: nothing there to shadow.
float plane_ref(vec3 w, vec3 q, vec3 n, vec3 c) {
    vec3 d = w - c;
    float cos_r = -dot(d, n) / max(length(d), 1e-12);
    if (cos_r <= 1e-4) return 0.0;
    float dist = dot(c - q, n) / cos_r;
    float tan_r = min(sqrt(max(1.0 - cos_r * cos_r, 0.0)) / cos_r, 20.0);
    float ref = dist - shadow_texel * dist * (1.0 + tan_r) - 1e-4 * dist;
    return min(ref, 0.999 * shadow_far);
}

const float NO_SURFACE = 1e30;

// The map's raw distance along the ray from c through w; NO_SURFACE outside the map.
float map_distance(vec3 w, vec3 c) {
    vec2 uv;
    float z;
    if (!shadow_uv(w, c, 0, uv, z)) return NO_SURFACE;
    return texture(shadow_raw, uv).r * shadow_far;
}

// The map's raw distance and where that caster ends (the exit layer), along the ray
// from c through w; NO_SURFACE for both outside the map. Area lights' maps only.
vec2 map_layers(vec3 w, vec3 c) {
    vec2 uv;
    float z;
    if (!shadow_uv(w, c, 0, uv, z)) return vec2(NO_SURFACE);
    return vec2(texture(shadow_raw, uv).r * shadow_far,
                shadow_exits ? texture(shadow_exit, uv).r * shadow_far : NO_SURFACE);
}

// The filtered (bilinear compare) visibility along the ray from c through w.
float map_visible(vec3 w, vec3 q, vec3 n, vec3 c) {
    vec2 uv;
    float z;
    if (!shadow_uv(w, c, 0, uv, z)) return 1.0;
    return texture(shadow_cmp, vec3(uv, plane_ref(w, q, n, c) / shadow_far));
}

// 1 = lit, 0 = shadowed, for the area light centred at c (camera-relative) with unit
// axes x, y in its plane, half extents `half_extent` (a disk: its semi-axes, which
// differ for an ellipse), emitting along `axis`. p, n: the receiver; view_depth: its depth along the camera
// axis (the footprint of a map with blended casters).
float area_shadow_factor(vec3 p, vec3 n, vec3 c, vec3 x, vec3 y, vec2 half_extent,
                         bool disk, vec3 axis, float view_depth) {
    area_penumbra = 0.0;
    float dist = length(p - c);
    if (dist < 1e-5) return 1.0;
    vec3 dir = (p - c) / dist;
    float texel = shadow_texel * dist;
    float NoL = clamp(-dot(n, dir), 0.0, 1.0);
    if (NoL <= 0.0) return 1.0;                // facing away from the centre: unshadowed
    float sin_t = sqrt(max(1.0 - NoL * NoL, 0.0));
    float tan_t = min(sin_t / max(NoL, 1e-3), 20.0);
    vec3 q = p + n * texel * (0.5 + 1.5 * sin_t);
    float D = length(q - c);
    vec3 ex = x * half_extent.x, ey = y * half_extent.y;
    float ign = tap_phase();
    vec2 jitter = vec2(ign / float(blocker_taps), fract(ign * 1.6180340 + 0.5));

    float blockers = 0.0, block_sum = 0.0, nearest = NO_SURFACE, farthest = 0.0;
    for (int i = 0; i < blocker_taps; ++i) {
        vec2 s = shape_point(lattice(i, blocker_taps, jitter), disk);
        vec3 w = q + (ex * s.x + ey * s.y) * AREA_SEARCH;
        float d = map_distance(w, c);
        if (d < plane_ref(w, q, n, c)) {
            blockers += 1.0;
            block_sum += d;
            nearest = min(nearest, d);
            farthest = max(farthest, d);
        }
    }
    if (blockers == 0.0) return 1.0;
    float d_block = max(block_sum / blockers, 1e-6);
    float k = max(D - d_block, 0.0) / d_block;
    // At least a screen pixel's footprint over blended casters (shadow_footprint).
    float least = 0.75 * (shadow_footprint.x * view_depth + shadow_footprint.y);
    k = max(k, least / max(max(half_extent.x, half_extent.y), 1e-9));
    area_penumbra = 2.0 * k * max(half_extent.x, half_extent.y);
    float lo = 0.9 * nearest, hi = min(1.1 * farthest, 0.99 * D);
    float step = max(hi - lo, 0.0) / float(AREA_MARCH_STEPS);
    float thickness = 1.5 * step;
    float offset = fract(ign * 7.0 + 0.5);

    float lit = 0.0, total = 0.0;
    vec2 jitter2 = vec2(ign / float(pcf_taps), fract(ign * 1.6180340 + 0.5698403));
    for (int i = 0; i < pcf_taps; ++i) {
        vec2 s = shape_point(lattice(i, pcf_taps, jitter2), disk);
        vec3 e = ex * s.x + ey * s.y;          // the light's point, from its centre
        vec3 l = c + e;
        vec3 to_l = l - p;
        float d2 = max(dot(to_l, to_l), 1e-12);
        float wgt = max(dot(n, to_l), 0.0) * max(-dot(axis, to_l), 0.0) / (d2 * d2);
        if (wgt <= 0.0) continue;
        total += wgt;
        vec3 w = q + e * k;
        float z0 = map_distance(w, c);
        if (z0 < plane_ref(w, q, n, c))
            w = q + e * (max(D - z0, 0.0) / max(z0, 1e-6));
        float v = map_visible(w, q, n, c);
        float before = NO_SURFACE;             // the last point's caster, were it in front of it
        for (int j = 0; j < AREA_MARCH_STEPS && v > 0.0; ++j) {
            vec3 m = l + (q - l) * ((lo + (float(j) + offset) * step) / D);
            float r = length(m - c);
            vec2 layers = map_layers(m, c);
            float surface = layers.x;
            float bias = shadow_texel * r * (1.0 + tan_t) + 1e-4 * r;
            bool behind = surface + bias <= r;
            bool inside = behind && r <= min(surface + thickness, layers.y + 0.5 * step);
            // Crossed between two points: in front of a caster, then past the far side
            // of the same one (its front within a step of the last point's).
            bool crossed = behind && r > layers.y && abs(surface - before) <= step;
            before = behind ? NO_SURFACE : surface;
            if (inside || crossed) {
                v = 0.0;
                // An occluder the blockers' mean depth misses: its own, narrower penumbra.
                float t = length(m - q);
                area_penumbra = min(area_penumbra, 2.0 * max(half_extent.x, half_extent.y)
                                                   * t / max(D - t, 1e-6));
            }
        }
        lit += wgt * v;
    }
    return total > 0.0 ? lit / total : 1.0;
}

#ifdef AREA_VISIBILITY
uniform sampler2D area_visibility;  // this light's, filtered (area_visibility.glsl)
#endif

// The loaded light's shadow colour: what glass before it gives its light (white: none).
vec3 light_shadow_colour(vec3 p, vec3 n, float view_depth) {
    return shadow_colour(p, n, light_pos, view_depth);
}

// The loaded light's shadow (lights.glsl's globals), of any of the program's kinds
// (lights.glsl LIGHT_DISTANT, LIGHT_SPHERE, LIGHT_AREA); AREA_VISIBILITY: an area
// light's, filtered, at this pixel (the G-buffer's surfaces only).

float light_shadow(vec3 p, vec3 n, float view_depth) {
#ifdef AREA_VISIBILITY
    if (n_poly > 0) return texelFetch(area_visibility, ivec2(pixel_centre()), 0).r;
#endif
#ifdef LIGHT_AREA
    if (n_poly > 0)
        return area_shadow_factor(p, n, light_pos, light_x, light_y,
                                  half_size, is_disk,
                                  light_axis, view_depth);
#endif
#if defined(LIGHT_DISTANT) || defined(LIGHT_SPHERE)
    return shadow_factor(p, n, light_pos, light_axis, view_depth);
#else
    return 1.0;
#endif
}
