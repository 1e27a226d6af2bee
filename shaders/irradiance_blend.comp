#version 430 core
// The irradiance field's maps from one update's rays (engine/gpu/passes/irradiance.py):
// one invocation a texel of a probe's 8 x 8 map, which also writes the tile's border
// texels that repeat it (the map's opposite edge: copies, not made again), irradiance
// as the cosine-weighted mean of the rays' radiance (times pi: the mean over the sphere
// of max(cos, 0) is 1/4), distance and its square weighted by a sharp power of the
// cosine (Majercik et al. 2019), and the nearest hits about the texel and their planes,
// over the rays of all the build's updates traced from the probe's place (as the
// steady light below). The map's first texel also moves its probe
// and switches it off or on (Majercik et al. 2021): a probe whose rays meet many back
// faces close by lies inside geometry: off, and moved out through the nearest back face;
// one closer to a surface (either side) than a fifth of the spacing is moved away; never more
// than 0.45 of the spacing from its grid place.
#include "irradiance_field.glsl"
layout(local_size_x = 8, local_size_y = 8) in;      // FIELD_TEXELS
layout(rgba32f, binding = 0) writeonly uniform image2D irradiance_image;
layout(rgba32f, binding = 1) writeonly uniform image2D distance_image;
layout(rgba32f, binding = 2) writeonly uniform image2D probe_image;
// The planes of two hits about each texel's direction (irradiance_field.glsl field_planes):
// the nearest, in the upper atlas, and the nearest off that plane, in the lower.
layout(rgba32f, binding = 3) writeonly uniform image2D plane_image;
// Per texel, what the build's updates so far saw of the light that does not change from
// one to the next (emission, the lights, the dome: all but the field's bounces), as its
// mean over them, and how many updates that mean holds: each update's rays are new (a new
// rotation), so the field takes that light from all of them, and only its bounces from
// the last (which brings one more). A probe moved starts it again. Each probe's texels
// are its own: an update spread over dispatches gives what one dispatch gives.
layout(rgba32f, binding = 4) uniform image2D steady_image;
shared bool moved;
uniform sampler2D field_rays;        // irradiance_trace.comp's ray_image
uniform mat3 u_rotation;
uniform int u_rays;
uniform bool u_bounce;               // not the first update: probes as it left them
uniform int u_first_probe;           // the first probe of those this dispatch updates
uniform float u_max_distance[FIELD_GRIDS];   // by grid: distances are clamped there
                                             // (beyond a cell: seen)
// The nearest hit within this cosine of a texel's direction: what a zero-thickness wall's
// edge hides from the mean, which rays past the edge pull far. A cone that holds about
// the same number of the build's rays whatever their count (irradiance.py near_cone).
uniform float u_near_cone;

// A hit's plane: its normal, towards the probe, and its offset from the probe along it.
vec4 hit_plane(int ray, int probe, vec3 r, float distance) {
    vec3 normal = texelFetch(field_rays, ivec2(u_rays + ray, probe), 0).xyz;
    return vec4(normal, dot(distance * r, normal));
}

// Whether a hit's plane is another surface's than `plane`'s (turned or moved from it).
bool off_plane(vec4 candidate, vec4 plane, float spacing) {
    return dot(candidate.xyz, plane.xyz) < 0.9 || abs(candidate.w - plane.w) > 0.05 * spacing;
}

// Where the tile holds interior texel s (1..N), its own place and the border texels
// that repeat it (an edge's its mirror image along the edge, a corner's the opposite
// corner), as offsets in the tile: `count` of the four.
int places(ivec2 s, out ivec2 at[4]) {
    const int N = FIELD_TEXELS;
    int count = 0;
    at[count++] = s;
    if (s.x == 1 || s.x == N) at[count++] = ivec2(s.x == 1 ? 0 : N + 1, N + 1 - s.y);
    if (s.y == 1 || s.y == N) at[count++] = ivec2(N + 1 - s.x, s.y == 1 ? 0 : N + 1);
    if ((s.x == 1 || s.x == N) && (s.y == 1 || s.y == N))
        at[count++] = ivec2(s.x == 1 ? N + 1 : 0, s.y == 1 ? N + 1 : 0);
    return count;
}

