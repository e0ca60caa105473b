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
// 2. The ranking, in float32: each arc's features (the foot on the arc, or its ends) as
//    chords 2 sin(angle / 2), good to NEAREST_ERR (field_pass.py, with its derivation);
//    an end shared by two arcs is one feature (its vertex id); the six least kept, with
//    how many lie within u_gap of the least and whether more may.
// 3. The finishing, in double: the features within u_gap of the least (the cell's whole
//    list, its far caps skipped, where more may be), each with the operations of
//    gloffset.geometry.sphere.arc_distance (products and sums rounded once, `precise`:
//    no fused multiply-add; square roots and arctangents from lib/fp64.glsl), the least
//    written. A cell with no arc writes +inf.
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
layout(std430, binding = 10) writeonly buffer Sign {
    uint sign_code[];         // per pixel: FIELD_OUTSIDE, FIELD_INSIDE or FIELD_UNDECIDED
};

uniform ivec2 u_size;         // the block's pixels (columns, rows)
uniform ivec2 u_origin;       // its first pixel in the grid (column, row)
uniform int u_shift;          // output pixels per cell side: 1 << u_shift
uniform int u_cells_w;        // cells per row of the block
uniform float u_gap;          // 2 NEAREST_ERR: chords nearer than this to the least one
uniform float u_same;         // NEAREST_ERR / 8: an undecided arc's two chords, at most
uniform int u_signed;         // 1: write the sign codes too
uniform int u_seams;          // seams (rows of Seams)
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
    }
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
// an arc it does not decide is a feature of its own.
void measure(vec3 p, uint k, uint pair) {
    if (far_cap(p, k)) {
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
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
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
    for (uint k = list.x; k < list.x + list.y; k++) {
        measure(p, pairs[k], k);
    }
    uint at = uint(px.y * u_size.x + px.x);
    if (w0 == NONE) {
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
    uint g0 = 3u, g1 = 3u, g2 = 3u, g3 = 3u, g4 = 3u, g5 = 3u;
    double d0 = feature(pd, w0, g0);
    double d1 = double(inf), d2 = d1, d3 = d1, d4 = d1, d5 = d1;
    if (m1 <= reach) {
        d1 = feature(pd, w1, g1);
    }
    if (m2 <= reach) {
        d2 = feature(pd, w2, g2);
    }
    if (m3 <= reach) {
        d3 = feature(pd, w3, g3);
    }
    if (m4 <= reach) {
        d4 = feature(pd, w4, g4);
    }
    if (m5 <= reach) {
        d5 = feature(pd, w5, g5);
    }
    double d = min(min(min(d0, d1), min(d2, d3)), min(d4, d5));
    // more may be: the cell's whole list (arcs whose caps lie beyond reach skipped)
    bool whole = dropped <= reach || unsure <= reach;
    if (whole) {
        uint gk;
        for (uint k = list.x; k < list.x + list.y; k++) {
            uint a = pairs[k];
            if (!far_cap(p, a)) {
                d = min(d, feature(pd, k << 2, gk));
            }
        }
    }
    dist[at] = d;
    if (u_signed == 0) {
        return;
    }
    // 4. the sign: every finished feature within FIELD_ETA of the least asked
    double near = d + FIELD_ETA;
    uint code = FIELD_UNDECIDED;
    bool none = true;
    if (d0 <= near) { code = feature_sign(pd, p, w0, g0, code, none); }
    if (d1 <= near) { code = feature_sign(pd, p, w1, g1, code, none); }
    if (d2 <= near) { code = feature_sign(pd, p, w2, g2, code, none); }
    if (d3 <= near) { code = feature_sign(pd, p, w3, g3, code, none); }
    if (d4 <= near) { code = feature_sign(pd, p, w4, g4, code, none); }
    if (d5 <= near) { code = feature_sign(pd, p, w5, g5, code, none); }
    if (whole) {
        uint gk;
        for (uint k = list.x; k < list.x + list.y; k++) {
            uint a = pairs[k];
            if (!far_cap(p, a) && feature(pd, k << 2, gk) <= near) {
                code = feature_sign(pd, p, k << 2, gk, code, none);
            }
        }
    }
    if (none) {
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
