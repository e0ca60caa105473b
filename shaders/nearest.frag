#version 430
// The nearest arcs of each pixel of a distance field (gloffset/gl/nearest_pass.py).
// Drawn over a block of output pixels (fullscreen.vert): the fragment at column x, row y
// is the pixel whose centre is texel (x, y) of u_centers; its cell (x, y) >> u_shift
// holds the list of every arc that can be its nearest (made in float64 on the CPU,
// gloffset/raster/field_gpu.py). Each arc's features (the foot on the arc, or its ends)
// are measured as chords 2 sin(angle / 2) (monotone in the angle), in float32, good to
// NEAREST_ERR (nearest_pass.py, with its derivation); an end shared by two arcs is one
// feature (its vertex id). Out, for the K least features: what the CPU finishes in
// float64 ((pair << 2) | 0 the arc, 1 its end a, 2 its end b; 0xffffffff for none),
// the least chord (its float bits), and how many of the others lie within u_gap of the
// least, 0x100 added where one more may (the CPU then takes the cell's whole list):
// o_near (what[0], what[1], chord, count), o_more (what[2..5]).

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

layout(location = 0) out uvec4 o_near;
layout(location = 1) out uvec4 o_more;

const uint NONE = 0xffffffffu;

const uint LINE = 0x80000000u;  // a key of its own: the arc (line or uncertain)
const float TEST = 1e-6;        // a branch test decided alike in float64 beyond this

// The six least chords of distinct features, ascending, their keys (a vertex id, or
// LINE | pair) and what the CPU finishes ((pair << 2) | 0 the arc, 1 end a, 2 end b);
// plain variables, no arrays (llvmpipe runs an indexed local array many times slower)
float m0, m1, m2, m3, m4, m5;
uint k0, k1, k2, k3, k4, k5;
uint w0, w1, w2, w3, w4, w5;
float dropped;                  // the least chord pushed out of them (or never let in)
float unsure;                   // the least chord of the undecided arcs whose two differ

void put(float v, uint key, uint w) {
    if (!(v < m5)) {
        dropped = min(dropped, v);
        return;
    }
    if (key == k0 || key == k1 || key == k2 || key == k3 || key == k4 || key == k5) {
        return;  // a vertex seen already: the same bits of the same chord
    }
    dropped = min(dropped, m5);
    m5 = v;
    k5 = key;
    w5 = w;
    if (m5 < m4) {
        float t = m4; m4 = m5; m5 = t;
        uint k = k4; k4 = k5; k5 = k;
        uint x = w4; w4 = w5; w5 = x;
    } else {
        return;
    }
    if (m4 < m3) {
        float t = m3; m3 = m4; m4 = t;
        uint k = k3; k3 = k4; k4 = k;
        uint x = w3; w3 = w4; w4 = x;
    } else {
        return;
    }
    if (m3 < m2) {
        float t = m2; m2 = m3; m3 = t;
        uint k = k2; k2 = k3; k3 = k;
        uint x = w2; w2 = w3; w3 = x;
    } else {
        return;
    }
    if (m2 < m1) {
        float t = m1; m1 = m2; m2 = t;
        uint k = k1; k1 = k2; k2 = k;
        uint x = w1; w1 = w2; w2 = x;
    } else {
        return;
    }
    if (m1 < m0) {
        float t = m0; m0 = m1; m1 = t;
        uint k = k0; k0 = k1; k1 = k;
        uint x = w0; w0 = w1; w1 = x;
    } else {
        return;
    }
}

// The features of arc k (pair `pair`) measured from p as chords 2 sin(t / 2): the foot
// on its great circle where it falls on the arc (sin t = |p.n|, cos t = |p - (p.n) n|:
// 2 sin(t / 2) = sin t sqrt(2 / (1 + cos t)), well conditioned at every angle), else
// each end, a feature of its own (its vertex id), where the float32 test decides
// (beyond TEST: float64 decides alike, gloffset.geometry.sphere.arc_distance's test);
// an arc it does not decide is a feature of its own.
void measure(vec3 p, uint k, uint pair) {
    // an arc whose cap lies farther than the least chord so far plus u_gap (by more
    // than 2 NEAREST_ERR more, the errors of this bound and of its chords) has no
    // feature within u_gap of the least: the CPU reads none of it
    vec4 cap = arcs[5u * k + 4u];
    vec3 dm = p - cap.xyz;
    float far = m0 + cap.w + 2.0 * u_gap;
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
    m0 = inf; m1 = inf; m2 = inf; m3 = inf; m4 = inf; m5 = inf;
    k0 = NONE; k1 = NONE; k2 = NONE; k3 = NONE; k4 = NONE; k5 = NONE;
    w0 = NONE; w1 = NONE; w2 = NONE; w3 = NONE; w4 = NONE; w5 = NONE;
    dropped = inf;
    unsure = inf;
    for (uint k = list.x; k < list.x + list.y; k++) {
        measure(p, pairs[k], k);
    }
    float reach = m0 + u_gap;
    uvec4 within = uvec4(lessThanEqual(vec4(m1, m2, m3, m4), vec4(reach)));
    uint near = within.x + within.y + within.z + within.w + (m5 <= reach ? 1u : 0u);
    uint every = dropped <= reach || unsure <= reach ? 0x100u : 0u;
    o_near = uvec4(w0, w1, floatBitsToUint(m0), near | every);
    o_more = uvec4(w2, w3, w4, w5);
}
