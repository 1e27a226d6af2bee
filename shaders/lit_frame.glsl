// Where a point lies on the lit frame (engine/gpu/lit_copy.py): the passes that read
// the frame where a ray meets it (reflections.glsl, glass.glsl). The includer declares
// view_proj (camera-relative -> clip).

// Window uv of camera-relative q; false when it is behind the camera or off screen.
bool on_screen(vec3 q, out vec2 uv) {
    vec4 clip = view_proj * vec4(q, 1.0);
    uv = clip.xy / clip.w * 0.5 + 0.5;
    return clip.w > 0.0 && all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)));
}
