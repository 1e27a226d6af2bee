// A light's row in the light table (engine/gpu/lights.py): LIGHTS_PER_LINE rows lie side
// by side on each texture line, so the table fits GL's texture size limit (16384 lines
// on llvmpipe) for a million lights, not 16384. Both constants match engine/gpu/lights.py.
uniform sampler2D u_lights;
const int LIGHT_ROW_TEXELS = 40;
const int LIGHTS_PER_LINE = 64;

vec4 light_table(int row, int k) {
    return texelFetch(u_lights, ivec2(k + (row % LIGHTS_PER_LINE) * LIGHT_ROW_TEXELS,
                                      row / LIGHTS_PER_LINE), 0);
}
