#version 430
// The per-pixel stage of a distance field (gloffset/gl/field_pass.py,
// gloffset/raster/fields/gpu.py): each pixel's distance (rad, float64) to its nearest arc.
// One invocation per output pixel of a block, 8 x 8 to a work group; pixel (x, y) of the
// block lies in cell (x, y) >> u_shift, whose list (made in float64 on the host) holds
// every arc that can be its nearest.
// 1. The centre, in double, on the GPU: lon/lat grids from the (cos, sin) of their row's
//    latitude and column's longitude (the host's products, bit for bit), cube faces from
//    their rows' and columns' face coordinates (lib/cube64.glsl, cube_point), grids with a
//    GLSL function from it (GRID_GLSL); other grids read the host's centres (GRID_TEXTURE).
// 2. The ranking, in float32 (of the arcs of the list that the pixel may need: its
//    lists pruned, 2a): each arc's nearest feature (the foot on the arc, or its
//    nearer end; the arc itself where its ends' chords lie within u_gap) as a chord
//    2 sin(angle / 2), good to NEAREST_ERR (field_pass.py, with its derivation); an end
//    shared by two arcs is one feature (its vertex id); the six least kept, with how
//    many lie within u_gap of the least and whether more may.
// 3. The finishing, in double: the features within u_gap of the least (the cell's whole
//    list, its far caps skipped, where more may be), each with the operations of
//    gloffset.geometry.sphere.arc_distance (products and sums rounded once, `precise`:
//    no fused multiply-add; square roots and arctangents from lib/fp64.glsl), the least
//    written. A cell with no arc writes +inf. Shaped for llvmpipe, which runs the body of
//    every branch its lanes take (masked: of every `if`, at least once of every loop):
//    the ranking's insertion has no branch, and one loop finishes every feature (its
//    body run as often as the most its lanes ask), keeping the least six for the sign.
// 4. The sign (u_signed), from the finished features within FIELD_ETA of the least
//    (lib/field_sign.glsl with the corner flags of gloffset.raster.fields.sign.Corners,
//    the answers combined: decided only where they agree), undecided where the pixel's
//    disc may hold a seam; the host leaves undecided the pixels within NEAR of the
//    boundary or beyond max_distance and settles the undecided by the levels.
#include "lib/fp64.glsl"
#include "lib/field_sign.glsl"
#include "lib/cube64.glsl"
#include GRID_GLSL

layout(local_size_x = 8, local_size_y = 8) in;

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
layout(std430, binding = 4) readonly buffer Exact {
    dvec4 exact[];            // 4 per arc (float64): (a, ok), (b, bn.x), (n, bn.y),
};                            // (n x a, bn.z), with bn = b x n and ok 1 or 0
layout(std430, binding = 5) writeonly buffer Out {
    double dist[];            // per pixel of the block (row-major): the distance (rad)
};
layout(std430, binding = 6) readonly buffer Rows {
    double rows[];            // per pixel row: lon/lat (cos, sin) of its latitude; cube:
};                            // its face coordinate t; texture: the centres (x, y, z)
layout(std430, binding = 7) readonly buffer Cols {
    double cols[];            // per pixel column: lon/lat (cos, sin) of its longitude;
};                            // cube: its face coordinate s

layout(std430, binding = 8) readonly buffer Flags {
    uint flags[];             // per arc: Corners.flags (with u_signed)
};
layout(std430, binding = 9) readonly buffer Seams {
    vec4 seams[];             // the seams' bounding caps: (mid, half angle)
};
layout(std430, binding = 11) readonly buffer Chunks {
    vec4 chunks[];            // at each chunk's first pair: a cap holding its arcs' caps
};                            // (centre, chord radius; field_pass.chunk_caps)
layout(std430, binding = 10) writeonly buffer Sign {
    uint sign_code[];         // per pixel: FIELD_OUTSIDE, FIELD_INSIDE or FIELD_UNDECIDED
};

uniform ivec2 u_size;         // the block's pixels (columns, rows)
uniform ivec2 u_origin;       // its first pixel in the grid (column, row)
uniform int u_row0;           // the first row of this dispatch (a band of the block's rows)
uniform int u_shift;          // output pixels per cell side: 1 << u_shift
uniform int u_cells_w;        // cells per row of the block
uniform float u_gap;          // 2 NEAREST_ERR: chords nearer than this to the least one
uniform float u_prune;        // PRUNE_MARGIN: an arc's cap beyond U + this is dropped
uniform float u_same;         // NEAREST_ERR / 8: an undecided arc's two chords, at most
uniform int u_signed;         // 1: write the sign codes too
uniform int u_seams;          // seams (rows of Seams)
uniform uint u_direct;        // lists of at most this many arcs are finished whole in
                              // double, unranked (field_pass.DIRECT; 0: none)
