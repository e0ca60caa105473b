#version 430
// The entry level's (cell, arc) pairs (gloffset/raster/vector/scatter.py, gloffset/gl/scatter_pass.py).
//
// One invocation per chunk of a box (an arc and a rectangle of cells, nc columns wide from
// row j0, column i0; a chunk: the box's cells start .. start + count - 1, row-major, at most
// CHUNK of them, since llvmpipe ends any loop after 65535 iterations):
// for every cell of the chunk, cm = c.m in float64, with c the cell centre
// (cos(lat) cos(lon), cos(lat) sin(lon), sin(lat)) and m the arc's cap centre, evaluated as
// cphi * (clam * m.x + slam * m.y) + sphi * m.z: products and sums only, each rounded once
// (`precise` forbids fusing them), the operations and order of the numpy path. The pair is
// written (cell = j * width + i, arc, cm) when cm >= lo, the arc's lowest threshold of the
// exact cap test (less a margin), with UNSURE set in arc when cm < hi, its highest threshold
// (plus a margin): the host takes the exact test on those.
// With u_cross, a kept pair of a ring edge (u_ring_arc[arc * 20 + 19] != 0: a, b and the
// normal n at 0, 3, 6) and a cell other than the first also gets CROSS set in arc when the
// edge crosses the short arc from the cell's centre to its predecessor's (left, or above
// in the first column): gloffset.geometry.sphere.arcs_cross, its products and sums each
// rounded once, in its order, so the same booleans where + and * are IEEE.
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Boxes { ivec4 u_box[]; };    // j0, i0, nc, arc
layout(std430, binding = 1) readonly buffer Chunks { ivec4 u_chunk[]; }; // box, start, count
layout(std430, binding = 2) readonly buffer Arcs { dvec4 u_arc[]; };     // m.xyz, lo
layout(std430, binding = 3) readonly buffer Rows { dvec2 u_row[]; };     // cos, sin lat
layout(std430, binding = 4) readonly buffer Cols { dvec2 u_col[]; };     // cos, sin lon
layout(std430, binding = 5) writeonly buffer Pairs { uvec2 o_pair[]; };  // cell, arc
layout(std430, binding = 6) writeonly buffer Cms { double o_cm[]; };
layout(std430, binding = 7) buffer Count { uint o_count; };
layout(std430, binding = 8) readonly buffer His { double u_hi[]; };
layout(std430, binding = 9) readonly buffer RingArcs { double u_ring_arc[]; };  // (arcs, 20)

uniform int u_chunks;
uniform int u_width;
uniform uint u_capacity;
uniform bool u_cross;

const uint UNSURE = 0x80000000u;
const uint CROSS = 0x40000000u;

dvec3 centre(int j, int i) {
    dvec2 r = u_row[j];
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

double cell_cm(dvec4 a, int j, int i) {
    dvec2 r = u_row[j];
    dvec2 c = u_col[i];
    precise double t = c.x * a.x;
    precise double u = c.y * a.y;
    precise double s = t + u;
    precise double p = r.x * s;
    precise double q = r.y * a.z;
    precise double cm = p + q;
    return cm;
}

void main() {
    int k = int(gl_GlobalInvocationID.x);
    if (k >= u_chunks) {
        return;
    }
    ivec4 c = u_chunk[k];
    ivec4 b = u_box[c.x];
    int arc = b.w;
    dvec4 a = u_arc[arc];
    double hi = u_hi[arc];
    int end = c.y + c.z;
    uint n = 0u;
    for (int o = c.y; o < end; ++o) {
        if (cell_cm(a, b.x + o / b.z, b.y + o % b.z) >= a.w) {
            ++n;
        }
    }
    if (n == 0u) {
        return;
    }
    uint at = atomicAdd(o_count, n);
    if (at + n > u_capacity) {
        return;  // the count tells the host the buffer was too small
    }
    for (int o = c.y; o < end; ++o) {
        int j = b.x + o / b.z;
        int i = b.y + o % b.z;
        double cm = cell_cm(a, j, i);
        if (cm >= a.w) {
            uint flags = (cm < hi ? UNSURE : 0u) | (u_cross && crosses(arc, j, i) ? CROSS : 0u);
            o_pair[at] = uvec2(uint(j * u_width + i), uint(arc) | flags);
            o_cm[at] = cm;
            ++at;
        }
    }
}
