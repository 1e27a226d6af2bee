// Blender's pattern nodes as Cycles evaluates them (intern/cycles/kernel/svm: math_util,
// color_util, mapping_util, checker, hsv, ramp), for the GLSL that engine/gpu/pattern.py
// generates per graph. Operation numbers are core/pattern_nodes.py's list positions;
// they are compile-time constants in the generated code, so the branches fold away.

float pt_safe_div(float a, float b) { return b != 0.0 ? a / b : 0.0; }
float pt_safe_mod(float a, float b) { return b != 0.0 ? a - b * trunc(a / b) : 0.0; }
float pt_floored_mod(float a, float b) { return b != 0.0 ? a - floor(a / b) * b : 0.0; }
float pt_wrap(float v, float hi, float lo) {
    float range = hi - lo;
    return range != 0.0 ? v - range * floor((v - lo) / range) : lo;
}
float pt_pingpong(float a, float b) {
    return b != 0.0 ? abs(fract((a - b) / (b * 2.0)) * b * 2.0 - b) : 0.0;
}
float pt_smoothmin(float a, float b, float k) {
    if (k == 0.0) return min(a, b);
    float h = max(k - abs(a - b), 0.0) / k;
    return min(a, b) - h * h * h * k * (1.0 / 6.0);
}
float pt_pow(float a, float b) {
    // Cycles' safe_powf: a negative base needs an integer exponent.
    if (a < 0.0 && b != floor(b)) return 0.0;
    float r = pow(abs(a), b);
    return (a < 0.0 && mod(b, 2.0) != 0.0) ? -r : r;
}

float pt_math(int op, float a, float b, float c) {
    if (op == 0) return a + b;
    if (op == 1) return a - b;
    if (op == 2) return a * b;
    if (op == 3) return pt_safe_div(a, b);
    if (op == 4) return a * b + c;
    if (op == 5) return pt_pow(a, b);
    if (op == 6) return (a > 0.0 && b > 0.0) ? pt_safe_div(log(a), log(b)) : 0.0;
    if (op == 7) return a > 0.0 ? sqrt(a) : 0.0;
    if (op == 8) return a > 0.0 ? inversesqrt(a) : 0.0;
    if (op == 9) return abs(a);
    if (op == 10) return exp(a);
    if (op == 11) return min(a, b);
    if (op == 12) return max(a, b);
    if (op == 13) return a < b ? 1.0 : 0.0;
    if (op == 14) return a > b ? 1.0 : 0.0;
    if (op == 15) return sign(a);
    if (op == 16) return abs(a - b) <= max(c, 1e-5) ? 1.0 : 0.0;
    if (op == 17) return pt_smoothmin(a, b, c);
    if (op == 18) return -pt_smoothmin(-a, -b, c);
    if (op == 19) return floor(a + 0.5);
    if (op == 20) return floor(a);
    if (op == 21) return ceil(a);
    if (op == 22) return trunc(a);
    if (op == 23) return a - floor(a);
    if (op == 24) return pt_safe_mod(a, b);
    if (op == 25) return pt_floored_mod(a, b);
    if (op == 26) return pt_wrap(a, b, c);
    if (op == 27) return floor(pt_safe_div(a, b)) * b;
    if (op == 28) return pt_pingpong(a, b);
    if (op == 29) return sin(a);
    if (op == 30) return cos(a);
    if (op == 31) return tan(a);
    if (op == 32) return (a >= -1.0 && a <= 1.0) ? asin(a) : 0.0;
    if (op == 33) return (a >= -1.0 && a <= 1.0) ? acos(a) : 0.0;
    if (op == 34) return atan(a);
    if (op == 35) return atan(a, b);
    if (op == 36) return sinh(a);
    if (op == 37) return cosh(a);
    if (op == 38) return tanh(a);
    if (op == 39) return radians(a);
    return degrees(a);
}

vec3 pt_safe_div3(vec3 a, vec3 b) {
    return vec3(pt_safe_div(a.x, b.x), pt_safe_div(a.y, b.y), pt_safe_div(a.z, b.z));
}

