// Where a point lies on the lit frame (engine/gpu/lit_copy.py), and what a traced ray
// meets as the frame shows it: the passes that read the frame where a ray meets it
// (reflections.glsl, glass.glsl). The includer declares view_proj (camera-relative ->
// clip), inv_view_proj and, with the ray tracer (raytrace.glsl, first), u_eye (the
// camera's world position).

// Window uv of camera-relative q; false when it is behind the camera or off screen.
bool on_screen(vec3 q, out vec2 uv) {
    vec4 clip = view_proj * vec4(q, 1.0);
    uv = clip.xy / clip.w * 0.5 + 0.5;
    return clip.w > 0.0 && all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)));
}

#ifdef RT_FAR
// What frame_hit finds.
#define FRAME_ESCAPED 0     // nothing: the ray leaves the scene
#define FRAME_SHOWN 1       // a hit the frame shows, at uv
#define FRAME_UNSEEN 2      // a hit off screen, or hidden there
// A hit on screen is hidden where the opaque surface there is nearer than this share of
// its distance. (The frame's depth is the pixel centre's: on a grazing floor it differs
// from a hit elsewhere in the pixel by a few per cent.)
#define FRAME_HIDDEN 0.95

// The closest hit of the ray from camera-relative o along d, beyond tmin: its distance
// t, and whether the frame shows it (`depth`: the opaque depth the frame was lit from).
int frame_hit(vec3 o, vec3 d, float tmin, sampler2D depth, out vec2 uv, out float t) {
    RtHit hit;
    uv = vec2(0.0);
    t = RT_FAR;
    if (!rt_closest_hit(o + u_eye, d, tmin, RT_FAR, hit)) return FRAME_ESCAPED;
    t = hit.t;
    vec3 h = o + hit.t * d;
    if (!on_screen(h, uv)) return FRAME_UNSEEN;
    float z = textureLod(depth, uv, 0.0).r;
    vec3 shown = position_from_depth(uv, z, inv_view_proj);
    return is_background(z) || length(shown) >= FRAME_HIDDEN * length(h) ? FRAME_SHOWN
                                                                          : FRAME_UNSEEN;
}
#endif
