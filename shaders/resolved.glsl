// The resolved pixel of the HDR accumulation: its light, and alpha 1, or coverage
// when the render is transparent (the ambient pass writes 1 where a surface was
// drawn, the transparency pass composites blended layers over it, alpha too, and
// anti-aliasing filters it). Shared by the resolve pass and the non-finite count, so
// the count is of exactly the values read back.
vec4 resolved(sampler2D hdr, ivec2 px, bool transparent) {
    vec4 light = texelFetch(hdr, px, 0);
    return vec4(light.rgb, transparent ? clamp(light.a, 0.0, 1.0) : 1.0);
}

bool not_finite(vec4 c) {
    return any(isnan(c)) || any(isinf(c));
}
