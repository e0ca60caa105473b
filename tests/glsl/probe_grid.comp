#version 430
// A grid's GLSL function (GRID_GLSL) at the output-pixel coordinates of a buffer, in
// double (tests/test_grids_glsl.py).
#include GRID_GLSL
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Pixels {
    dvec2 px[];
};
layout(std430, binding = 1) writeonly buffer Points {
    double xyz[];
};
uniform uint u_n;

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= u_n) {
        return;
    }
    dvec3 p = grid_centre(px[k]);
    xyz[3u * k] = p.x;
    xyz[3u * k + 1u] = p.y;
    xyz[3u * k + 2u] = p.z;
}