#ifdef GRID_CUBE
uniform vec3 u_face_e;        // the face's axis and the directions of s and t (0, +-1)
uniform vec3 u_face_u;
uniform vec3 u_face_v;
#endif

const uint NONE = 0xffffffffu;
const uint LINE = 0x80000000u;  // a key of its own: the arc (line or uncertain)
const float TEST = 1e-6;        // a branch test decided alike in float64 beyond this
const double FIELD_ETA = 1e-13LF;  // gloffset.raster.fields.sign.ETA
const float SEAM_MARGIN = 1e-5;  // the float32 seam test's margin (its error: 1e-6)

// The centre of pixel (x, y) of the block, in double.
dvec3 pixel_centre(ivec2 px) {
#ifdef GRID_CUBE
    return cube_point(cols[px.x], rows[px.y], dvec3(u_face_e), dvec3(u_face_u),
                      dvec3(u_face_v));
#elif defined(GRID_GLSL)
    return grid_centre(dvec2(u_origin + px) + 0.5LF);
#elif defined(GRID_TEXTURE)
    uint k = 3u * uint(px.y * u_size.x + px.x);
    return dvec3(rows[k], rows[k + 1u], rows[k + 2u]);
#else
    // LonLatGrid.centers: (cos(phi) cos(lam), cos(phi) sin(lam), sin(phi))
    double cphi = rows[2 * px.y], sphi = rows[2 * px.y + 1];
    precise double x = cphi * cols[2 * px.x];
    precise double y = cphi * cols[2 * px.x + 1];
    return dvec3(x, y, sphi);
#endif
}

// ---- 2. the ranking, in float32 ------------------------------------------------------

// The six least chords of distinct features, ascending, their keys (a vertex id, or
// LINE | pair) and what the finishing reads ((pair << 2) | 0 the arc, 1 end a, 2 end b);
// plain variables, no arrays (llvmpipe runs an indexed local array many times slower)
float m0, m1, m2, m3, m4, m5;
uint k0, k1, k2, k3, k4, k5;
uint w0, w1, w2, w3, w4, w5;
float dropped;                  // the least chord pushed out of them (or never let in)
float unsure;                   // the least chord of the undecided arcs whose two differ

void put(float v, uint key, uint w) {
    // branch-free (llvmpipe runs both sides of a branch its lanes disagree on, and
    // the body of any branch): a chord not below m5 is dropped, a vertex seen already
    // (the same bits of the same chord) is skipped, else it is inserted after the
    // equal ones and pushes m5 out
    bool in6 = v < m5;
    bool seen = key == k0 || key == k1 || key == k2 || key == k3 || key == k4 || key == k5;
    bool ins = in6 && !seen;
    float inf = uintBitsToFloat(0x7f800000u);
    dropped = min(dropped, in6 ? (seen ? inf : m5) : v);
    float x = ins ? v : inf;
    bool s;
    float tm; uint tk, tw;
    s = x < m0; tm = m0; tk = k0; tw = w0;
    m0 = s ? x : m0; k0 = s ? key : k0; w0 = s ? w : w0;
    x = s ? tm : x; key = s ? tk : key; w = s ? tw : w;
    s = x < m1; tm = m1; tk = k1; tw = w1;
    m1 = s ? x : m1; k1 = s ? key : k1; w1 = s ? w : w1;
    x = s ? tm : x; key = s ? tk : key; w = s ? tw : w;
    s = x < m2; tm = m2; tk = k2; tw = w2;
    m2 = s ? x : m2; k2 = s ? key : k2; w2 = s ? w : w2;
    x = s ? tm : x; key = s ? tk : key; w = s ? tw : w;
    s = x < m3; tm = m3; tk = k3; tw = w3;
    m3 = s ? x : m3; k3 = s ? key : k3; w3 = s ? w : w3;
    x = s ? tm : x; key = s ? tk : key; w = s ? tw : w;
    s = x < m4; tm = m4; tk = k4; tw = w4;
    m4 = s ? x : m4; k4 = s ? key : k4; w4 = s ? w : w4;
    x = s ? tm : x; key = s ? tk : key; w = s ? tw : w;
    s = x < m5;
    m5 = s ? x : m5; k5 = s ? key : k5; w5 = s ? w : w5;
}

