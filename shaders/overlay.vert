#version 330 core
// Overlay quads (sprites, glyphs) in image pixels, y down from the top row. The
// image's row 0 is GL's row 0, so pixel y maps to NDC without a flip and the
// read-back rows come out in the image's order.
uniform vec2 u_size;            // target width, height in pixels
in vec2 in_pos;                 // pixels
in vec2 in_uv;                  // texels of the bound texture
out vec2 v_uv;
void main() {
    v_uv = in_uv;
    gl_Position = vec4(in_pos / u_size * 2.0 - 1.0, 0.0, 1.0);
}
