#version 430
// A refined level's children and their candidate pairs (gloffset/raster/vector/levels.py
// refine, gloffset/gl/refine_pass.py): the work of child_pairs.slot_pairs, arcs_cross and
// levels._on_ring.
//
// One invocation per chunk of a parent's candidate pairs (u_chunk: the parent k, the chunk's
// first pair and its count, at most CHUNK: the work of the invocations alike). The parent's
// children (at most four, u_slot[k], -1 where none) each take every pair whose cap test passes:
// cm >= cos(min(first + h, pi)) - COS_SLACK, cm = c.m of the child's centre c and the arc's
// cap centre m, evaluated as (c.x m.x + c.z m.z) + c.y m.y with each product and sum rounded
// once (`precise` forbids fusing them): the numpy path's operations in its order. The
// threshold here is cos(first) cos(h) - sin(first) sin(h) - COS_SLACK from the host's float64
// cosines and sines, within 1e-14 of the host's; a pair more than MARGIN (1e-9) below it
// fails, one more than MARGIN above passes, and those between (and every pair whose first + h
// comes within 1e-6 of pi, where the host clamps the sum) are written with UNSURE set in
// the arc: the host takes its exact test on those alone.
//
// COUNT (the first dispatch): each chunk's number of pairs written per child slot (o_count),
// and two lists that the host reads back whole:
// * the ring edges (u_term[3 * arc + 1].z != 0) whose cap comes within seg (the child's
//   distance to its parent's centre) of the child (the same bounded test, NEAR_UNSURE where
//   the host decides) and that cross the short arc child -> parent centre (arcs_cross, its
//   products and sums each rounded once, in its order): (child, arc | flags) in o_toggle;
// * the pairs of ring edges whose great circle passes within ON_EDGE of the parent's centre
//   (|p.n| <= ON_EDGE, p.n as (p.x n.x + p.z n.z) + p.y n.y, the host's order): (parent, arc)
//   in o_on, whose cap test (levels.on_edge) is the host's.
// A list longer than its capacity is counted on (the host then takes the numpy path).
// Without COUNT: each chunk's pairs of slot s written from u_first_out[chunk][s] on (the
// host's sums of the counts: each child's pairs in its parent's order): the arc (with
// UNSURE) in o_arc, cm in o_cm.
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Chunks { ivec4 u_chunk[]; };   // k, first, count
layout(std430, binding = 1) readonly buffer PairArc { int u_arc[]; };      // pairs
layout(std430, binding = 2) readonly buffer Slots { ivec4 u_slot[]; };     // k
// per child: (c.x, c.y, c.z, first), (cos first, sin first, cos seg, sin seg), (seg, 0, 0, 0)
layout(std430, binding = 3) readonly buffer Children { dvec4 u_child[]; };
layout(std430, binding = 4) readonly buffer Parents { dvec4 u_parent[]; }; // centre, 0
// per arc: (m, h), (cos h, sin h, 1 for a ring edge else 0, 0), (n, 0)
layout(std430, binding = 5) readonly buffer Terms { dvec4 u_term[]; };
// the arcs' rows (gloffset.edges.CurveArcs.rows: a, b, n at 0, 3, 6): the crossing tests'
layout(std430, binding = 6) readonly buffer Rows { double u_rows[]; };
layout(std430, binding = 7) writeonly buffer Counts { uvec4 o_count[]; };   // per chunk
layout(std430, binding = 8) readonly buffer FirstOut { uvec4 u_first_out[]; };
layout(std430, binding = 9) writeonly buffer OutArc { uint o_arc[]; };
layout(std430, binding = 10) writeonly buffer OutCm { double o_cm[]; };
layout(std430, binding = 11) writeonly buffer Toggles { uvec2 o_toggle[]; };
layout(std430, binding = 12) writeonly buffer OnEdge { uvec2 o_on[]; };
layout(std430, binding = 13) buffer Lists { uint o_lists[]; };  // toggles, on-edge pairs

uniform int u_chunks;
uniform uint u_toggle_capacity;
uniform uint u_on_capacity;

const uint UNSURE = 0x80000000u;
const uint NEAR_UNSURE = 0x40000000u;
const double MARGIN = 1e-9LF;  // gloffset.raster.gpu.GPU_PAIR_MARGIN
const double COS_SLACK = 1e-12LF;  // gloffset.geometry.caps.COS_SLACK
const double ON_EDGE = 1e-13LF;  // gloffset.raster.vector.levels.ON_EDGE
const double NEAR_PI = 3.1415916535897932LF;  // pi - 1e-6: the host's clamp is near

dvec3 arc_point(int arc, int at) {
    int k = 20 * arc + at;
    return dvec3(u_rows[k], u_rows[k + 1], u_rows[k + 2]);
}