// Whether arc k's bounding cap lies farther from p than the least chord so far plus
// u_gap (by more than 2 NEAREST_ERR more, the errors of this bound and of its chords):
// then it has no feature within u_gap of the least.
bool far_cap(vec3 p, uint k) {
    vec4 cap = arcs[5u * k + 4u];
    vec3 dm = p - cap.xyz;
    float far = m0 + cap.w + 2.0 * u_gap;
    return dot(dm, dm) > far * far;
}

// The features of arc k (pair `pair`) measured from p as chords 2 sin(t / 2): the foot
// on its great circle where it falls on the arc (sin t = |p.n|, cos t = |p - (p.n) n|:
// 2 sin(t / 2) = sin t sqrt(2 / (1 + cos t)), well conditioned at every angle), else
// each end, a feature of its own (its vertex id), where the float32 test decides
// (beyond TEST: float64 decides alike, gloffset.geometry.sphere.arc_distance's test);
// an arc it does not decide is a feature of its own. One put per arc (see below).
void measure(vec3 p, uint k, uint pair) {
    // every case computed, two puts (llvmpipe runs the body of every branch anyway)
    float inf = uintBitsToFloat(0x7f800000u);
    bool far = far_cap(p, k);
    vec4 r0 = arcs[5u * k];
    vec4 r1 = arcs[5u * k + 1u];
    vec4 r2 = arcs[5u * k + 2u];
    vec4 r3 = arcs[5u * k + 3u];
    float ta = dot(p, r2.xyz);
    float tb = dot(p, r3.xyz);
    bool ok = r3.w > 0.5;
    bool foot = ok && ta >= TEST && tb >= TEST;
    bool two = !ok || ta < -TEST || tb < -TEST;  // its ends
    vec3 n = vec3(r0.w, r1.w, r2.w);
    float s = dot(p, n);
    float cl = abs(s) * sqrt(2.0 / (1.0 + length(p - s * n)));
    float ca = length(p - r0.xyz);
    float cb = length(p - r1.xyz);
    // undecided: float64 may take either branch; both chords, and where they differ by
    // more than u_same (the far side of a short arc, seen from near its circle's pole)
    // and the lesser lies within u_gap of the least, the pixel takes its whole list
    float ce = min(ca, cb);
    if (!far && !foot && !two && abs(cl - ce) > u_same) {
        unsure = min(unsure, min(cl, ce));
    }
    // one feature per arc: the foot; its nearer end, one feature with the other arcs
    // of its vertex, where the ends' chords differ by more than u_gap (the nearer in
    // float64 too); else the arc itself (finished to its nearer end in double)
    uvec2 id = ends[k];
    bool vertex = two && abs(ca - cb) > u_gap;
    bool at_a = ca < cb;
    float v = far ? inf : (foot ? cl : min(cl, ce));
    v = two && !far ? ce : v;
    put(v, vertex ? (at_a ? id.x : id.y) : LINE | pair,
        vertex ? (pair << 2) | (at_a ? 1u : 2u) : pair << 2);
}

// ---- 2a. the pruning, per pixel (PRUNE) ----------------------------------------------

// Lists of at least PRUNE_MIN arcs are pruned: each pixel ranks only the arcs whose
// bounding caps come within U + PRUNE_MARGIN of it, U an upper bound of its nearest
// arc's chord (its least chord to a chunk's cap, then to the first ends of the arcs
// of the chunks that may hold a nearer one). Every arc that the ranking and the
// finishing read at p has its cap within the least ranked chord + 2 u_gap (far_cap),
// and the least ranked chord is at most U plus the ranking's error (NEAREST_ERR): the
// arcs dropped change no value that is read (field_pass.py, PRUNE_MARGIN).
// llvmpipe runs a loop as often as the most its lanes ask: a chunk's arcs are visited
// only where some lane's test passes its cap.
const uint PRUNE_MIN = 8u;
const uint CHUNK = 8u;          // pairs per chunk (field_pass.CHUNK), dividing 32

// U + PRUNE_MARGIN at p for the list's first n pairs (inf for none).
float prune_limit(vec3 p, uvec2 list, uint n) {
    uint nc = (n + CHUNK - 1u) / CHUNK;
    float u = uintBitsToFloat(0x7f800000u);
    for (uint j = 0u; j < nc; j++) {
        vec4 c = chunks[list.x + j * CHUNK];
        u = min(u, length(p - c.xyz) + c.w);
    }
    for (uint j = 0u; j < nc; j++) {
        uint k0 = list.x + j * CHUNK;
        vec4 c = chunks[k0];
        uint m = length(p - c.xyz) - c.w <= u ? min(CHUNK, n - j * CHUNK) : 0u;
        for (uint i = 0u; i < m; i++) {
            u = min(u, length(p - arcs[5u * pairs[k0 + i]].xyz));
        }
    }
    return u + u_prune;
}