void pt_vector_math(int op, vec3 a, vec3 b, vec3 c, float s, out vec3 v, out float f) {
    v = vec3(0.0);
    f = 0.0;
    if (op == 0) v = a + b;
    else if (op == 1) v = a - b;
    else if (op == 2) v = a * b;
    else if (op == 3) v = pt_safe_div3(a, b);
    else if (op == 4) v = a * b + c;
    else if (op == 5) v = cross(a, b);
    else if (op == 6) { float l = dot(b, b); v = l != 0.0 ? b * (dot(a, b) / l) : vec3(0.0); }
    else if (op == 7) { vec3 n = length(b) > 0.0 ? normalize(b) : vec3(0.0); v = a - 2.0 * dot(a, n) * n; }
    else if (op == 8) f = dot(a, b);
    else if (op == 9) f = distance(a, b);
    else if (op == 10) f = length(a);
    else if (op == 11) v = a * s;
    else if (op == 12) v = length(a) > 0.0 ? normalize(a) : vec3(0.0);
    else if (op == 13) v = floor(pt_safe_div3(a, b)) * b;
    else if (op == 14) v = floor(a);
    else if (op == 15) v = ceil(a);
    else if (op == 16) v = vec3(pt_safe_mod(a.x, b.x), pt_safe_mod(a.y, b.y), pt_safe_mod(a.z, b.z));
    else if (op == 17) v = vec3(pt_wrap(a.x, b.x, c.x), pt_wrap(a.y, b.y, c.y), pt_wrap(a.z, b.z, c.z));
    else if (op == 18) v = a - floor(a);
    else if (op == 19) v = abs(a);
    else if (op == 20) v = vec3(pt_pow(a.x, b.x), pt_pow(a.y, b.y), pt_pow(a.z, b.z));
    else if (op == 21) v = sign(a);
    else if (op == 22) v = min(a, b);
    else if (op == 23) v = max(a, b);
    else if (op == 24) v = sin(a);
    else if (op == 25) v = cos(a);
    else if (op == 26) v = tan(a);
    else if (op == 27) v = refract(a, length(b) > 0.0 ? normalize(b) : vec3(0.0), s);
    else v = dot(c, b) < 0.0 ? a : -a;     // faceforward(a, b, c): Cycles' argument order
}

// Blender's Euler XYZ rotation (Cycles euler_to_transform): rows of Rz * Ry * Rx.
mat3 pt_euler_rows(vec3 e) {
    float cx = cos(e.x), cy = cos(e.y), cz = cos(e.z);
    float sx = sin(e.x), sy = sin(e.y), sz = sin(e.z);
    // GLSL mat3 takes columns; these are the rows, so the matrix is transposed.
    return mat3(cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz,
                cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz,
                -sy, cy * sx, cy * cx);
}

vec3 pt_mapping(int type, vec3 v, vec3 loc, vec3 rot, vec3 scale) {
    mat3 rows = pt_euler_rows(rot);      // transpose(R)
    if (type == 0) return (v * scale) * rows + loc;               // R (v s) + l
    if (type == 1) return pt_safe_div3(rows * (v - loc), scale);  // R^T (v - l) / s
    if (type == 2) return (v * scale) * rows;
    vec3 n = pt_safe_div3(v, scale) * rows;
    return length(n) > 0.0 ? normalize(n) : vec3(0.0);
}

vec3 pt_rgb_to_hsv(vec3 rgb) {
    float cmax = max(rgb.r, max(rgb.g, rgb.b));
    float cmin = min(rgb.r, min(rgb.g, rgb.b));
    float cdelta = cmax - cmin;
    float h = 0.0, s = cmax != 0.0 ? cdelta / cmax : 0.0;
    if (s != 0.0) {
        vec3 c = (vec3(cmax) - rgb) / cdelta;
        if (rgb.r == cmax) h = c.b - c.g;
        else if (rgb.g == cmax) h = 2.0 + c.r - c.b;
        else h = 4.0 + c.g - c.r;
        h /= 6.0;
        if (h < 0.0) h += 1.0;
    }
    return vec3(h, s, cmax);
}

vec3 pt_hsv_to_rgb(vec3 hsv) {
    float h = hsv.x, s = hsv.y, v = hsv.z;
    if (s == 0.0) return vec3(v);
    if (h == 1.0) h = 0.0;
    h *= 6.0;
    float i = floor(h), f = h - i;
    float p = v * (1.0 - s), q = v * (1.0 - s * f), t = v * (1.0 - s * (1.0 - f));
    if (i == 0.0) return vec3(v, t, p);
    if (i == 1.0) return vec3(q, v, p);
    if (i == 2.0) return vec3(p, v, t);
    if (i == 3.0) return vec3(p, q, v);
    if (i == 4.0) return vec3(t, p, v);
    return vec3(v, p, q);
}

