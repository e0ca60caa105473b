#version 430
// The double helpers of lib/fp64.glsl at the values of a buffer (tests/test_grids_tm.py):
// per value x, exp(x), sin(x), cos(x), sqrt(|x|), 1 / |x|.
#include "lib/fp64.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Values {
    double xs[];
};
layout(std430, binding = 1) writeonly buffer Results {
    double out5[];
};
uniform uint u_n;

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= u_n) {
        return;
    }
    double x = xs[k];
    double s, c;
    fp64_sin_cos(x, s, c);
    out5[5u * k] = fp64_exp(x);
    out5[5u * k + 1u] = s;
    out5[5u * k + 2u] = c;
    out5[5u * k + 3u] = fp64_sqrt(abs(x));
    out5[5u * k + 4u] = fp64_recip(abs(x));
}
