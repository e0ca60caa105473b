#version 430
// The nearest arcs of each pixel of a distance field (gloffset/gl/nearest_pass.py).
// Drawn over a block of output pixels (fullscreen.vert): the fragment at column x, row y
// is the pixel whose centre is texel (x, y) of u_centers; its cell (x, y) >> u_shift
// holds the list of every arc that can be its nearest (made in float64 on the CPU,
// gloffset/raster/field_gpu.py). Each arc's distance is measured as the chord
// 2 sin(angle / 2) (monotone in the angle), in float32, good to NEAREST_ERR
// (nearest_pass.py, with its derivation). Out: the arcs of the least and second least
// chord (as positions in the block's pair list; 0xffffffff for none), the least chord
// (its float bits) and bit 0 set where the second lies within u_gap of the least, bit 1
// where a third does: the CPU finishes those in float64.

uniform sampler2D u_centers;  // RGB32F: the pixel centres, unit vectors (float64 rounded)
uniform int u_shift;          // output pixels per cell side: 1 << u_shift
uniform int u_cells_w;        // cells per row of the block
uniform float u_gap;          // 2 NEAREST_ERR: chords nearer than this to the least one
layout(std430, binding = 0) readonly buffer Cells {
    uvec2 cells[];            // per cell (row-major in the block): first pair, pair count
};
layout(std430, binding = 1) readonly buffer Pairs {
    uint pairs[];             // the cells' lists, each pair an arc (row of Arcs)
};
layout(std430, binding = 2) readonly buffer Arcs {
    vec4 arcs[];              // 4 per arc: (a, n.x), (b, n.y), (n x a, n.z), (b x n, ok)
};

out uvec4 o_near;

const uint NONE = 0xffffffffu;

// The chord from p to arc k: to the foot on the arc's great circle where it falls on
// the arc (sin = |p.n|, cos = |p - (p.n) n|: 2 sin(t / 2) = sin t sqrt(2 / (1 + cos t)),
// well conditioned at every angle), else to the nearer end. The branch test is that of
// gloffset.geometry.sphere.arc_distance.
float chord(vec3 p, uint k) {
    vec4 r0 = arcs[4u * k];
    vec4 r1 = arcs[4u * k + 1u];
    vec4 r2 = arcs[4u * k + 2u];
    vec4 r3 = arcs[4u * k + 3u];
    if (r3.w > 0.5 && dot(p, r2.xyz) >= 0.0 && dot(p, r3.xyz) >= 0.0) {
        vec3 n = vec3(r0.w, r1.w, r2.w);
        float s = dot(p, n);
        return abs(s) * sqrt(2.0 / (1.0 + length(p - s * n)));
    }
    return min(length(p - r0.xyz), length(p - r1.xyz));
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    ivec2 cell = px >> u_shift;
    uvec2 list = cells[cell.y * u_cells_w + cell.x];
    vec3 p = texelFetch(u_centers, px, 0).xyz;
    float inf = uintBitsToFloat(0x7f800000u);
    float m1 = inf, m2 = inf, m3 = inf;
    uint a1 = NONE, a2 = NONE;
    for (uint k = list.x; k < list.x + list.y; k++) {
        float v = chord(p, pairs[k]);
        if (v < m1) {
            m3 = m2;
            m2 = m1;
            a2 = a1;
            m1 = v;
            a1 = k;
        } else if (v < m2) {
            m3 = m2;
            m2 = v;
            a2 = k;
        } else if (v < m3) {
            m3 = v;
        }
    }
    uint flags = (m2 <= m1 + u_gap ? 1u : 0u) | (m3 <= m1 + u_gap ? 2u : 0u);
    o_near = uvec4(a1, a2, floatBitsToUint(m1), flags);
}