// The bits of word wd of the list (bit b: pair list.x + 32 wd + b) whose arcs' caps
// come within lim of p.
uint kept_bits(vec3 p, uvec2 list, uint wd, float lim) {
    uint n = list.y;
    uint nc = (n + CHUNK - 1u) / CHUNK;
    uint bits = 0u;
    for (uint j = 0u; j < min(32u / CHUNK, nc - wd * (32u / CHUNK)); j++) {
        uint at = (wd << 5) + j * CHUNK;
        vec4 c = chunks[list.x + at];
        vec3 dc = p - c.xyz;
        float rc = lim + c.w;
        uint m = dot(dc, dc) <= rc * rc ? min(CHUNK, n - at) : 0u;
        for (uint i = 0u; i < m; i++) {
            vec4 cap = arcs[5u * pairs[list.x + at + i] + 4u];
            vec3 dm = p - cap.xyz;
            float r = lim + cap.w;
            bits |= dot(dm, dm) <= r * r ? 1u << (at + i - (wd << 5)) : 0u;
        }
    }
    return bits;
}

// ---- 3. the finishing, in double -----------------------------------------------------

// u . v summed as gloffset.geometry.sphere.dot sums: (u0 v0 + u1 v1) + u2 v2
double dot3(dvec3 u, dvec3 v) {
    precise double s = u.x * v.x + u.y * v.y + u.z * v.z;
    return s;
}

// The squared lengths (|p - v|^2, |p + v|^2) of the angle from p to the point v, 2
// atan2(|p - v|, |p + v|) = 2 atan2(sqrt(A B), B) (one square root).
dvec2 end_lengths(dvec3 p, dvec3 v) {
    precise dvec3 dm = p - v;
    precise dvec3 dp = p + v;
    return dvec2(dot3(dm, dm), dot3(dp, dp));
}

// The exact distance of a feature ((pair << 2) | kind) as the ranking names it: kind 1
// or 2 an end (2 atan2(|p - v|, |p + v|)), kind 0 the arc (arc_distance): to its great
// circle, atan2(|p.n|, |p - (p.n) n|), where the foot falls on the arc (p.(n x a) >= 0,
// p.(b x n) >= 0, n a normal), else to the nearer end (the one of lesser tan^2 of half
// its angle, A / B, compared as A_a B_b < A_b B_a: where the roundings could swap them,
// their angles agree to a few ulp). Every case ends in one square root and one
// arctangent (no branch of the SIMD lanes runs them twice). `got` says which it was,
// for the sign: 4 the foot with p . n > 0 (in double, as the host's rule), 0 the foot
// with p . n <= 0, 1 end a, 2 end b, 3 the arc's nearer end.
double feature(dvec3 p, uint w, out uint got) {
    uint k = pairs[w >> 2];
    uint kind = w & 3u;
    dvec4 r0 = exact[4u * k];
    dvec4 r1 = exact[4u * k + 1u];
    bool foot = false;
    double pn = 0.0LF;
    double q;  // the square root's argument: |foot|^2, or A B
    double x;  // atan2's x for an end: B
    if (kind == 0u) {
        dvec4 r2 = exact[4u * k + 2u];
        dvec4 r3 = exact[4u * k + 3u];
        foot = r0.w > 0.5LF && dot3(p, r3.xyz) >= 0.0LF
            && dot3(p, dvec3(r1.w, r2.w, r3.w)) >= 0.0LF;
        if (foot) {
            pn = dot3(p, r2.xyz);
            precise dvec3 f = p - pn * r2.xyz;
            q = dot3(f, f);
            got = pn > 0.0LF ? 4u : 0u;
        } else {
            got = 3u;
            dvec2 ea = end_lengths(p, r0.xyz);
            dvec2 eb = end_lengths(p, r1.xyz);
            dvec2 e = ea.x * eb.y <= eb.x * ea.y ? ea : eb;
            q = e.x * e.y;
            x = e.y;
        }
    } else {
        got = kind;
        dvec2 e = end_lengths(p, kind == 1u ? r0.xyz : r1.xyz);
        q = e.x * e.y;
        x = e.y;
    }
    double r = fp64_sqrt(q);
    double t = fp64_atan2(foot ? abs(pn) : r, foot ? r : x);
    return foot ? t : 2.0LF * t;
}

