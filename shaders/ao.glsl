#include "lib.glsl"
// Screen-space ambient occlusion (docs/design.md, Ambient occlusion), the fraction of a
// surface's cosine-weighted hemisphere that sees the dome within `radius` (Blender's AO
// distance), by a horizon search (GTAO, Jimenez et al. 2016) whose occluders have a
// thickness (a visibility bit mask, search below): per slice through the view
// vector, which directions of the normal's half circle the samples within the radius
// hide, and the cosine-weighted measure of the open ones, in closed form per sector,
// about the normal projected into the slice. `slices` directions (the preset's rays)
// x `steps` depth samples per side, rotated per pixel over a 4x4 tile (a Bayer
// pattern) that the bilateral blur (ao_blur.glsl) then averages away. Depth is read
// through lib.glsl's helpers.
// One more slice, through the surface's specular lobe (lib.glsl Lobe: its mean
// direction, and the cap that stands for it), gives the occlusion of the dome's
// reflections: the share of the lobe's arc in that slice the scene leaves open, over
// the share of it within the half circle. A mirror is lit where the scene leaves its
// direction open and black where it does not (as Cycles' direct light). (GTSO's cone
// about a bent normal counted a convex surface's few percent of estimator noise as a
// horizon all round, and blacked out a lone mirror sphere's rim; the AO slices seldom
// pass through a mirror's direction.) Output: (occlusion, specular occlusion, 0, 0).
// NEAR_FIELD (passes/near_field.py, a frame with an irradiance field): the same search
// within half the field's probe spacing, run on the lit frame; each sample also brings
// the lit colour of the sectors it is first to hide (nearest first: a visibility bit
// mask's indirect light, Therrien et al. 2023). Output: (the irradiance from the hidden
// sectors, the cosine-weighted share they hide): the near field the probes are too
// coarse to hold.
uniform sampler2D g_depth;
uniform sampler2D g_normal;
uniform sampler2D g_mat;       // roughness: the specular lobe (and dfg_lut, lib.glsl)
uniform mat4 inv_view_proj;
uniform vec3 cam_forward;
uniform bool cam_ortho;
uniform float radius;        // world units
uniform float thickness;     // of every occluder, along the view (world units)
uniform float pixel_scale;   // pixels per world unit at view depth 1 (orthographic: at any)
uniform float max_pixels;    // the search never reaches further across the screen
uniform int slices;
uniform int steps;
// Drawn at 1/u_step of the G-buffer's size per side (a supersampled frame's AO at the
// output's resolution): each AO pixel searches from the centre sub-pixel of its block.
uniform int u_step;
#ifdef NEAR_FIELD
uniform sampler2D u_lit;       // the lit opaque frame (lit_copy.py), at g_depth's size
#endif

// A 4x4 Bayer index in [0, 16): the tile's 16 pixels take 16 evenly spaced slice
// rotations, so the blur's average is a stratified quadrature over the half circle
// (random rotations over-weight some slice directions: -1.6 % on a grazing plane).
float bayer4(ivec2 p) {
    const int b[16] = int[16](0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5);
    return float(b[(p.y & 3) * 4 + (p.x & 3)]);
}

// The surface seen at window position w (pixels), on the camera ray through w itself,
// so every sample of a slice lies in the slice's plane: a texel centre off the line,
// or a texel's depth placed on it, lifts a grazing plane's horizon (-6 % on a floor).
// Window depth is affine in screen space on a plane, so the bilinear depth of the four
// texels around w is exact there; where one of them is the background, the texel w
// falls in.
vec3 position_at(vec2 w, out bool drawn) {
    vec2 f = w - 0.5;
    ivec2 b = clamp(ivec2(floor(f)), ivec2(0), textureSize(g_depth, 0) - 2);
    vec2 t = clamp(f - vec2(b), 0.0, 1.0);
    vec4 q = vec4(texelFetch(g_depth, b, 0).r, texelFetch(g_depth, b + ivec2(1, 0), 0).r,
                  texelFetch(g_depth, b + ivec2(0, 1), 0).r, texelFetch(g_depth, b + ivec2(1, 1), 0).r);
    float d = mix(mix(q.x, q.y, t.x), mix(q.z, q.w, t.x), t.y);
    if (is_background(q.x) || is_background(q.y) || is_background(q.z) || is_background(q.w)) {
#ifdef NEAR_FIELD
        // A texel's depth on another texel's ray lies off its surface: at a plane's
        // edge that lifts its horizon, which would swap the field's light for the
        // surface's own. The near field takes no sample on a silhouette.
        drawn = false;
        return vec3(0.0);
#endif
        d = texelFetch(g_depth, ivec2(w), 0).r;
    }
    drawn = !is_background(d);
    return position_from_depth(w / vec2(textureSize(g_depth, 0)), d, inv_view_proj);
}

