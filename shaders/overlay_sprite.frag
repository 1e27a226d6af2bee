#version 330 core
// A sprite: its straight-alpha display-referred texels, premultiplied, times opacity.
uniform sampler2D overlay_image;
uniform float u_opacity;
in vec2 v_uv;
out vec4 frag;
void main() {
    vec4 c = texture(overlay_image, v_uv / vec2(textureSize(overlay_image, 0)));
    float a = c.a * u_opacity;
    frag = vec4(c.rgb * a, a);
}