// The sign's answer of a finished feature ((pair << 2) | kind, `got` as feature()
// reports it) combined with the answers so far (`none`: no answer yet): the foot's
// side from its double p . n, its lune values and the ends' rule from
// lib/field_sign.glsl; an arc's nearer end by p . (a - b) in double, both ends asked
// where it lies within 2 FIELD_ETA of 0 (their distances may be that near:
// fields/sign.py's test).
uint feature_sign(dvec3 pd, vec3 p, uint w, uint got, uint now, inout bool none) {
    uint k = pairs[w >> 2];
    vec4 r0 = arcs[5u * k];
    vec4 r1 = arcs[5u * k + 1u];
    vec4 r2 = arcs[5u * k + 2u];
    vec4 r3 = arcs[5u * k + 3u];
    uint corner = flags[k];
    uint ans;
    if (got == 0u || got == 4u) {
        uint side = got == 4u ? FIELD_INSIDE : FIELD_OUTSIDE;
        ans = field_sign_foot(side, dot(p, r2.xyz), dot(p, r3.xyz), corner);
    } else if (got == 3u) {
        precise dvec3 ab = exact[4u * k].xyz - exact[4u * k + 1u].xyz;
        double s = dot3(pd, ab);  // > 0: a is the nearer end
        if (s > 2.0LF * FIELD_ETA) {
            ans = field_sign(p, 1u, r0, r1, r2, r3, corner);
        } else if (s < -2.0LF * FIELD_ETA) {
            ans = field_sign(p, 2u, r0, r1, r2, r3, corner);
        } else {
            ans = field_sign_agree(field_sign(p, 1u, r0, r1, r2, r3, corner),
                                   field_sign(p, 2u, r0, r1, r2, r3, corner));
        }
    } else {
        ans = field_sign(p, got, r0, r1, r2, r3, corner);
    }
    if (none) {
        none = false;
        return ans;
    }
    return field_sign_agree(now, ans);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy) + ivec2(0, u_row0);
    if (px.x >= u_size.x || px.y >= u_size.y) {
        return;
    }
    ivec2 cell = px >> u_shift;
    uvec2 list = cells[cell.y * u_cells_w + cell.x];
    dvec3 pd = pixel_centre(px);
    vec3 p = vec3(pd);
    float inf = uintBitsToFloat(0x7f800000u);
    m0 = inf; m1 = inf; m2 = inf; m3 = inf; m4 = inf; m5 = inf;
    k0 = NONE; k1 = NONE; k2 = NONE; k3 = NONE; k4 = NONE; k5 = NONE;
    w0 = NONE; w1 = NONE; w2 = NONE; w3 = NONE; w4 = NONE; w5 = NONE;
    dropped = inf;
    unsure = inf;
#ifdef PRUNE
    // the ranking of the list's arcs that p may need (2a), a word of the list at a time
    bool prune = list.y >= PRUNE_MIN;
    float lim = prune_limit(p, list, prune ? list.y : 0u);
    uint words = (list.y + 31u) >> 5;
    for (uint wd = 0u; wd < words; wd++) {
        uint tail = list.y - (wd << 5);
        uint bits = tail >= 32u ? 0xffffffffu : (1u << tail) - 1u;
        bits = prune ? kept_bits(p, list, wd, lim) : bits;
        uint base = list.x + (wd << 5);
        while (bits != 0u) {
            uint b = uint(findLSB(bits));
            bits &= bits - 1u;
            measure(p, pairs[base + b], base + b);
        }
    }
    bool direct = false;
#else
    // a short list of a deep block: its arcs finished in double, unranked (below)
    bool direct = list.y <= u_direct;
    for (uint k = list.x; k < list.x + (direct ? 0u : list.y); k++) {
        measure(p, pairs[k], k);
    }
#endif
    uint at = uint(px.y * u_size.x + px.x);
    if (w0 == NONE && (!direct || list.y == 0u)) {
        dist[at] = double(inf);
        if (u_signed != 0) {
            sign_code[at] = FIELD_UNDECIDED;
        }
        return;
    }
    // the features within reach of the least, in double (the least first)
    float reach = m0 + u_gap;
#ifdef PROBE_RANKING
    // the ranking alone (tests/test_field_gpu.py): the least chord, negated where the
    // pixel would take its cell's whole list
    dist[at] = dropped <= reach || unsure <= reach ? -double(m0) : double(m0);
    return;