vec3 pt_hsv_adjust(float hue, float sat, float val, float fac, vec3 color) {
    vec3 hsv = pt_rgb_to_hsv(color);
    hsv.x = fract(hsv.x + hue + 0.5);
    hsv.y = clamp(hsv.y * sat, 0.0, 1.0);
    hsv.z *= val;
    return max(mix(color, pt_hsv_to_rgb(hsv), fac), vec3(0.0));
}

float pt_dodge(float c1, float c2, float t) {
    if (c1 == 0.0) return c1;
    float tmp = 1.0 - t * c2;
    return tmp <= 0.0 ? 1.0 : min(c1 / tmp, 1.0);
}

float pt_burn(float c1, float c2, float t) {
    float tmp = (1.0 - t) + t * c2;
    return tmp <= 0.0 ? 0.0 : clamp(1.0 - (1.0 - c1) / tmp, 0.0, 1.0);
}

float pt_overlay(float c1, float c2, float t) {
    float tm = 1.0 - t;
    return c1 < 0.5 ? c1 * (tm + 2.0 * t * c2) : 1.0 - (tm + 2.0 * t * (1.0 - c2)) * (1.0 - c1);
}

vec3 pt_blend(int type, float t, vec3 c1, vec3 c2) {
    float tm = 1.0 - t;
    if (type == 0) return mix(c1, c2, t);
    if (type == 1) return mix(c1, c1 + c2, t);
    if (type == 2) return mix(c1, c1 * c2, t);
    if (type == 3) return mix(c1, c1 - c2, t);
    if (type == 4) return vec3(1.0) - (vec3(tm) + t * (vec3(1.0) - c2)) * (vec3(1.0) - c1);
    if (type == 5) return vec3(c2.x != 0.0 ? tm * c1.x + t * c1.x / c2.x : c1.x,
                               c2.y != 0.0 ? tm * c1.y + t * c1.y / c2.y : c1.y,
                               c2.z != 0.0 ? tm * c1.z + t * c1.z / c2.z : c1.z);
    if (type == 6) return mix(c1, abs(c1 - c2), t);
    if (type == 7) return max(mix(c1, c1 + c2 - 2.0 * c1 * c2, t), vec3(0.0));
    if (type == 8) return mix(c1, min(c1, c2), t);
    if (type == 9) return mix(c1, max(c1, c2), t);
    if (type == 10) return vec3(pt_overlay(c1.x, c2.x, t), pt_overlay(c1.y, c2.y, t),
                                pt_overlay(c1.z, c2.z, t));
    if (type == 11) return vec3(pt_dodge(c1.x, c2.x, t), pt_dodge(c1.y, c2.y, t),
                                pt_dodge(c1.z, c2.z, t));
    if (type == 12) return vec3(pt_burn(c1.x, c2.x, t), pt_burn(c1.y, c2.y, t),
                                pt_burn(c1.z, c2.z, t));
    if (type == 13 || type == 16) {           // hue; colour also takes the saturation
        vec3 hsv2 = pt_rgb_to_hsv(c2);
        if (hsv2.y == 0.0) return c1;
        vec3 hsv = pt_rgb_to_hsv(c1);
        hsv.x = hsv2.x;
        if (type == 16) hsv.y = hsv2.y;
        return mix(c1, pt_hsv_to_rgb(hsv), t);
    }
    if (type == 14) {
        vec3 hsv = pt_rgb_to_hsv(c1);
        if (hsv.y == 0.0) return c1;
        hsv.y = tm * hsv.y + t * pt_rgb_to_hsv(c2).y;
        return pt_hsv_to_rgb(hsv);
    }
    if (type == 15) {
        vec3 hsv = pt_rgb_to_hsv(c1);
        hsv.z = tm * hsv.z + t * pt_rgb_to_hsv(c2).z;
        return pt_hsv_to_rgb(hsv);
    }
    if (type == 17) {
        vec3 scr = vec3(1.0) - (vec3(1.0) - c2) * (vec3(1.0) - c1);
        return tm * c1 + t * ((vec3(1.0) - c1) * c2 * c1 + c1 * scr);
    }
    return c1 + t * (2.0 * c2 - vec3(1.0));
}

