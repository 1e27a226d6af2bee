// The irradiance field (engine/gpu/passes/irradiance.py; Majercik et al. 2019, "Dynamic
// Diffuse Global Illumination with Ray-Traced Irradiance Fields", and 2021, "Scaling
// Probe-Based Real-Time Dynamic GI for Production"): a grid of probes over the scene's
// bounds, each holding, in small octahedral maps, the irradiance arriving from every
// direction and the mean distance (and its square) to what its rays hit. Read per
// point with a visibility test (Chebyshev) against those distances, so light from a
// probe beyond a wall does not reach a surface on this side. World space throughout.
//
// Atlas layout: a probe is a tile of (FIELD_TEXELS + 2)^2 texels, its octahedral map
// inside a one-texel border that repeats the map's opposite edge (so bilinear filtering
// wraps across the octahedron's seams); field_tiles tiles a line. field_probes: one
// texel a probe at its tile's place, (offset from its grid place, 1 on / 0 off).
// field_distance: per texel (mean distance, mean squared distance, the nearest hit about
// its direction, the nearest hit off that one's plane: those two of all the build's
// updates' rays, irradiance_blend.comp); field_planes: two atlases, one
// above the other: those two hits' planes (normal towards the probe, offset from the probe
// along it; 0 where there is none).
//
// Grids: one over the bounds, or, where the bounds are large, nested cascades about the
// camera, finest first, the last over the bounds (irradiance.py cascades). Their probes
// follow each other in the atlas. A point reads the finest that holds it, blended into
// the next over the cell inside its region's edge.
#define FIELD_TEXELS 8
#define FIELD_GRIDS 8               // at most (irradiance.py GRIDS)
uniform int field_grids;            // grids in use
uniform vec3 field_lo[FIELD_GRIDS];      // a grid's probe (0, 0, 0), before its offset
uniform vec3 field_step[FIELD_GRIDS];    // its probe spacing
uniform ivec3 field_counts[FIELD_GRIDS]; // its probes along each axis
uniform int field_first[FIELD_GRIDS];    // its first probe in the atlas
uniform vec3 field_region_lo[FIELD_GRIDS];  // where it is whole (its probes' box; far
uniform vec3 field_region_hi[FIELD_GRIDS];  // beyond, on a side at the bounds' edge)
uniform int field_tiles;        // tiles a line
uniform float field_bias;       // the self-shadowing bias (a share of the spacing)
const float FIELD_BIAS_ALONG_N = 0.2;   // of it along the normal,
const float FIELD_BIAS_ALONG_V = 0.8;   // and along v, towards the viewer
uniform sampler2D field_irradiance;   // rgb: irradiance E (W/m2 per unit radiance)
uniform sampler2D field_distance;
uniform sampler2D field_probes;
uniform sampler2D field_planes;

const float FIELD_PI = 3.14159265358979;

vec2 oct_encode(vec3 d) {
    vec3 a = d / (abs(d.x) + abs(d.y) + abs(d.z));
    vec2 e = a.xy;
    if (a.z < 0.0) e = (1.0 - abs(a.yx)) * vec2(a.x >= 0.0 ? 1.0 : -1.0, a.y >= 0.0 ? 1.0 : -1.0);
    return e;
}

vec3 oct_decode(vec2 e) {
    vec3 d = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (d.z < 0.0) d.xy = (1.0 - abs(d.yx)) * vec2(d.x >= 0.0 ? 1.0 : -1.0, d.y >= 0.0 ? 1.0 : -1.0);
    return normalize(d);
}

// Ray i of n from a probe: a spherical Fibonacci point set (even over the sphere),
// turned by `rotation` (a new one each update, so updates do not repeat their rays).
vec3 fibonacci_ray(int i, int n, mat3 rotation) {
    float phi = 2.0 * FIELD_PI * fract(float(i) * 0.6180339887498949);
    float z = 1.0 - (2.0 * float(i) + 1.0) / float(n);
    float r = sqrt(max(1.0 - z * z, 0.0));
    return rotation * vec3(cos(phi) * r, sin(phi) * r, z);
}

int probe_index(int g, ivec3 c) {
    return field_first[g] + c.x + field_counts[g].x * (c.y + field_counts[g].y * c.z);
}
ivec2 probe_tile(int probe) { return ivec2(probe % field_tiles, probe / field_tiles); }

vec4 probe_state(int probe) { return texelFetch(field_probes, probe_tile(probe), 0); }

vec3 probe_position(int g, ivec3 c, vec4 state) {
    return field_lo[g] + vec3(c) * field_step[g] + state.xyz;
}

int probe_grid(int probe) {
    int g = 0;
    for (int i = 1; i < field_grids; ++i)
        if (probe >= field_first[i]) g = i;
    return g;
}

ivec3 probe_cell(int g, int probe) {
    int i = probe - field_first[g];
    ivec3 n = field_counts[g];
    return ivec3(i % n.x, (i / n.x) % n.y, i / (n.x * n.y));
}

// Where direction d lies in a probe's map, as the atlas' normalised coordinates.
vec2 field_uv(sampler2D atlas, int probe, vec3 d) {
    vec2 texel = vec2(probe_tile(probe) * (FIELD_TEXELS + 2)) + 1.0
               + (oct_encode(d) * 0.5 + 0.5) * float(FIELD_TEXELS);
    return texel / vec2(textureSize(atlas, 0));
}

