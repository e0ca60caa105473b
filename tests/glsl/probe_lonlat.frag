#version 430
// Evaluates lonlat_offset and precise_sin for one case per pixel.
#include "lib/lonlat.glsl"
uniform sampler2D u_in;   // texel (i, 0): (phi, lam, dphi, dlam) of case i
out vec4 o_out;
void main() {
    vec4 v = texelFetch(u_in, ivec2(gl_FragCoord.x, 0), 0);
    vec2 cs_phi = vec2(cos(v.x), sin(v.x));
    vec2 cs_lam = vec2(cos(v.y), sin(v.y));
    o_out = vec4(lonlat_offset(cs_phi, cs_lam, v.z, v.w), precise_sin(v.z));
}