// The mean of (-1)^floor(x) (+1 on the even cells) under a tent of half-width h (in x's
// units): the second difference of its second integral, over h^2. The integral of the
// square wave is a triangle wave, and its integral floor(x / 2) + a piecewise
// quadratic of x mod 2; a narrow tent (whose difference would lose float's bits)
// takes the box of the same spread (width h sqrt 2: the first difference), a tent
// narrower still the point.
float pt_square_integral2(float x) {
    float u = mod(x, 2.0);
    float over = max(u - 1.0, 0.0);
    return floor(x * 0.5) + 0.5 * u * u - over * over;
}
float pt_square_filtered(float x, float h) {
    x = mod(x, 2.0);
    if (h >= 0.05)
        return (pt_square_integral2(x + h) - 2.0 * pt_square_integral2(x)
                + pt_square_integral2(x - h)) / (h * h);
    float w = 1.41421356 * h;
    if (w >= 1e-4)
        return ((1.0 - abs(1.0 - mod(x + 0.5 * w, 2.0)))
                - (1.0 - abs(1.0 - mod(x - 0.5 * w, 2.0)))) / w;
    return x < 1.0 ? 1.0 : -1.0;
}

// Cycles' svm_checker (1 on the cells where the parities of x, y, z agree, 0 on the
// others) as Cycles' pixel filter averages it: one sample a pixel of the 0/1 cells
// steps along their edges and flickers where a pixel spans many cells (the grazing
// floor's grey). The checker is (1 - the product of the three axes' square waves) / 2,
// and each axis is averaged alone under a tent of the filter's spread (variance),
// which the pixel's derivatives map to that axis. The spread: Cycles'
// Blackman-Harris over its reach R (material.glsl u_pixel_filter, its cosine terms a_n)
// has variance R^2 (1/3 + 2 / (pi^2 a_0) sum a_n / n^2) (0.28 R standard deviation);
// in a supersampled image (reach 0), whose pixel filter comes after, the fragment's
// box (1/12).
float pt_checker(vec3 p) {
    p = (p + 0.000001) * 0.999999;
    float r = u_pixel_filter_reach;
    vec4 a = u_pixel_filter;
    float variance = r > 0.0
        ? r * r * (1.0 / 3.0 + 2.0 / (9.8696044 * a.x) * (a.y + a.z / 4.0 + a.w / 9.0))
        : 1.0 / 12.0;
    float half_width = sqrt(6.0 * variance);          // pixels: a tent of that variance
    vec3 dx = dFdx(p), dy = dFdy(p);
    vec3 h = half_width * sqrt(dx * dx + dy * dy);
    float waves = pt_square_filtered(p.x, h.x) * pt_square_filtered(p.y, h.y)
                  * pt_square_filtered(p.z, h.z);
    return 0.5 - 0.5 * waves;
}

// Cycles' svm_gradient, clamped to [0, 1] as the node does.
float pt_gradient(int type, vec3 p) {
    float f;
    if (type == 0) f = p.x;
    else if (type == 1) { float r = max(p.x, 0.0); f = r * r; }
    else if (type == 2) { float r = clamp(p.x, 0.0, 1.0); float t = r * r; f = 3.0 * t - 2.0 * t * r; }
    else if (type == 3) f = (p.x + p.y) * 0.5;
    else if (type == 6) f = atan(p.y, p.x) / 6.28318530717958647692 + 0.5;
    else {
        float r = max(1.0 - length(p), 0.0);
        f = type == 5 ? r * r : r;
    }
    return clamp(f, 0.0, 1.0);
}

// Blender's Perlin noise (Cycles noise.h): lookup3 hashes of the lattice corners,
// gradients by grad3, quintic fade, scaled by 0.9820 to [-1, 1].
uint pt_rot(uint x, int k) { return (x << uint(k)) | (x >> uint(32 - k)); }

uint pt_hash3(uint kx, uint ky, uint kz) {
    uint a = 0xdeadbeefu + (3u << 2u) + 13u, b = a, c = a;
    c += kz; b += ky; a += kx;
    c ^= b; c -= pt_rot(b, 14);
    a ^= c; a -= pt_rot(c, 11);
    b ^= a; b -= pt_rot(a, 25);
    c ^= b; c -= pt_rot(b, 16);
    a ^= c; a -= pt_rot(c, 4);
    b ^= a; b -= pt_rot(a, 14);
    c ^= b; c -= pt_rot(b, 24);
    return c;
}

float pt_grad3(uint hash, float x, float y, float z) {
    uint h = hash & 15u;
    float u = h < 8u ? x : y;
    float vt = (h == 12u || h == 14u) ? x : z;
    float v = h < 4u ? y : vt;
    return ((h & 1u) != 0u ? -u : u) + ((h & 2u) != 0u ? -v : v);
}