// arcs_cross(p, q, a, b, n) of the numpy path
bool crosses(dvec3 p, dvec3 q, int arc) {
    dvec3 a = arc_point(arc, 0), b = arc_point(arc, 3), n = arc_point(arc, 6);
    precise dvec3 pq = dvec3(p.y * q.z - p.z * q.y, p.z * q.x - p.x * q.z, p.x * q.y - p.y * q.x);
    precise double da = pq.x * a.x + pq.y * a.y + pq.z * a.z;
    precise double db = pq.x * b.x + pq.y * b.y + pq.z * b.z;
    precise double dp = n.x * p.x + n.y * p.y + n.z * p.z;
    precise double dq = n.x * q.x + n.y * q.y + n.z * q.z;
    bool sa = da >= 0.0LF, sb = db >= 0.0LF, sp = dp >= 0.0LF, sq = dq >= 0.0LF;
    return (sa != sb) && (sp != sq) && (sp == sb);
}

double pair_cm(dvec3 c, dvec3 m) {
    precise double t = c.x * m.x;
    precise double u = c.z * m.z;
    precise double s = t + u;
    precise double v = c.y * m.y;
    precise double cm = s + v;
    return cm;
}

// 2: passes, 1: the host's, 0: fails; the test cm >= cos(min(r + h, pi)) - COS_SLACK from
// (cos r, sin r), (cos h, sin h) and r + h
uint cap_test(double cm, double cr, double sr, double ch, double sh, double total) {
    if (total >= NEAR_PI) {
        return 1u;
    }
    double t = cr * ch - sr * sh - COS_SLACK;
    return cm >= t + MARGIN ? 2u : (cm >= t - MARGIN ? 1u : 0u);
}

#ifdef COUNT
// child slot S of the pair: its count, and the crossing of a ring edge near it
#define CHILD(S)                                                                            \
    if (slot[S] >= 0) {                                                                     \
        double cm = pair_cm(c0_##S.xyz, m);                                                 \
        if (cap_test(cm, c1_##S.x, c1_##S.y, h.x, h.y, c0_##S.w + mh.w) != 0u) {            \
            ++n[S];                                                                         \
        }                                                                                   \
        if (ring) {                                                                         \
            uint nt = cap_test(cm, c1_##S.z, c1_##S.w, h.x, h.y, seg_##S + mh.w);           \
            if (nt != 0u && crosses(c0_##S.xyz, q, arc)) {                                  \
                uint o = atomicAdd(o_lists[0], 1u);                                         \
                if (o < u_toggle_capacity) {                                                \
                    o_toggle[o] = uvec2(uint(slot[S]), uint(arc) | (nt == 1u ? NEAR_UNSURE : 0u)); \
                }                                                                           \
            }                                                                               \
        }                                                                                   \
    }
#else
// child slot S of the pair: written where its cap test does not fail
#define CHILD(S)                                                                            \
    if (slot[S] >= 0) {                                                                     \
        double cm = pair_cm(c0_##S.xyz, m);                                                 \
        uint keep = cap_test(cm, c1_##S.x, c1_##S.y, h.x, h.y, c0_##S.w + mh.w);            \
        if (keep != 0u) {                                                                   \
            o_arc[at[S]] = uint(arc) | (keep == 1u ? UNSURE : 0u);                          \
            o_cm[at[S]] = cm;                                                               \
            ++at[S];                                                                        \
        }                                                                                   \
    }
#endif

void main() {
    int j = int(gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u);
    if (j >= u_chunks) {
        return;
    }
    ivec4 chunk = u_chunk[j];
    int k = chunk.x, s0 = chunk.y, s1 = chunk.y + chunk.z;
    ivec4 slot = u_slot[k];
    dvec3 q = u_parent[k].xyz;
    // the children's terms, read once
#define TERMS(S)                                                                            \
    int ch_##S = max(slot[S], 0);                                                           \
    dvec4 c0_##S = u_child[3 * ch_##S], c1_##S = u_child[3 * ch_##S + 1];                  \
    double seg_##S = u_child[3 * ch_##S + 2].x;
    TERMS(0)
    TERMS(1)
    TERMS(2)
    TERMS(3)
#ifdef COUNT
    uvec4 n = uvec4(0u);
#else
    uvec4 at = u_first_out[j];
#endif
    for (int p = s0; p < s1; ++p) {
        int arc = u_arc[p];
        dvec4 mh = u_term[3 * arc];
        dvec4 h = u_term[3 * arc + 1];
        dvec3 m = mh.xyz;
#ifdef COUNT
        bool ring = h.z != 0.0LF;
        if (ring) {
            dvec3 nn = u_term[3 * arc + 2].xyz;
            precise double a0 = q.x * nn.x;
            precise double a2 = q.z * nn.z;
            precise double a02 = a0 + a2;
            precise double a1 = q.y * nn.y;
            precise double qn = a02 + a1;
            if (abs(qn) <= ON_EDGE) {
                uint o = atomicAdd(o_lists[1], 1u);
                if (o < u_on_capacity) {
                    o_on[o] = uvec2(uint(k), uint(arc));
                }
            }
        }
        CHILD(0)
        CHILD(1)
        CHILD(2)
        CHILD(3)
#else
        CHILD(0)
        CHILD(1)
        CHILD(2)
        CHILD(3)
#endif
    }
#ifdef COUNT
    o_count[j] = n;
#endif
}