// Whether a wall the probe sees hides the point at `from_probe` (r away) from it: about
// its direction (the four texels about uv, unfiltered: filtering would blend a near wall's
// edge with the far side beyond it) the probe saw a hit nearer than the point, and the
// point lies behind that hit's plane. A nearer hit alone is no wall: where the probe sees
// the point's own surface at a slant, rays a little steeper meet that surface nearer than
// the point, which lies in front of its plane (a test of distance alone left a floor seen
// from probes beside a table black in patches).
bool field_hidden(vec2 uv, vec3 from_probe, float r) {
    ivec2 t = ivec2(floor(uv * vec2(textureSize(field_distance, 0)) - 0.5));
    ivec2 lines = ivec2(0, textureSize(field_planes, 0).y / 2);
    for (int k = 0; k < 4; ++k) {
        ivec2 at = t + ivec2(k & 1, k >> 1);
        vec2 nearest = texelFetch(field_distance, at, 0).ba;
        vec4 plane = texelFetch(field_planes, at, 0), other = texelFetch(field_planes, at + lines, 0);
        if ((r > nearest.x && dot(from_probe, plane.xyz) < plane.w) ||
            (r > nearest.y && dot(from_probe, other.xyz) < other.w))
            return true;
    }
    return false;
}

// The irradiance at world point p on a surface of normal n seen along v (towards the
// viewer; n for a ray's hit): the eight probes of its cell, each weighted by trilinear
// position, by whether it lies in front of the surface, and by the chance (Chebyshev,
// from its mean and squared distances) that it sees the point, which goes to 0 behind a
// wall. 0 where no probe sees the point. `along`: the direction whose irradiance is
// read (n for the surface's own; a reflection's direction for a rough lobe's light).
// Grid `grid`'s probes alone.
vec3 grid_irradiance_along(int grid, vec3 p, vec3 n, vec3 v, vec3 along) {
    vec3 lo = field_lo[grid], step = field_step[grid];
    ivec3 counts = field_counts[grid];
    float spacing = min(step.x, min(step.y, step.z));
    vec3 q = p + (FIELD_BIAS_ALONG_N * n + FIELD_BIAS_ALONG_V * v) * field_bias * spacing;
    vec3 g = clamp((q - lo) / step, vec3(0.0), vec3(counts - 1));
    ivec3 base = min(ivec3(g), max(counts - 2, ivec3(0)));
    vec3 alpha = clamp(g - vec3(base), 0.0, 1.0);
    vec3 sum = vec3(0.0);
    float total = 0.0;
    for (int i = 0; i < 8; ++i) {
        ivec3 off = ivec3(i & 1, (i >> 1) & 1, (i >> 2) & 1);
        ivec3 c = min(base + off, counts - 1);
        int probe = probe_index(grid, c);
        vec4 state = probe_state(probe);
        if (state.w < 0.5) continue;                 // switched off: inside geometry
        vec3 tri = mix(1.0 - alpha, alpha, vec3(off));
        float w = tri.x * tri.y * tri.z;
        vec3 pp = probe_position(grid, c, state);
        vec3 to_probe = pp - p;
        float len = length(to_probe);
        vec3 dir = len > 0.0 ? to_probe / len : n;
        float facing = (dot(dir, n) + 1.0) * 0.5;    // probes behind the surface count less
        w *= facing * facing + 0.2;
        vec3 from_probe = q - pp;
        float r = length(from_probe);
        if (r > 0.0) {
            vec2 uv = field_uv(field_distance, probe, from_probe / r);
            vec2 m = textureLod(field_distance, uv, 0.0).rg;
            if (field_hidden(uv, from_probe, r)) continue;   // behind a wall
            if (r > m.x) {
                float variance = abs(m.y - m.x * m.x);
                float d = r - m.x;
                float chebyshev = variance / (variance + d * d);
                w *= chebyshev * chebyshev * chebyshev;
            }
        }
        if (w < 0.2) w *= w * w / 0.04;              // crushes what little light leaks
        sum += w * textureLod(field_irradiance, field_uv(field_irradiance, probe, along), 0.0).rgb;
        total += w;
    }
    return total > 0.0 ? sum / total : vec3(0.0);
}

// How much grid g holds p: 1 inside its region, falling to 0 over half its cell
// towards the region's edge (the last grid holds every point).
float grid_share(int g, vec3 p) {
    if (g == field_grids - 1) return 1.0;
    vec3 to_edge = min(p - field_region_lo[g], field_region_hi[g] - p);
    float cell = max(field_step[g].x, max(field_step[g].y, field_step[g].z));
    return clamp(min(to_edge.x, min(to_edge.y, to_edge.z)) / (0.5 * cell), 0.0, 1.0);
}

// The finest grids that hold p, blended.
vec3 field_irradiance_along(vec3 p, vec3 n, vec3 v, vec3 along) {
    vec3 sum = vec3(0.0);
    float left = 1.0;
    for (int g = 0; g < field_grids && left > 0.0; ++g) {
        float share = grid_share(g, p);
        if (share <= 0.0) continue;
        sum += left * share * grid_irradiance_along(g, p, n, v, along);
        left *= 1.0 - share;
    }
    return sum;
}

vec3 field_irradiance_at(vec3 p, vec3 n, vec3 v) { return field_irradiance_along(p, n, v, n); }
