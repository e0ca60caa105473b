#version 430
// The output level outside the frontier bins: each pixel takes the class of its bin
// (contained or outside, decided in float64 on the CPU). One fetch per pixel: this
// pass is the engine's share of the unavoidable cost of touching every pixel once.
uniform usampler2D u_coarse;  // classes of the bin level (R8UI)
uniform int u_shift;          // output level - bin level
out uint o_class;
void main() {
    o_class = texelFetch(u_coarse, ivec2(gl_FragCoord.xy) >> u_shift, 0).r;
}
