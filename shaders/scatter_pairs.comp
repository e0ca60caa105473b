#version 430
// The entry level's (cell, arc) pairs (gloffset/raster/vector/scatter.py, gloffset/gl/scatter_pass.py).
//
// One invocation per chunk of a box (an arc and a rectangle of cells, nc columns wide from
// row j0, column i0; a chunk: the box's cells start .. start + count - 1, row-major, at most
// CHUNK of them, since llvmpipe ends any loop after 65535 iterations):
// for every cell of the chunk, cm = c.m in float64, with c the cell centre
// (cos(lat) cos(lon), cos(lat) sin(lon), sin(lat)) and m the arc's cap centre, evaluated as
// cphi * (clam * m.x + slam * m.y) + sphi * m.z: products and sums only, each rounded once
// (`precise` forbids fusing them), the operations and order of the numpy path.
// The exact cap test of the row (cm >= cos(min(reach + h, pi)) - COS_SLACK, reach the row's,
// h the arc's cap radius) is the host's; here its threshold is cos(reach) cos(h) - sin(reach)
// sin(h) - COS_SLACK from the host's float64 cosines and sines, within 1e-14 of the host's,
// and a pair more than MARGIN (1e-9) above it passes, more than MARGIN below fails; the few
// between, and every pair of an arc whose h plus a reach comes near pi (where the host clamps
// the sum; the host flags those arcs, u_arc[arc].w), are left to the host. The pair
// is written (cell = j * width + i, arc, cm) unless it fails the test of the row's reach
// (UNSURE set in arc where the host decides), and with u_near, NEAR set where it passes the
// test of the row's second reach (the candidate lists'), NEAR_UNSURE where the host decides.
// With u_cross, a kept pair of a ring edge (u_ring_arc[arc * 20 + 19] != 0: a, b and the
// normal n at 0, 3, 6) and a cell other than the first also gets CROSS set in arc when the
// edge crosses the short arc from the cell's centre to its predecessor's (left, or above
// in the first column): gloffset.geometry.sphere.arcs_cross, its products and sums each
// rounded once, in its order, so the same booleans where + and * are IEEE.
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Boxes { ivec4 u_box[]; };    // j0, i0, nc, arc
layout(std430, binding = 1) readonly buffer Chunks { ivec4 u_chunk[]; }; // box, start, count
// cos h, sin h, h, and 1 where h plus a reach of a row is near pi (else 0)
layout(std430, binding = 2) readonly buffer Arcs { dvec4 u_arc[]; };
// two per row: cos lat, sin lat, reach, near reach; their cos, sin: reach's, near reach's
layout(std430, binding = 3) readonly buffer Rows { dvec4 u_row[]; };
layout(std430, binding = 4) readonly buffer Cols { dvec2 u_col[]; };     // cos, sin lon
layout(std430, binding = 5) writeonly buffer Pairs { uvec2 o_pair[]; };  // cell, arc
layout(std430, binding = 6) writeonly buffer Cms { double o_cm[]; };
layout(std430, binding = 7) buffer Count { uint o_count; };
layout(std430, binding = 9) readonly buffer RingArcs { double u_ring_arc[]; };  // (arcs, 20)

uniform int u_chunks;
uniform int u_width;
uniform uint u_capacity;
uniform bool u_cross;
uniform bool u_near;

const uint UNSURE = 0x80000000u;
const uint CROSS = 0x40000000u;
const uint NEAR = 0x20000000u;
const uint NEAR_UNSURE = 0x10000000u;
const double MARGIN = 1e-9LF;  // gloffset.raster.gpu.GPU_PAIR_MARGIN
const double COS_SLACK = 1e-12LF;  // gloffset.geometry.caps.COS_SLACK

dvec3 centre(int j, int i) {
    dvec2 r = u_row[2 * j].xy;
    dvec2 c = u_col[i];
    precise dvec3 p = dvec3(r.x * c.x, r.x * c.y, r.y);
    return p;
}

dvec3 arc_point(int arc, int at) {
    int k = 20 * arc + at;
    return dvec3(u_ring_arc[k], u_ring_arc[k + 1], u_ring_arc[k + 2]);
}

