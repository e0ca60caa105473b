#version 430
// One level of a distance field's walk (gloffset/gl/walk_pass.py, gloffset/raster/fields/lists.py).
//
// One invocation per cell of the level (u_width cells a row; the invocations take the cells
// in the order the host gives, cells of like parents' list lengths side by side: the lanes
// of a SIMD vector then run about as many steps each): the cell's list
// starts as its parent's (cell j >> 1, i >> 1 of the level above; the root list for every
// cell at level 0) and is pruned and split as gloffset/raster/fields/walk.py's _bound does,
// in float32 with every bound widened (the derivation: gloffset/gl/walk_pass.py):
//   lower bound of a node: max(angle(c, mid) - reach, distance to its arc - err),
//   upper bound:           min(angle(c, mid) + reach, distance to its arc + err),
// kept where lo <= min(best + 2 reach_c, m + reach_c) + u_sum_err (best: the least upper
// bound of the cell found so far, from the parent's nodes on, which only falls: the list
// is a superset of the one kept against the final bound) and, kept for the slack alone,
// where maybe_nearer (the bisector test against the nearest end of the parent's nodes)
// and, at least u_deep reaches away, where that end does not dominate it (dominated),
// split (depth first) where err > bound. One walk: each node kept is written as it is
// found, into chunks of CHUNK slots of the pool reserved with atomicAdd (CHUNK - 1 ids,
// then the start of the cell's next chunk); the cell's (first chunk, count) is its list.
// The parents' lists are read the same way (u_pchunk ids a chunk; or contiguous).
// A full pool (the walk goes on counting; the host retries with o_total), a full stack
// or a loop too long raise a flag.
layout(local_size_x = 64) in;

struct Node {
    vec4 cap;  // mid.xyz, reach (rounded up)
    vec4 a;    // a.xyz, err (rounded up)
    vec4 b;    // b.xyz, flags: 1 leaf, 2 the arc has a normal
    vec4 n;    // n.xyz
    vec4 r;    // 1 - cos(reach), sin(reach) (rounded up)
};

layout(std430, binding = 0) readonly buffer Nodes { Node u_node[]; };
layout(std430, binding = 1) readonly buffer Child { ivec2 u_child[]; };
struct Cell {
    vec4 c;   // c.xyz, reach (rounded up)
    vec3 b;   // the split bound; cos, sin of the reach
    uint id;  // the cell (row-major)
};

layout(std430, binding = 2) readonly buffer Cells { Cell u_cell[]; };  // in the order run
layout(std430, binding = 3) readonly buffer Parents { uvec2 u_parent[]; };  // start, count
layout(std430, binding = 4) readonly buffer ParentPool { uint u_ppool[]; };
layout(std430, binding = 5) writeonly buffer Out { uvec2 o_cell[]; };  // first chunk, count
layout(std430, binding = 6) writeonly buffer Pool { uint o_pool[]; };
layout(std430, binding = 7) buffer Count { uint o_total; uint o_flags; };

uniform uint u_first;  // the invocations u_first .. u_cells - 1 (o_cell by cell)
uniform uint u_cells;
uniform int u_width;
uniform int u_pwidth;  // the parent level's width (0: every cell takes parent 0)
uniform uint u_capacity;
uniform uint u_pchunk;  // ids a chunk of the parents' pool (0xffffffff: contiguous lists)
uniform int u_bisector;  // 0: no bisector test
// Most steps of an invocation (llvmpipe silently ends the loops of a shader once they have
// run 65535 iterations in all, counted per SIMD vector)
uniform int u_max_steps;
uniform float u_m;         // max_distance, rounded up (at most 4)
uniform float u_ch_rel;    // chord error: relative ...
uniform float u_ch_abs;    // ... and absolute
uniform float u_asin_rel;  // relative error of asin_f
uniform float u_dot_err;   // error of c.n, c.(n x a), c.(b x n)
uniform float u_sum_err;   // the roundings of the sums compared
uniform float u_bis_abs;   // error of the bisector test's least q.v: absolute ...
uniform float u_bis_rel;   // ... and relative to |vtx - mid| + 1 - cos r
uniform float u_deep;      // the dominance test on nodes at least this many reaches away
                           // (0: none; gloffset/raster/fields/dominance.py's DEEP)

