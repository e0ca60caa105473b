#version 430
// The nearest arcs of each pixel of a distance field (gloffset/gl/nearest_pass.py).
// Drawn over a block of output pixels (fullscreen.vert): the fragment at column x, row y
// is the pixel whose centre is texel (x, y) of u_centers; its cell (x, y) >> u_shift
// holds the list of every arc that can be its nearest (made in float64 on the CPU,
// gloffset/raster/field_gpu.py). Each arc's features (the foot on the arc, or its ends)
// are measured as chords 2 sin(angle / 2) (monotone in the angle), in float32, good to
// NEAREST_ERR (nearest_pass.py, with its derivation); an end shared by two arcs is one
// feature (its vertex id). Out: what the CPU finishes in float64 for the least and the
// second least feature ((pair << 2) | 0 the arc, 1 its end a, 2 its end b; 0xffffffff
// for none), the least chord (its float bits), and bit 0 set where the second lies
// within u_gap of the least, bit 1 where a third does (the CPU then takes the cell's
// whole list).

uniform sampler2D u_centers;  // RGB32F: the pixel centres, unit vectors (float64 rounded)
uniform int u_shift;          // output pixels per cell side: 1 << u_shift
uniform int u_cells_w;        // cells per row of the block
uniform float u_gap;          // 2 NEAREST_ERR: chords nearer than this to the least one
uniform float u_same;         // NEAREST_ERR / 8: an undecided arc's two chords, at most
layout(std430, binding = 0) readonly buffer Cells {
    uvec2 cells[];            // per cell (row-major in the block): first pair, pair count
};
layout(std430, binding = 1) readonly buffer Pairs {
    uint pairs[];             // the cells' lists, each pair an arc (row of Arcs)
};
layout(std430, binding = 2) readonly buffer Arcs {
    vec4 arcs[];              // 5 per arc: (a, n.x), (b, n.y), (n x a, n.z), (b x n, ok),
};                            // (mid, r): its bounding cap's centre and chord radius
layout(std430, binding = 3) readonly buffer Ends {
    uvec2 ends[];             // per arc: the ids of its ends (one per distinct vertex)
};

out uvec4 o_near;

const uint NONE = 0xffffffffu;

const uint LINE = 0x80000000u;  // a key of its own: the arc (line or uncertain)
const float TEST = 1e-6;        // a branch test decided alike in float64 beyond this

float m1, m2, m3;               // the three least chords of distinct features
uint k1, k2, k3;                // their keys: a vertex id, or LINE | pair
uint w1, w2, w3;                // what the CPU finishes: (pair << 2) | 0 arc, 1 end a, 2 end b
float unsure;                   // the least chord of the undecided arcs whose two differ

void put(float v, uint key, uint what) {
    if (key == k1 || key == k2 || key == k3) {
        return;  // a vertex seen already: the same bits of the same chord
    }
    if (v < m1) {
        m3 = m2; k3 = k2; w3 = w2;
        m2 = m1; k2 = k1; w2 = w1;
        m1 = v; k1 = key; w1 = what;
    } else if (v < m2) {
        m3 = m2; k3 = k2; w3 = w2;
        m2 = v; k2 = key; w2 = what;
    } else if (v < m3) {
        m3 = v; k3 = key; w3 = what;
    }
}

// The features of arc k (pair `pair`) measured from p as chords 2 sin(t / 2): the foot
// on its great circle where it falls on the arc (sin t = |p.n|, cos t = |p - (p.n) n|:
// 2 sin(t / 2) = sin t sqrt(2 / (1 + cos t)), well conditioned at every angle), else
// each end, a feature of its own (its vertex id), where the float32 test decides
// (beyond TEST: float64 decides alike, gloffset.geometry.sphere.arc_distance's test);
// an arc it does not decide is a feature of its own.
void measure(vec3 p, uint k, uint pair) {
    // an arc whose cap lies farther than the third least chord (by more than 2
    // NEAREST_ERR, the errors of this bound and of its chords) would change nothing
    vec4 cap = arcs[5u * k + 4u];
    vec3 dm = p - cap.xyz;
    float far = m3 + cap.w + u_gap;
    if (dot(dm, dm) > far * far) {
        return;
    }
    vec4 r0 = arcs[5u * k];
    vec4 r1 = arcs[5u * k + 1u];
    vec4 r2 = arcs[5u * k + 2u];
    vec4 r3 = arcs[5u * k + 3u];
    float ta = dot(p, r2.xyz);
    float tb = dot(p, r3.xyz);
    bool ok = r3.w > 0.5;
    if (ok && ta >= TEST && tb >= TEST) {
        vec3 n = vec3(r0.w, r1.w, r2.w);
        float s = dot(p, n);
        put(abs(s) * sqrt(2.0 / (1.0 + length(p - s * n))), LINE | pair, pair << 2);
        return;
    }
    float ca = length(p - r0.xyz);
    float cb = length(p - r1.xyz);
    if (!ok || ta < -TEST || tb < -TEST) {
        uvec2 id = ends[k];
        put(ca, id.x, (pair << 2) | 1u);
        put(cb, id.y, (pair << 2) | 2u);
        return;
    }
    // undecided: float64 may take either branch; both chords, and where they differ by
    // more than u_same (the far side of a short arc, seen from near its circle's pole)
    // and the lesser lies within u_gap of the least, the pixel takes its whole list
    vec3 n = vec3(r0.w, r1.w, r2.w);
    float s = dot(p, n);
    float cl = abs(s) * sqrt(2.0 / (1.0 + length(p - s * n)));
    float ce = min(ca, cb);
    if (abs(cl - ce) > u_same) {
        unsure = min(unsure, min(cl, ce));
    }
    put(min(cl, ce), LINE | pair, pair << 2);
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    ivec2 cell = px >> u_shift;
    uvec2 list = cells[cell.y * u_cells_w + cell.x];
    vec3 p = texelFetch(u_centers, px, 0).xyz;
    float inf = uintBitsToFloat(0x7f800000u);
    m1 = inf; m2 = inf; m3 = inf;
    unsure = inf;
    k1 = NONE; k2 = NONE; k3 = NONE;
    w1 = NONE; w2 = NONE; w3 = NONE;
    for (uint k = list.x; k < list.x + list.y; k++) {
        measure(p, pairs[k], k);
    }
    uint flags = (m2 <= m1 + u_gap ? 1u : 0u) | (m3 <= m1 + u_gap || unsure <= m1 + u_gap ? 2u : 0u);
    o_near = uvec4(w1, w2, floatBitsToUint(m1), flags);
}