// arcs_cross(centre(j, i), its predecessor's, a, b, n) of the numpy path
bool crosses(int arc, int j, int i) {
    if (u_ring_arc[20 * arc + 19] == 0.0LF || (j == 0 && i == 0)) {
        return false;
    }
    dvec3 p = centre(j, i);
    dvec3 q = i > 0 ? centre(j, i - 1) : centre(j - 1, 0);
    dvec3 a = arc_point(arc, 0), b = arc_point(arc, 3), n = arc_point(arc, 6);
    precise dvec3 pq = dvec3(p.y * q.z - p.z * q.y, p.z * q.x - p.x * q.z, p.x * q.y - p.y * q.x);
    precise double da = pq.x * a.x + pq.y * a.y + pq.z * a.z;
    precise double db = pq.x * b.x + pq.y * b.y + pq.z * b.z;
    precise double dp = n.x * p.x + n.y * p.y + n.z * p.z;
    precise double dq = n.x * q.x + n.y * q.y + n.z * q.z;
    bool sa = da >= 0.0LF, sb = db >= 0.0LF, sp = dp >= 0.0LF, sq = dq >= 0.0LF;
    return (sa != sb) && (sp != sq) && (sp == sb);
}

double cell_cm(dvec3 a, int j, int i) {
    dvec2 r = u_row[2 * j].xy;
    dvec2 c = u_col[i];
    precise double t = c.x * a.x;
    precise double u = c.y * a.y;
    precise double s = t + u;
    precise double p = r.x * s;
    precise double q = r.y * a.z;
    precise double cm = p + q;
    return cm;
}

// The bounds of the row's cap tests, of its reach (xy) and of its second reach (zw): a cm at
// or above x passes, one below y fails, those between are the host's (h: cos h, sin h, and
// 1 where h plus a reach is near pi, the host's clamp, all of whose pairs are the host's)
dvec4 row_bounds(int j, dvec3 h) {
    if (h.z != 0.0LF) {
        return dvec4(1e300LF, -1e300LF, 1e300LF, -1e300LF);
    }
    dvec4 q = u_row[2 * j + 1];
    double t = q.x * h.x - q.y * h.y - COS_SLACK;
    double u = q.z * h.x - q.w * h.y - COS_SLACK;
    return dvec4(t + MARGIN, t - MARGIN, u + MARGIN, u - MARGIN);
}

void main() {
    int k = int(gl_GlobalInvocationID.x);
    if (k >= u_chunks) {
        return;
    }
    ivec4 c = u_chunk[k];
    ivec4 b = u_box[c.x];
    int arc = b.w;
    dvec3 h = u_arc[arc].xyw;
    dvec3 m = arc_point(arc, 15);
    // the chunk's cells, row by row: (j, i) from its first one, the bounds once per row
    int j0 = b.x + c.y / b.z, i0 = b.y + c.y % b.z, stop = b.y + b.z;
    int j = j0, i = i0;
    dvec4 t = row_bounds(j, h);
    uint n = 0u;
    for (int o = 0; o < c.z; ++o) {
        if (cell_cm(m, j, i) >= t.y) {
            ++n;
        }
        if (++i == stop && o + 1 < c.z) {
            i = b.y;
            t = row_bounds(++j, h);
        }
    }
    if (n == 0u) {
        return;
    }
    uint at = atomicAdd(o_count, n);
    if (at + n > u_capacity) {
        return;  // the count tells the host the buffer was too small
    }
    j = j0;
    i = i0;
    t = row_bounds(j, h);
    for (int o = 0; o < c.z; ++o) {
        double cm = cell_cm(m, j, i);
        if (cm >= t.y) {
            uint flags = (cm < t.x ? UNSURE : 0u) | (u_cross && crosses(arc, j, i) ? CROSS : 0u);
            if (u_near) {
                flags |= cm >= t.z ? NEAR : (cm >= t.w ? NEAR_UNSURE : 0u);
            }
            o_pair[at] = uvec2(uint(j * u_width + i), uint(arc) | flags);
            o_cm[at] = cm;
            ++at;
        }
        if (++i == stop && o + 1 < c.z) {
            i = b.y;
            t = row_bounds(++j, h);
        }
    }
}