void main() {
    int probe = u_first_probe + int(gl_WorkGroupID.x);
    int g = probe_grid(probe);
    float max_distance = u_max_distance[g];
    vec3 step = field_step[g];
    ivec2 t = ivec2(gl_LocalInvocationID.xy);
    vec3 d = oct_decode((vec2(t) + 0.5) / float(FIELD_TEXELS) * 2.0 - 1.0);
    ivec2 tile = probe_tile(probe) * (FIELD_TEXELS + 2);
    ivec2 at = tile + t + 1;
    ivec2 lines = ivec2(0, imageSize(plane_image).y / 2);
    // The nearest hits of the build's updates so far, where they were traced from this
    // place (the steady light's count: a probe moved starts it again). Walls do not change
    // from one update to the next and each update's rays are new, so a texel's cone holds
    // all their rays: one update's one or two there can meet a wall seen at a grazing
    // angle far beyond a point it hides, where others meet it nearer.
    vec4 steady = imageLoad(steady_image, at);
    bool earlier = u_bounce && steady.a > 0.0;
    vec4 seen = earlier ? texelFetch(field_distance, at, 0) : vec4(max_distance);
    vec4 seen_plane = earlier ? texelFetch(field_planes, at, 0) : vec4(0.0);
    vec4 seen_other = earlier ? texelFetch(field_planes, at + lines, 0) : vec4(0.0);
    vec3 sum = vec3(0.0), bounced = vec3(0.0);
    float total = 0.0, dist = 0.0, dist2 = 0.0, dist_total = 0.0, nearest = seen.b;
    vec4 plane = seen_plane;         // (0: no hit about d, nothing lies behind)
    int nearest_ray = -1;            // the nearest hit, where it is this update's
    int backs = 0;
    float nearest_front = 1.0e30, nearest_back = 1.0e30;
    vec3 front_dir = vec3(0.0), back_dir = vec3(0.0);
    float farthest = 0.0;
    for (int i = 0; i < u_rays; ++i) {
        vec3 r = fibonacci_ray(i, u_rays, u_rotation);
        vec4 h = texelFetch(field_rays, ivec2(i, probe), 0);
        float c = dot(d, r);
        if (c > 0.0) {
            sum += c * h.rgb;
            bounced += c * texelFetch(field_rays, ivec2(2 * u_rays + i, probe), 0).rgb;
            total += c;
            float w = pow(c, 50.0);
            float s = min(abs(h.w), max_distance);
            dist += w * s;
            dist2 += w * s * s;
            dist_total += w;
            if (c > u_near_cone && s < nearest) {
                nearest = s;
                nearest_ray = i;
            }
        }
        if (t == ivec2(0)) {
            float a = abs(h.w);
            farthest = max(farthest, a);
            if (h.w < 0.0) {
                backs += 1;
                if (a < nearest_back) { nearest_back = a; back_dir = r; }
            } else if (a < nearest_front) { nearest_front = a; front_dir = r; }
        }
    }
    vec2 m = dist_total > 0.0 ? vec2(dist, dist2) / dist_total : vec2(max_distance, max_distance * max_distance);
    // The nearest hit off the nearest one's plane: a floor near the probe must not hide
    // the wall behind it (the floor's plane has the point in front, the wall's behind).
    float spacing = min(step.x, min(step.y, step.z));
    float other = max_distance;
    vec4 other_plane = vec4(0.0);
    if (nearest_ray >= 0)
        plane = hit_plane(nearest_ray, probe, fibonacci_ray(nearest_ray, u_rays, u_rotation),
                          abs(texelFetch(field_rays, ivec2(nearest_ray, probe), 0).w));
    if (nearest < max_distance) {
        for (int i = 0; i < u_rays; ++i) {
            vec3 r = fibonacci_ray(i, u_rays, u_rotation);
            if (dot(d, r) <= u_near_cone) continue;
            float a = abs(texelFetch(field_rays, ivec2(i, probe), 0).w);
            if (a >= min(other, max_distance)) continue;
            vec4 candidate = hit_plane(i, probe, r, a);
            if (off_plane(candidate, plane, spacing)) {
                other = a;
                other_plane = candidate;
            }
        }
        // The earlier updates' two: the nearest is another's where this update's is nearer.
        if (seen.b < other && off_plane(seen_plane, plane, spacing)) {
            other = seen.b;
            other_plane = seen_plane;
        }
        if (seen.a < other && off_plane(seen_other, plane, spacing)) {
            other = seen.a;
            other_plane = seen_other;
        }
    }
    vec4 distances = vec4(m, nearest, other);
    if (t == ivec2(0)) {
        vec4 state = u_bounce ? probe_state(probe) : vec4(0.0, 0.0, 0.0, 1.0);
        bool inside = float(backs) > 0.25 * float(u_rays) && farthest < 1.5 * length(step);
        vec3 offset = state.xyz;
        if (inside)
            offset += back_dir * (nearest_back + 0.1 * spacing);
        else if (min(nearest_front, nearest_back) < 0.2 * spacing) {
            // Away from the nearest surface, whichever side of it faces the probe.
            bool front = nearest_front < nearest_back;
            offset -= (front ? front_dir : back_dir) * (0.2 * spacing - min(nearest_front, nearest_back));
        }
        offset = clamp(offset, -0.45 * step, 0.45 * step);
        imageStore(probe_image, probe_tile(probe), vec4(offset, inside ? 0.0 : 1.0));
        moved = offset != state.xyz || inside != (state.w < 0.5);
    }
    barrier();
    vec3 mean = total > 0.0 ? (steady.rgb * steady.a + FIELD_PI * sum / total) / (steady.a + 1.0)
                            : vec3(0.0);
    vec4 kept = vec4(mean, moved ? 0.0 : steady.a + 1.0);
    vec4 irradiance = vec4(mean + (total > 0.0 ? FIELD_PI * bounced / total : vec3(0.0)), 1.0);
    ivec2 where[4];
    int count = places(t + 1, where);
    for (int i = 0; i < count; ++i) {
        ivec2 p = tile + where[i];
        imageStore(distance_image, p, distances);
        imageStore(plane_image, p, plane);
        imageStore(plane_image, p + lines, other_plane);
        imageStore(steady_image, p, kept);
        imageStore(irradiance_image, p, irradiance);
    }
}
