// The sheen lobe (core/sheen.py names its modes), as Cycles evaluates it, for the
// lighting programs of frames with a sheen (SHEEN: g_sheen, passes/gbuffer.py). Cycles
// counts sheen as diffuse light (its closures are labelled diffuse), so the lights and
// the dome add it to their diffuse part.
#ifdef SHEEN
// The Ashikhmin (velvet) lobe's directional albedo by n.v (s) and roughness (t), read
// as dfg_lut is (engine/lighting.py velvet_albedo_lut): the dome's sheen light.
uniform sampler2D sheen_lut;

// Microfiber sheen (Zeltner, Burley and Chiang 2022, "Practical Multiple-Scattering
// Sheen Using Linearly Transformed Cosines"; Cycles' Principled and Sheen BSDF): a
// cosine lobe stretched by the LTC matrix [[a, 0, b], [0, a, 0], [0, 0, 1]] (inverse)
// in the frame whose x axis is the view's tangent direction, and scaled by the
// directional albedo. Cycles reads a, b and the albedo from tables of the paper's fit;
// these are the paper's rational (a, b) and Gaussian (albedo) fits to the same data,
// over roughness 0.01-1.
float sheen_ltc_a(float x, float y) {
    return (2.58126 * x + 0.813703 * y) * y / (1.0 + 0.310327 * x * x + 2.60994 * x * y);
}
float sheen_ltc_b(float x, float y) {
    return sqrt(1.0 - x) * (y - 1.0) * y * y * y /
        (0.0000254053 + 1.71228 * x - 1.71506 * x * y + 1.34174 * y * y);
}
float sheen_ltc_albedo(float x, float y) {
    float s = y * (0.0206607 + 1.58491 * y) / (0.0379424 + y * (1.32227 + y));
    float m = y * (-0.193854 + y * (-1.14885 + y * (1.7932 - 0.95943 * y * y))) / (0.046391 + y);
    float o = y * (0.000654023 + (-0.0207818 + 0.119681 * y) * y) / (1.26264 + y * (-1.92021 + y));
    float z = (x - m) / s;
    return exp(-0.5 * z * z) / (s * sqrt(2.0 * PI)) + o;
}

// A G-buffer sheen texel (colour; roughness + 2 x mode, or alpha -1: none) into the
// surface. The
// Principled BSDF's sheen (mode 0) is its top layer: what lies below (coat, specular,
// diffuse) receives 1 - the sheen's albedo, its largest channel, as Cycles'
// closure_layering_weight has it. A Sheen BSDF (modes 1, 2) is added, on nothing.
void apply_sheen(inout Surface s, vec4 texel) {
    float mode = sheen_mode_of(texel.a);
    if (mode < 0.0) return;                     // no sheen (passes/gbuffer.py sheen_texel)
    s.sheen = max(texel.rgb, vec3(0.0));
    s.sheen_mode = int(mode);
    s.sheen_roughness = clamp(sheen_roughness_of(texel.a), 0.0, 1.0);
    if (s.sheen_mode == 2) {
        s.sheen_albedo = texture(sheen_lut, table_uv(textureSize(sheen_lut, 0), s.NoV,
                                                     s.sheen_roughness)).r;
        return;
    }
    float r = max(s.sheen_roughness, 0.01);
    s.sheen_a = sheen_ltc_a(s.NoV, r);
    s.sheen_b = sheen_ltc_b(s.NoV, r);
    s.sheen_albedo = clamp(sheen_ltc_albedo(s.NoV, r), 0.0, 1.0);
    if (s.sheen_mode == 0) {
        vec3 layer = s.sheen * s.sheen_albedo;
        float below = clamp(1.0 - max(layer.r, max(layer.g, layer.b)), 0.0, 1.0);
        s.diffuse *= below;
        s.under_coat *= below;
        s.coat *= below;
        s.coat_albedo *= below;
    }
}

// The sheen lobe's BRDF towards l (0 without a sheen).
vec3 brdf_sheen(Surface s, vec3 l) {
    float NoL = dot(s.n, l);
    if (NoL <= 0.0 || max(s.sheen.r, max(s.sheen.g, s.sheen.b)) <= 0.0) return vec3(0.0);
    if (s.sheen_mode == 2) {
        // Cycles' Ashikhmin velvet (bsdf_ashikhmin_velvet.h): D an inverted Gaussian
        // in cot(n.h) of width sigma >= 0.01, its own shadowing term, over 4 n.v n.l.
        float sigma = max(s.sheen_roughness, 0.01);
        vec3 h = normalize(l + s.v);
        float NoH = dot(s.n, h), VoH = abs(dot(s.v, h));
        if (abs(NoH) >= 1.0 - 1e-5 || VoH <= 1e-5) return vec3(0.0);
        float ratio = max(NoH / VoH, 1e-5);
        float G = min(1.0, 2.0 * ratio * min(s.NoV, NoL));
        float sin2 = 1.0 - NoH * NoH;
        float D = exp(-NoH * NoH / (sin2 * sigma * sigma)) / (sigma * sigma * PI * sin2 * sin2);
        return s.sheen * (0.25 * D * G / (s.NoV * NoL));
    }
    vec3 t = s.v - s.n * dot(s.n, s.v);
    t = dot(t, t) > 1e-12 ? normalize(t) :
        normalize(cross(s.n, abs(s.n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0)));
    vec3 local = vec3(dot(t, l), dot(cross(s.n, t), l), NoL);
    float a = s.sheen_a, b = s.sheen_b;
    vec3 w = vec3(a * local.x + b * local.z, a * local.y, local.z);
    float len2 = dot(w, w);
    // The lobe's cosine-weighted density is z / pi (a / |w|^2)^2: over n.l, the BRDF.
    return s.sheen * (s.sheen_albedo / PI * (a / len2) * (a / len2));
}

// What a dome of irradiance E (at the normal) reflects through the sheen: its
// directional albedo times the mean radiance E / pi, as MaterialX approximates it.
vec3 sheen_ambient(Surface s, vec3 E) {
    return s.sheen * s.sheen_albedo * E / PI;
}
#endif
