#version 430
// The double log, wide exp and atan2 of lib/fp64.glsl at the pairs of a buffer
// (tests/test_grids_lcc.py): per pair (a, b), log(a), exp_wide(b), atan2(b, a).
#include "lib/fp64.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Values {
    dvec2 ab[];
};
layout(std430, binding = 1) writeonly buffer Results {
    double out3[];
};
uniform uint u_n;

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= u_n) {
        return;
    }
    dvec2 v = ab[k];
    out3[3u * k] = fp64_log(v.x);
    out3[3u * k + 1u] = fp64_exp_wide(v.y);
    out3[3u * k + 2u] = fp64_atan2(v.y, v.x);
}