// The geometric normal at px from the depth buffer (the neighbour on each axis whose
// depth is closer, so edges do not bend it): the normal of the facet the samples lie
// on. The interpolated shading normal would put neighbouring facets of a smooth,
// faceted surface above its tangent plane (a sphere darkened 5 % at its rim).
vec3 depth_normal(ivec2 px, vec3 p, vec3 fallback) {
    const float BIG = 1e30;      // a neighbour that is not there: never the nearer one
    ivec2 size = textureSize(g_depth, 0);
    bool drawn;
    vec3 best[2];
    for (int axis = 0; axis < 2; ++axis) {
        ivec2 e = axis == 0 ? ivec2(1, 0) : ivec2(0, 1);
        float sgn = 1.0;
        vec3 a = position_at(vec2(clamp(px + e, ivec2(0), size - 1)) + 0.5, drawn) - p;
        if (!drawn) a = vec3(BIG);
        vec3 b = p - position_at(vec2(clamp(px - e, ivec2(0), size - 1)) + 0.5, drawn);
        if (!drawn) b = vec3(BIG);
        best[axis] = dot(a, a) < dot(b, b) ? a : b;
        if (!(dot(best[axis], best[axis]) < BIG) || dot(best[axis], best[axis]) == 0.0) return fallback;
    }
    vec3 n = cross(best[0], best[1]);
    float len = length(n);
    if (len < 1e-20) return fallback;
    n /= len;
    return dot(n, fallback) < 0.0 ? -n : n;
}

// A slice through the view vector along screen direction dir (unit, pixels): its
// side axis (the direction of +dir across the view, unit), the angle of the normal
// projected into it (from v towards that side), the projected normal's length, and
// which of SECTORS equal sectors of that normal's half circle the scene hides, as a
// bit mask (a visibility bit mask, Therrien et al. 2023): each sample within the
// radius hides the angles from the direction of its surface point to that of the same
// point `thickness` further from the camera. A horizon alone (GTAO's) takes every
// occluder for infinitely thick: a cube beside another lost 56% of the dome where
// Cycles' loses 17%.
const int SECTORS = 32;
struct Slice { vec3 side; float angle_n, proj_len; uint hidden; vec3 gathered; };

// The cosine-weighted measure of the slice's directions from v up to angle x (signed),
// about the projected normal at angle nn: the integral of cos(t - nn) |sin t| (GTAO's
// arc, per side).
float arc_to(float x, float nn) {
    float g = -0.25 * cos(2.0 * x - nn) + 0.5 * x * sin(nn);
    return sign(x) * (g + 0.25 * cos(nn));
}

// The index of x's lowest set bit (x > 0; findLSB is GLSL 4.00): that bit alone is a
// power of two, which a float holds exactly, in its exponent.
int lowest_bit(uint x) { return int(floatBitsToUint(float(x & (~x + 1u))) >> 23) - 127; }

// The cosine-weighted measure of the sectors set in `mask` of the half circle about
// the projected normal at angle nn.
float mask_arc(uint mask, float nn) {
    float lo = nn - 0.5 * PI, sector = PI / float(SECTORS);
    // Summed run by run of set sectors, found by their bits (a loop over the sectors
    // would cost its every step on llvmpipe, which runs masked branches): arc_to at
    // the runs' ends only.
    uint open = mask;
    float sum = 0.0;
    while (open != 0u) {
        int first = lowest_bit(open);                    // the run's first sector
        uint hidden_above = ~open & (0xFFFFFFFFu << uint(first));
        int end = hidden_above == 0u ? SECTORS : lowest_bit(hidden_above);
        sum += arc_to(lo + float(end) * sector, nn) - arc_to(lo + float(first) * sector, nn);
        open = end >= SECTORS ? 0u : open & (0xFFFFFFFFu << uint(end));
    }
    return sum;
}

float slice_angle(vec3 d, vec3 side, vec3 v) { return atan(dot(d, side), dot(d, v)); }