const uint CHUNK = 16u;  // slots a chunk of the pool written (gloffset/gl/walk_pass.py's CHUNK)
const uint FLAG_POOL = 1u;   // the pool was too small (the host retries with o_total)
const uint FLAG_LIMIT = 2u;  // a stack or loop limit (the host walks in float64)
const int STACK = 64;
// each invocation's stack (local arrays indexed at run time miscompile on llvmpipe 15)
shared int stack[64 * STACK];
const float HALF_PI = 1.57079632679489662;

// asin of x in [0, 1] (Cephes' asinf: a polynomial on [0, 1/2], the half-angle formula above)
float asin_f(float x) {
    bool big = x > 0.5;
    float z;
    if (big) {
        z = 0.5 * (1.0 - x);
        x = sqrt(z);
    } else {
        z = x * x;
    }
    float p = (((4.2163199048e-2 * z + 2.4181311049e-2) * z + 4.5470025998e-2) * z
               + 7.4953002686e-2) * z + 1.6666752422e-1;
    float r = p * z * x + x;
    return big ? HALF_PI - 2.0 * r : r;
}

// bounds on the angle of a float32 chord ch (of float32 unit vectors)
float ang_lo(float ch) {
    float c = max(ch * (1.0 - u_ch_rel) - u_ch_abs, 0.0);
    return 2.0 * asin_f(min(0.5 * c, 1.0)) * (1.0 - u_asin_rel);
}

float ang_hi(float ch) {
    float c = min(ch * (1.0 + u_ch_rel) + u_ch_abs, 2.0);
    return 2.0 * asin_f(0.5 * c) * (1.0 + u_asin_rel) + u_ch_abs;
}

// Lower and upper bounds on the distance from c to the run of node nd; ch the chord to
// its cap's centre, ca and cb those to its ends. The distance to the arc: between the
// distance to its great circle and that to its nearer end, the former where the foot is
// surely on the arc (upper bound), the latter where surely off it (lower bound): one
// asin_f each way (both sides of a branch cost the same on a SIMD GPU).
vec2 bounds(vec3 c, Node nd, out float ch, out float ca, out float cb) {
    ch = length(c - nd.cap.xyz);
    float lo = ang_lo(ch) - nd.cap.w;
    float hi = ang_hi(ch) + nd.cap.w;
    ca = length(c - nd.a.xyz);
    cb = length(c - nd.b.xyz);
    float ce = min(ca, cb);
    bool on = false;  // the foot surely on the arc
    bool off = true;  // surely off it: an end is nearest
    float y = 0.0;
    if (nd.b.w >= 2.0) {
        vec3 n = nd.n.xyz;
        y = abs(dot(c, n));
        float s1 = dot(c, cross(n, nd.a.xyz));
        float s2 = dot(c, cross(nd.b.xyz, n));
        on = s1 > u_dot_err && s2 > u_dot_err;
        off = s1 < -u_dot_err || s2 < -u_dot_err;
    }
    // upper: asin(y) rounded up where on, else 2 asin(ce / 2) rounded up (ang_hi)
    float xh = on ? min(y + u_dot_err, 1.0) : 0.5 * min(ce * (1.0 + u_ch_rel) + u_ch_abs, 2.0);
    float dhi = (on ? 1.0 : 2.0) * asin_f(xh) * (1.0 + u_asin_rel) + u_ch_abs;
    // lower: 2 asin(ce / 2) rounded down where off (ang_lo), else asin(y) rounded down
    float xl = off ? min(0.5 * max(ce * (1.0 - u_ch_rel) - u_ch_abs, 0.0), 1.0)
                   : clamp(y - u_dot_err, 0.0, 1.0);
    float dlo = nd.b.w >= 2.0 ? (off ? 2.0 : 1.0) * asin_f(xl) * (1.0 - u_asin_rel) : 0.0;
    return vec2(max(lo, dlo - nd.a.w), min(hi, dhi + nd.a.w));
}