float pt_fade(float t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

float pt_snoise(vec3 p) {
    vec3 i = floor(p), f = p - i;
    uvec3 c = uvec3(ivec3(i));
    float u = pt_fade(f.x), v = pt_fade(f.y), w = pt_fade(f.z);
    float n000 = pt_grad3(pt_hash3(c.x, c.y, c.z), f.x, f.y, f.z);
    float n100 = pt_grad3(pt_hash3(c.x + 1u, c.y, c.z), f.x - 1.0, f.y, f.z);
    float n010 = pt_grad3(pt_hash3(c.x, c.y + 1u, c.z), f.x, f.y - 1.0, f.z);
    float n110 = pt_grad3(pt_hash3(c.x + 1u, c.y + 1u, c.z), f.x - 1.0, f.y - 1.0, f.z);
    float n001 = pt_grad3(pt_hash3(c.x, c.y, c.z + 1u), f.x, f.y, f.z - 1.0);
    float n101 = pt_grad3(pt_hash3(c.x + 1u, c.y, c.z + 1u), f.x - 1.0, f.y, f.z - 1.0);
    float n011 = pt_grad3(pt_hash3(c.x, c.y + 1u, c.z + 1u), f.x, f.y - 1.0, f.z - 1.0);
    float n111 = pt_grad3(pt_hash3(c.x + 1u, c.y + 1u, c.z + 1u), f.x - 1.0, f.y - 1.0, f.z - 1.0);
    float lo = (1.0 - v) * ((1.0 - u) * n000 + u * n100) + v * ((1.0 - u) * n010 + u * n110);
    float hi = (1.0 - v) * ((1.0 - u) * n001 + u * n101) + v * ((1.0 - u) * n011 + u * n111);
    return 0.9820 * ((1.0 - w) * lo + w * hi);
}

// Cycles' noise_fbm: octaves 0..floor(detail), the fraction blending one more.
float pt_noise_fbm(vec3 p, float detail, float roughness, float lacunarity, bool normalize) {
    float fscale = 1.0, amp = 1.0, maxamp = 0.0, sum = 0.0;
    int octaves = int(detail);
    for (int i = 0; i <= octaves; i++) {
        sum += pt_snoise(fscale * p) * amp;
        maxamp += amp;
        amp *= roughness;
        fscale *= lacunarity;
    }
    float rmd = detail - floor(detail);
    if (rmd != 0.0) {
        float sum2 = sum + pt_snoise(fscale * p) * amp;
        return normalize ? mix(0.5 * sum / maxamp + 0.5, 0.5 * sum2 / (maxamp + amp) + 0.5, rmd)
                         : mix(sum, sum2, rmd);
    }
    return normalize ? 0.5 * sum / maxamp + 0.5 : sum;
}

// Cycles' hash_int3_to_float3 (PCG 3D on signed integers, JCGT 2020), in [0, 1].
vec3 pt_hash_int3(ivec3 v) {
    v = v * 1664525 + 1013904223;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v ^= v >> 16;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v &= 0x7FFFFFFF;
    return vec3(v) * (1.0 / 2147483648.0);
}

float pt_voronoi_distance(vec3 d, int metric, float exponent) {
    if (metric == 0) return length(d);
    d = abs(d);
    if (metric == 1) return d.x + d.y + d.z;
    if (metric == 2) return max(d.x, max(d.y, d.z));
    return pow(pow(d.x, exponent) + pow(d.y, exponent) + pow(d.z, exponent), 1.0 / exponent);
}

// Cycles' voronoi_f1 in 3D: the nearest of the 27 cells' jittered points, the cells
// hashed by their integer positions.
void pt_voronoi_f1(vec3 coord, int metric, float exponent, float randomness,
                   out float dist, out vec3 color, out vec3 position) {
    vec3 cell_f = floor(coord), local = coord - cell_f;
    ivec3 cell = ivec3(cell_f), target_offset = ivec3(0);
    dist = 3.402823466e38;
    vec3 target = vec3(0.0);
    for (int k = -1; k <= 1; k++)
        for (int j = -1; j <= 1; j++)
            for (int i = -1; i <= 1; i++) {
                ivec3 offset = ivec3(i, j, k);
                vec3 point = vec3(offset) + pt_hash_int3(cell + offset) * randomness;
                float d = pt_voronoi_distance(point - local, metric, exponent);
                if (d < dist) { dist = d; target_offset = offset; target = point; }
            }
    color = pt_hash_int3(cell + target_offset);
    position = target + cell_f;
}

// Cycles' fractal_voronoi_x_fx for F1, unnormalised: octaves up to ceil(detail).
void pt_voronoi(vec3 coord, float scale, float detail, float roughness, float lacunarity,
                float exponent, float randomness, int metric,
                out float dist, out vec3 color, out vec3 position) {
    float amplitude = 1.0, max_amplitude = 0.0, s = 1.0;
    dist = 0.0; color = vec3(0.0); position = vec3(0.0);
    bool zero_input = detail == 0.0 || roughness == 0.0;
    for (int i = 0; i <= int(ceil(detail)); i++) {
        float od; vec3 oc, op;
        pt_voronoi_f1(coord * s, metric, exponent, randomness, od, oc, op);
        if (zero_input) {
            dist = od; color = oc; position = op;
            break;
        } else if (float(i) <= detail) {
            max_amplitude += amplitude;
            dist += od * amplitude;
            color += oc * amplitude;
            position = mix(position, op / s, amplitude);
            s *= lacunarity;
            amplitude *= roughness;
        } else {
            float r = detail - floor(detail);
            if (r != 0.0) {
                dist = mix(dist, dist + od * amplitude, r);
                color = mix(color, color + oc * amplitude, r);
                position = mix(position, mix(position, op / s, amplitude), r);
            }
        }
    }
    position = scale != 0.0 ? position / scale : vec3(0.0);
}

// Cycles' svm_wave: bands or rings along a direction (core/pattern_nodes.py numbers),
// distorted by fBm noise, through a sine, saw or triangle profile.
float pt_wave(int type, int dir, int profile, vec3 p, float distortion, float detail,
              float dscale, float droughness, float phase) {
    p = (p + 0.000001) * 0.999999;
    float n;
    if (type == 0) {
        n = dir == 3 ? (p.x + p.y + p.z) * 10.0 : p[dir] * 20.0;
    } else {
        vec3 rp = p;
        if (dir < 3) rp[dir] = 0.0;
        n = length(rp) * 20.0;
    }
    n += phase;
    if (distortion != 0.0)
        n += distortion * (pt_noise_fbm(p * dscale, detail, droughness, 2.0, true) * 2.0 - 1.0);
    if (profile == 0) return 0.5 + 0.5 * sin(n - 1.57079632679489661923);
    n /= 6.28318530717958647692;
    if (profile == 1) return n - floor(n);
    return abs(n - floor(n + 0.5)) * 2.0;
}

// Blender's implicit socket conversions: colour -> float is luminance (Rec. 709, the
// scene-linear role of Blender's default OCIO config), vector -> float the average.
float pt_color_to_float(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }
float pt_vector_to_float(vec3 v) { return (v.x + v.y + v.z) * (1.0 / 3.0); }

// Cycles' Bump node (svm_node_set_bump): the shading normal of a surface displaced by
// `distance` x height along normal_in (pt_N, material.glsl, unless a normal is linked
// in), from the height's and the position's derivatives across the pixel (Cycles
// takes finite differences of its ray differentials: the same surface gradient).
// Strength blends towards normal_in.
vec3 pt_bump(float strength, float distance, float height, bool invert, vec3 normal_in) {
    normal_in = dot(normal_in, normal_in) > 0.0 ? normalize(normal_in) : pt_N;
    vec3 dpdx = dFdx(pt_P), dpdy = dFdy(pt_P);
    vec3 rx = cross(dpdy, normal_in), ry = cross(normal_in, dpdx);
    float det = dot(dpdx, rx);
    vec3 surfgrad = dFdx(height) * rx + dFdy(height) * ry;
    float scale = invert ? -distance : distance;
    vec3 n = abs(det) * normal_in - scale * sign(det) * surfgrad;
    if (!(dot(n, n) > 0.0)) return normal_in;
    float s = max(strength, 0.0);
    return normalize(s * normalize(n) + (1.0 - s) * normal_in);
}

// Cycles' tangent-space Normal Map node (svm_node_normal_map) on a colour a network
// computed: n = 2c - 1 in the MikkTSpace frame (material.glsl tangent_space_normal),
// strength s weighting it as Cycles does (docs/stage_contract.md, "Normal maps").
vec3 pt_normal_map(float strength, vec3 color) {
    vec3 c = 2.0 * color - 1.0;
    float s = max(strength, 0.0);
    return tangent_space_normal(vec3(s * c.xy, 1.0 + min(s, 1.0) * (c.z - 1.0)));
}
