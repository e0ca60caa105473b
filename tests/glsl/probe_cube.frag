#version 430
// Evaluates cube_offset for one case per pixel exactly as raster_classify.frag (GRID_CUBE)
// does: bin centre and cell centre in output pixels, scaled by u_px = 2 / size.
#include "lib/cube.glsl"
uniform sampler2D u_in;   // texel (i, 0): (bin x, bin y, cell x - bin x, cell y - bin y), pixels
uniform vec3 u_face_e;
uniform vec3 u_face_u;
uniform vec3 u_face_v;
uniform float u_px;
out vec4 o_out;
void main() {
    vec4 v = texelFetch(u_in, ivec2(gl_FragCoord.x, 0), 0);
    vec3 c;
    vec3 dp = cube_offset(v.x * u_px - 1.0, v.y * u_px - 1.0, v.z * u_px, v.w * u_px,
                          u_face_e, u_face_u, u_face_v, c);
    o_out = vec4(dp, 0.0);
}