Slice search(vec2 dir, vec2 centre, vec2 uv, float depth, vec3 p, vec3 v, vec3 n,
             float r_px, float jitter) {
    ivec2 size = textureSize(g_depth, 0);
    Slice sl;
    vec3 along = position_from_depth(uv + dir / vec2(size), depth, inv_view_proj) - p;
    vec3 ortho = along - dot(along, v) * v;
    sl.side = normalize(ortho);
    vec3 axis = normalize(cross(ortho, v));
    vec3 proj_n = n - axis * dot(n, axis);
    sl.proj_len = length(proj_n);
    sl.angle_n = slice_angle(proj_n, sl.side, v);
    sl.hidden = 0u;
    sl.gathered = vec3(0.0);
    float lo = sl.angle_n - 0.5 * PI, sector = PI / float(SECTORS);
    for (int side = 0; side < 2; ++side) {
        vec2 d = side == 0 ? dir : -dir;
        vec3 previous = vec3(0.0);
        float previous_angle = 0.0;
        bool chained = false;
        for (int j = 0; j < steps; ++j) {
            // Steps crowd near the pixel, where small occluders are.
            float t = (float(j) + jitter) / float(steps);
            float offset = max(t * t * r_px, float(j) + 1.0);
            if (offset > r_px) break;
            vec2 w = centre + d * offset;
            if (any(lessThan(w, vec2(0.0))) || any(greaterThanEqual(w, vec2(size)))) break;
            bool drawn;
            vec3 q = position_at(w, drawn);
            vec3 delta = q - p;
            float dist = length(delta);
            // Occluders fade out over the last fifth of the radius (half-way in).
            if (!drawn || dist < 1e-6 * length(p) || dist > 0.9 * radius) { chained = false; continue; }
            vec3 back = q + thickness * (cam_ortho ? cam_forward : normalize(q)) - p;
            float a = slice_angle(delta, sl.side, v), b = slice_angle(back, sl.side, v);
            // Two samples nearer each other than the thickness lie on one surface, which
            // hides the angles between them too (the steps are sparse far out: a wall
            // seen from the floor would show gaps).
            float from = min(a, b), to = max(a, b);
            if (chained && length(q - previous) < thickness) {
                from = min(from, previous_angle);
                to = max(to, previous_angle);
            }
            previous = q;
            previous_angle = a;
            chained = true;
            int first = max(int(ceil((from - lo) / sector - 0.5)), 0);
            int last = min(int(floor((to - lo) / sector - 0.5)), SECTORS - 1);
            if (last < first) continue;
            int count = last - first + 1;
            uint bits = (count >= 32 ? 0xFFFFFFFFu : ((1u << uint(count)) - 1u)) << uint(first);
#ifdef NEAR_FIELD
            // The lit colour of the sectors no nearer sample hid; a surface turned
            // away from p shows p its unseen side, whose light the frame does not hold.
            uint fresh = bits & ~sl.hidden;
            if (fresh != 0u && dot(texelFetch(g_normal, ivec2(w), 0).xyz, -delta) > 0.0)
                sl.gathered += texelFetch(u_lit, ivec2(w), 0).rgb * mask_arc(fresh, sl.angle_n);
#endif
            sl.hidden |= bits;
        }
    }
    return sl;
}

// The cosine-weighted share of the slice's half circle the scene leaves open, and the
// share of the angle interval [c - w, c + w] (within the half circle) it leaves open
// over the share of it the half circle holds (1 if none).
float open_arc(Slice sl) { return mask_arc(~sl.hidden, sl.angle_n); }

float open_interval(Slice sl, float c, float w) {
    float lo = sl.angle_n - 0.5 * PI, sector = PI / float(SECTORS);
    int first = clamp(int(floor((c - w - lo) / sector)), 0, SECTORS - 1);
    int last = clamp(int(floor((c + w - lo) / sector)), 0, SECTORS - 1);
    float inside = 0.0, seen = 0.0;
    for (int i = first; i <= last; ++i) {
        float a = lo + float(i) * sector;
        float overlap = max(min(a + sector, c + w) - max(a, c - w), 0.0);
        inside += overlap;
        if ((sl.hidden & (1u << uint(i))) == 0u) seen += overlap;
    }
    return inside > 1e-6 * w ? seen / inside : 1.0;
}