#endif
    // One loop finishes them (llvmpipe runs a loop's body as often as the most any of
    // its lanes asks, at least once, and the body of every branch): first the six's
    // within reach, then, where more may be, the cell's whole list (arcs whose caps lie
    // beyond reach skipped); a direct list (u_direct), its arcs alone (each arc's
    // distance is the least of its features': the same least value). The least finished features are kept (distance, kind,
    // feature) for the sign, six of them.
    uint near_n = direct ? 0u : 1u + uint(m1 <= reach) + uint(m2 <= reach)
        + uint(m3 <= reach) + uint(m4 <= reach) + uint(m5 <= reach);
    bool whole = direct || dropped <= reach || unsure <= reach;
    uint n = near_n + (whole ? list.y : 0u);
    double dinf = double(inf);
    double d = dinf;
    double e0 = dinf, e1 = dinf, e2 = dinf, e3 = dinf, e4 = dinf, e5 = dinf;
    uint q0 = 3u, q1 = 3u, q2 = 3u, q3 = 3u, q4 = 3u, q5 = 3u;
    uint v0 = NONE, v1 = NONE, v2 = NONE, v3 = NONE, v4 = NONE, v5 = NONE;
    for (uint i = 0u; i < n; i++) {
        bool listed = i >= near_n;
        uint k = list.x + i - near_n;
        uint w = listed ? k << 2 : w0;
        w0 = w1; w1 = w2; w2 = w3; w3 = w4; w4 = w5;
        bool skip = listed && far_cap(p, pairs[k]);
        uint g;
        double x = feature(pd, w, g);
        x = skip ? dinf : x;
        d = min(d, x);
        // keep it among the least six (after the equal ones)
        bool c;
        double te; uint tq, tv;
        c = x < e0; te = e0; tq = q0; tv = v0;
        e0 = c ? x : e0; q0 = c ? g : q0; v0 = c ? w : v0;
        x = c ? te : x; g = c ? tq : g; w = c ? tv : w;
        c = x < e1; te = e1; tq = q1; tv = v1;
        e1 = c ? x : e1; q1 = c ? g : q1; v1 = c ? w : v1;
        x = c ? te : x; g = c ? tq : g; w = c ? tv : w;
        c = x < e2; te = e2; tq = q2; tv = v2;
        e2 = c ? x : e2; q2 = c ? g : q2; v2 = c ? w : v2;
        x = c ? te : x; g = c ? tq : g; w = c ? tv : w;
        c = x < e3; te = e3; tq = q3; tv = v3;
        e3 = c ? x : e3; q3 = c ? g : q3; v3 = c ? w : v3;
        x = c ? te : x; g = c ? tq : g; w = c ? tv : w;
        c = x < e4; te = e4; tq = q4; tv = v4;
        e4 = c ? x : e4; q4 = c ? g : q4; v4 = c ? w : v4;
        x = c ? te : x; g = c ? tq : g; w = c ? tv : w;
        c = x < e5;
        e5 = c ? x : e5; q5 = c ? g : q5; v5 = c ? w : v5;
    }
    dist[at] = d;
    if (u_signed == 0) {
        return;
    }
    // 4. the sign: every finished feature within FIELD_ETA of the least asked (all of
    // them kept, else undecided)
    double near = d + FIELD_ETA;
    uint code = FIELD_UNDECIDED;
    bool none = true;
    uint ns = uint(e0 <= near) + uint(e1 <= near) + uint(e2 <= near) + uint(e3 <= near)
        + uint(e4 <= near) + uint(e5 <= near);
    for (uint i = 0u; i < ns; i++) {
        code = feature_sign(pd, p, v0, q0, code, none);
        v0 = v1; v1 = v2; v2 = v3; v3 = v4; v4 = v5;
        q0 = q1; q1 = q2; q2 = q3; q3 = q4; q4 = q5;
    }
    if (none || e5 <= near) {
        code = FIELD_UNDECIDED;
    }
    // a disc about p of radius d that may hold a seam: undecided
    float df = float(d);
    for (int k = 0; k < u_seams && code != FIELD_UNDECIDED; k++) {
        vec4 cap = seams[k];
        float t = 2.0 * atan(length(p - cap.xyz), length(p + cap.xyz));
        if (t - cap.w <= df + SEAM_MARGIN) {
            code = FIELD_UNDECIDED;
        }
    }
    sign_code[at] = code;
}
