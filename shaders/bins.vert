#version 430
// One quad per frontier bin (instanced), covering the bin's cells at level l, so a
// pass touches only the frontier bins and never the rest of the image.
in ivec2 in_bin;     // bin column and row
uniform int u_shift; // l - bin level: a bin is 2^u_shift cells of level l on a side
uniform vec2 u_size; // level l size in cells (the viewport)
const ivec2 CORNERS[6] = ivec2[6](ivec2(0, 0), ivec2(1, 0), ivec2(0, 1),
                                  ivec2(1, 0), ivec2(1, 1), ivec2(0, 1));
void main() {
    vec2 cell = vec2((in_bin + CORNERS[gl_VertexID]) << u_shift);
    gl_Position = vec4(cell / u_size * 2.0 - 1.0, 0.0, 1.0);
}