// A screen pass's body (engine/gpu/screen.py): one raw AO texel, `cell`.
void screen_pixel(ivec2 cell, out vec4 ao, out vec4 unused1, out vec4 unused2,
                  out vec4 unused3) {
    unused1 = unused2 = unused3 = vec4(0.0);
    ivec2 size = textureSize(g_depth, 0);
    // A block the image's edge cuts (a size that is not a multiple of the step) searches
    // from its last whole sub-pixel: its centre would lie outside the G-buffer.
    ivec2 px = min(cell * u_step + u_step / 2, size - 1);
    vec2 centre = vec2(px) + 0.5;
    float depth = texelFetch(g_depth, px, 0).r;
    ao = vec4(1.0, 1.0, 0.0, 0.0);
#ifdef NEAR_FIELD
    ao = vec4(0.0);                 // nothing gathered, nothing hidden
#endif
    if (is_background(depth)) return;
    vec2 uv = (vec2(px) + 0.5) / vec2(size);
    vec3 p = position_from_depth(uv, depth, inv_view_proj);
    vec3 v = cam_ortho ? -cam_forward : normalize(-p);
    vec3 shading_n = normalize(texelFetch(g_normal, px, 0).xyz);
    vec3 n = depth_normal(px, p, shading_n);
    // A normal turned away from the viewer (a back face seen at a silhouette) has no
    // visible hemisphere to search: take it as unoccluded.
    if (dot(n, v) <= 0.0) return;
    float z = cam_ortho ? 1.0 : max(dot(p, cam_forward), 1e-6);
    float r_px = min(radius * pixel_scale / z, max_pixels);
    if (r_px < 1.0) return;
    float rotation = (bayer4(cell) + 0.5) / 16.0;
    float jitter = (bayer4(cell.yx + ivec2(1, 2)) + 0.5) / 16.0;
    float visible = 0.0;
#ifdef NEAR_FIELD
    vec3 gathered = vec3(0.0);
    float hidden = 0.0;
#endif
#ifdef SPECULAR_ONLY
    // A frame whose diffuse light is the irradiance field's, which the occlusion does
    // not dim (passes/ao.py): only the specular lobe's slice is searched.
    visible = float(slices);
#else
    for (int s = 0; s < slices; ++s) {
        float phi = (float(s) + rotation) * PI / float(slices);
        Slice sl = search(vec2(cos(phi), sin(phi)), centre, uv, depth, p, v, n, r_px, jitter);
        visible += sl.proj_len < 1e-4 ? 1.0 : sl.proj_len * open_arc(sl);
#ifdef NEAR_FIELD
        if (sl.proj_len >= 1e-4) {
            gathered += sl.proj_len * sl.gathered;
            hidden += sl.proj_len * mask_arc(sl.hidden, sl.angle_n);
        }
#endif
    }
#ifdef NEAR_FIELD
    // Irradiance: pi x the radiance's cosine-weighted mean (the measure is 1 over the
    // whole hemisphere, as the occlusion's).
    ao = vec4(PI * gathered / float(slices), hidden / float(slices));
    return;
#endif
#endif
    // Not clamped: with few slices one pixel's estimate may pass 1 (a grazing plane's
    // steep slices weigh more than 1); the blur averages it to the true value first.
    ao.x = visible / float(slices);

    // The specular lobe's slice: its screen direction is that of the lobe's mean
    // direction across the view (in the basis of one-pixel steps at this depth). Seen
    // along v (that direction points at the camera) nothing on screen can hide it.
    // Its dielectric share by metallic alone (the ambient pass weighs it by the two
    // lobes' albedos; where the lobe points hardly depends on it).
    vec4 mat = texelFetch(g_mat, px, 0);
    Lobe lobe = make_lobe(shading_n, v, mat.y, 1.0 - clamp(mat.x, 0.0, 1.0));
    vec3 mean = lobe_mean(lobe);
    vec3 dir_l = length(mean) > 1e-6 ? normalize(mean) : shading_n;
    vec3 across = dir_l - dot(dir_l, v) * v;
    vec3 ex = position_from_depth(uv + vec2(1.0, 0.0) / vec2(size), depth, inv_view_proj) - p;
    vec3 ey = position_from_depth(uv + vec2(0.0, 1.0) / vec2(size), depth, inv_view_proj) - p;
    ex -= dot(ex, v) * v;
    ey -= dot(ey, v) * v;
    vec2 screen = inverse(mat2(dot(ex, ex), dot(ex, ey), dot(ex, ey), dot(ey, ey)))
                * vec2(dot(across, ex), dot(across, ey));
    if (length(across) < 1e-3 || length(screen) < 1e-12) return;
    Slice sl = search(normalize(screen), centre, uv, depth, p, v, n, r_px, jitter);
    ao.y = open_interval(sl, slice_angle(dir_l, sl.side, v), max(lobe_cone(lobe), 1e-3));
}