// Whether node nd's run can be as near as the vertex v to some point within the cell's
// reach of c (gloffset/raster/fields/walk.py's _maybe_nearer, in float32 with its error
// bound: false only where every such point is surely nearer to v than to the node's cap).
// cs: cos and sin of the cell's reach, R its reach; chm the chord from c to the cap's centre.
bool maybe_nearer(vec3 c, float R, vec2 cs, vec3 v, Node nd, float chm) {
    vec3 mid = nd.cap.xyz;
    float kk = nd.r.x;
    vec3 w = v - mid;
    // q.(v - cos r mid) = q.w + (1 - cos r) q.mid: least over the disc
    float cv = dot(c, w) + kk * dot(c, mid);
    float sx = length(cross(c, w) + kk * cross(c, mid));
    float least = cv * cs.x - sx * cs.y;
    float err = u_bis_abs + u_bis_rel * (length(w) + kk);
    // S >= sin(min(t + R, pi / 2)), t the angle to the cap's centre (from a chord rounded up)
    float ch = min(chm * (1.0 + u_ch_rel) + u_ch_abs, 2.0);
    float ct = 1.0 - 0.5 * ch * ch;
    float st = ch * sqrt(max(1.0 - 0.25 * ch * ch, 0.0));
    float s = 1.0;
    if (ct * cs.x - st * cs.y > u_bis_abs) {  // t + R surely below pi / 2
        s = min(st * cs.x + ct * cs.y + u_bis_abs, 1.0);
    }
    float sr = nd.r.y;
    return nd.cap.w >= 1.0 || R >= 1.0 || least - err <= sr * max(s, sr) * (1.0 + u_bis_abs);
}

// Whether the vertex v (chord vch from c) dominates node nd over the disc of radius R
// about c (gloffset/raster/fields/dominance.py's vertex_dominates, from bounds that hold
// in float32): D = min(lo, angle(c, v)) - R rounded down, delta = angle(v, mid) + reach
// rounded up, L = chord(delta) / sin D rounded up (chord(delta) <= min(delta, 2), sin D
// >= D (1 - D^2 / 6) for D <= pi / 2), and the gap lo - angle(c, v) - R L above twice
// u_sum_err (its roundings, at most u_sum_err: the true gap then exceeds the float64
// rule's 1e-12).
bool dominated(vec3 c, float R, vec3 v, float vch, Node nd, float lo) {
    float av = ang_hi(vch);
    float low = min(lo, ang_lo(vch)) - R;
    float delta = ang_hi(length(v - nd.cap.xyz)) + nd.cap.w;
    float dd = min(low, HALF_PI);
    float sin_lo = dd * (1.0 - dd * dd * (1.0 / 6.0)) * (1.0 - 1e-6);
    float lip = min(delta, 2.0) / max(sin_lo, 1e-30) * (1.0 + 1e-6);
    bool fits = av + R + delta <= 3.14159 - low;
    return low > 0.0 && fits && lo - av - R * lip > 2.0 * u_sum_err;
}

