// Forward lighting of a surface the deferred passes do not light (the transparency
// and glass passes): the deferred passes' own functions (material.glsl, lights.glsl,
// environment.glsl, shadow_lookup.glsl with HAS_SHADOW), never a copy.
#define MAX_FORWARD_LIGHTS 32
uniform int n_lights;
uniform int light_rows[MAX_FORWARD_LIGHTS];

// What surface s at camera-relative p (shading normal n) sends to the viewer: with
// AMBIENT the dome and its emission, then the lights of light_rows (HAS_SHADOW:
// exactly one, with its shadow map).
vec3 forward_light(Surface s, vec3 p, vec3 n, vec3 emissive) {
    vec3 c = vec3(0.0), diffuse, glossy;
#ifdef AMBIENT
    dome_light(s, vec2(1.0), diffuse, glossy);      // no ambient occlusion: it is screen space
    c += emissive + diffuse + glossy;
#endif
    for (int i = 0; i < n_lights; ++i) {
        load_light(light_rows[i], cam_forward);
        light_reflected(s, diffuse, glossy);
        vec3 r = diffuse + glossy;
#ifdef HAS_SHADOW
        if (max(r.r, max(r.g, r.b)) > 0.0)
            r *= light_shadow(p, n, dot(p, cam_forward)) *
                 light_shadow_colour(p, n, dot(p, cam_forward));
#endif
        c += r;
    }
    return c;
}
