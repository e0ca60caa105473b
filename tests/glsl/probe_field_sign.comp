#version 430
// shaders/lib/field_sign.glsl's field_sign at pixels, each with its nearest feature
// (tests/test_field_sign.py).
#include "lib/field_sign.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Pixels {
    vec4 px[];                // the centre, and the feature: (arc << 2) | kind
};
layout(std430, binding = 1) readonly buffer Arcs {
    vec4 arcs[];              // 5 per arc, as shaders/nearest.frag reads them
};
layout(std430, binding = 2) readonly buffer Flags {
    uint flags[];             // per arc: Corners.flags
};
layout(std430, binding = 3) writeonly buffer Out {
    uint got[];
};
uniform uint u_n;

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= u_n) {
        return;
    }
    uint what = floatBitsToUint(px[k].w);
    uint arc = what >> 2;
    got[k] = field_sign(px[k].xyz, what & 3u, arcs[5u * arc], arcs[5u * arc + 1u],
                        arcs[5u * arc + 2u], arcs[5u * arc + 3u], flags[arc]);
}