void main() {
    uint inv = gl_GlobalInvocationID.x + u_first;
    if (inv >= u_cells) {
        return;
    }
    Cell cell = u_cell[inv];
    uint k = cell.id;
    uint o = k;
    int j = int(k) / u_width;
    int i = int(k) - j * u_width;
    uint p = u_pwidth > 0 ? uint((j >> 1) * u_pwidth + (i >> 1)) : 0u;
    uvec2 par = u_parent[p];
    vec4 cr = cell.c;
    vec3 c = cr.xyz;
    float slack = 2.0 * cr.w;
    float far = u_m + cr.w;
    vec3 cb = cell.b;
    float bound = cb.x;
    uint base = gl_LocalInvocationIndex * uint(STACK);
    float best = 1e30;
    float vch = 4.0;  // the chord to the nearest vertex vtx (an end of the nodes measured)
    vec3 vtx = c;
    bool test = false;
    uint first = 0u;  // the cell's first chunk
    uint at = 0u;  // its next slot
    uint kept = 0u;
    bool full = false;  // a chunk beyond the pool's capacity (the ids are no longer written)
    // One loop, a node measured each step (llvmpipe counts the iterations of all loops
    // together; one loop's, the most steps of a lane of the SIMD vector, stays within
    // u_max_steps): phase 0 the parent's nodes (a first least upper bound, the nearest
    // vertex), phase 1 the walk: the parent's next node where the stack is empty, else
    // the node popped.
    int phase = 0;
    uint e = 0u;  // the parent's nodes taken
    uint pa = par.x;  // the place of the next one in the parents' pool
    uint pi = 0u;  // and in its chunk
    int sp = 0;
    for (int steps = 0;; ++steps) {
        if (steps > u_max_steps) {
            atomicOr(o_flags, FLAG_LIMIT);
            o_cell[o] = uvec2(0u);
            return;
        }
        bool take = e < par.y && (phase == 0 || sp == 0);
        if (!take && sp == 0) {
            if (phase == 1) {
                break;
            }
            test = u_bisector != 0 && vch < 4.0;
            phase = 1;
            e = 0u;
            pa = par.x;
            pi = 0u;
            continue;
        }
        int id;
        if (take) {  // the parent's next node
            id = int(u_ppool[pa]);
            ++e;
            ++pa;
            ++pi;
            if (pi == u_pchunk && e < par.y) {
                pa = u_ppool[pa];
                pi = 0u;
            }
        } else {
            sp -= 1;
            id = stack[base + uint(sp)];
        }
        Node nd = u_node[id];
        float chm, ca, cb2;
        vec2 b = bounds(c, nd, chm, ca, cb2);
        best = min(best, b.y);
        if (ca < vch) {
            vch = ca;
            vtx = nd.a.xyz;
        }
        if (cb2 < vch) {
            vch = cb2;
            vtx = nd.b.xyz;
        }
        if (phase == 0) {
            continue;
        }
        // kept for the slack alone: the bisector test against vtx too
        if (b.x <= min(best + slack, far) + u_sum_err
            && (b.x <= best + u_sum_err || !test || maybe_nearer(c, cr.w, cb.yz, vtx, nd, chm))
            && (b.x <= best + u_sum_err || !test || u_deep <= 0.0 || b.x < u_deep * cr.w
                || !dominated(c, cr.w, vtx, vch, nd, b.x))) {
            if (mod(nd.b.w, 2.0) < 1.0 && nd.a.w > bound) {  // split
                if (sp + 2 > STACK) {
                    atomicOr(o_flags, FLAG_LIMIT);
                    o_cell[o] = uvec2(0u);
                    return;
                }
                ivec2 ch = u_child[id];
                stack[base + uint(sp)] = ch.y;
                stack[base + uint(sp) + 1u] = ch.x;
                sp += 2;
            } else {
                if (kept % (CHUNK - 1u) == 0u) {  // a new chunk
                    uint next = atomicAdd(o_total, CHUNK);
                    full = full || next + CHUNK > u_capacity;
                    if (kept == 0u) {
                        first = next;
                    } else if (!full) {
                        o_pool[at] = next;  // the link in the last slot of the chunk
                    }
                    at = next;
                }
                if (!full) {
                    o_pool[at] = uint(id);
                }
                ++at;
                ++kept;
            }
        }
    }
    if (full) {
        atomicOr(o_flags, FLAG_POOL);
    }
    o_cell[o] = uvec2(first, kept);
}
