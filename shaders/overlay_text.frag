#version 330 core
// Text coverage and its halo, premultiplied: the fill over an outline (SDF) or a
// 1 px drop shadow (BITMAP), so text reads on any background.
//   SDF: the atlas holds 0.5 + distance / (2 spread); u_px_range is how many output
//        pixels one unit spans, so the edge stays one pixel wide at any size.
//   BITMAP: FreeType's coverage drawn texel for pixel (pixel-exact small text).
uniform sampler2D overlay_atlas;
uniform vec4 u_color;           // display-referred, straight alpha
uniform vec4 u_halo_color;
uniform float u_px_range;       // SDF: output pixels per distance unit
uniform float u_halo_width;     // SDF: outline width, output pixels
in vec2 v_uv;
out vec4 frag;
void main() {
    vec2 texel = 1.0 / vec2(textureSize(overlay_atlas, 0));
#ifdef BITMAP
    float fill = texture(overlay_atlas, v_uv * texel).r;
    float halo = texture(overlay_atlas, (v_uv - vec2(1.0)) * texel).r;
#else
    float d = (texture(overlay_atlas, v_uv * texel).r - 0.5) * u_px_range;   // pixels, + inside
    float fill = clamp(d + 0.5, 0.0, 1.0);
    float halo = clamp(d + u_halo_width + 0.5, 0.0, 1.0);
#endif
    fill *= u_color.a;
    halo *= u_halo_color.a;
    float a = fill + (1.0 - fill) * halo;
    frag = vec4(u_color.rgb * fill + u_halo_color.rgb * (1.0 - fill) * halo, a);
}
