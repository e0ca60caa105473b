#version 430
// The arc records of the frontier bins and their cluster headers, made on the GL context
// (gloffset/gl/records_pass.py; the numpy twin: gloffset/raster/records.py, records).
// Three dispatches of one file:
//
// (default) one invocation per (bin, arc) pair: its record of six vec4 (lib/arcs.glsl),
//   every word but t0.x computed in double from the float64 bin centre and the arc's
//   float64 columns with the operations, in the order, of the numpy twin (products and
//   sums each rounded once: `precise` forbids fusing them), then cast to float: the same
//   bits where double + and * are IEEE and the cast rounds to nearest. t0.x, a lower bound
//   on the distance from the bin centre to the arc that only culls, is its own: the angle
//   to the cap centre bounded below by its chord (2 asin(x / 2) >= x + x^3 / 24 +
//   3 x^5 / 640), less the cap's radius and CAP_SLACK, rounded down by 1e-7 (relative).
// CLUSTERS: one invocation per cluster (a run of records of one bin): its header (Q, rho),
//   (Dmin, hmin, S, range) as the numpy twin's _balls and _clusters make it, from the
//   records just written, square roots from lib/fp64.glsl (2 ulp, far inside the 1e-9
//   widening of rho and S), rho and S rounded up to float; written unsorted, with Dmin's
//   bits as the key.
// ORDER: one invocation per cluster: its rank among its bin's clusters by (Dmin, index)
//   (the numpy twin's stable sort), and the header copied to that place.
layout(local_size_x = 64) in;

#include "lib/fp64.glsl"

uniform uint u_count;  // pairs (default) or clusters (CLUSTERS, ORDER)

#if defined(CLUSTERS) || defined(ORDER)
layout(std430, binding = 0) readonly buffer Records { vec4 u_rec[]; };
layout(std430, binding = 1) readonly buffer Ranges { uvec4 u_range[]; };  // first record, records, bin's first cluster, its end
layout(std430, binding = 2) buffer Headers { uvec4 o_hdr[]; };            // unsorted, two per cluster
layout(std430, binding = 3) buffer Keys { uint o_key[]; };                // Dmin's bits
layout(std430, binding = 4) writeonly buffer Sorted { uvec4 o_sorted[]; }; // by bin, then Dmin
#else
layout(std430, binding = 0) readonly buffer Pairs { uvec2 u_pair[]; };   // bin, arc
layout(std430, binding = 1) readonly buffer Codes { uint u_code[]; };    // flags + 8 * local id
layout(std430, binding = 2) readonly buffer Centres { dvec4 u_centre[]; }; // bin centres
layout(std430, binding = 3) readonly buffer Arcs { double u_arc[]; };    // (arcs, 20) rows
layout(std430, binding = 4) writeonly buffer Out { vec4 o_rec[]; };
uniform double u_se;   // sin(e)
uniform double u_chord_e;  // chord(e)^2
#endif

const double CAP_SLACK = 2e-7LF;
const double F32_TINY = 1.1754943508222875e-38LF;  // the least positive normal float

uint invocation() {
    return gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;
}

#if defined(CLUSTERS)
// float >= x (x > 0): the cast, one float up where it fell below x
float round_up(double x) {
    float y = float(x);
    return double(y) < x ? uintBitsToFloat(floatBitsToUint(y) + 1u) : y;
}

double norm64(dvec3 v) {
    precise double s = v.x * v.x + v.y * v.y + v.z * v.z;
    return fp64_sqrt(s);
}

void main() {
    uint m = invocation();
    if (m >= u_count) {
        return;
    }
    uvec4 rg = u_range[m];
    uint r0 = rg.x, r1 = rg.x + rg.y;
    vec3 lo = vec3(1e30), hi = vec3(-1e30);
    float dmin = uintBitsToFloat(0x7f800000u);
    float hmin = dmin;
    for (uint r = r0; r < r1; ++r) {
        vec4 t0 = u_rec[6u * r];
        vec3 t4 = u_rec[6u * r + 4u].xyz;
        vec3 t5 = u_rec[6u * r + 5u].xyz;
        lo = min(lo, min(t4, t5));
        hi = max(hi, max(t4, t5));
        dmin = min(dmin, t0.x);
        if ((uint(t0.y) & 4u) != 0u) {  // ARC_RING
            hmin = min(hmin, abs(t0.z));
        }
    }
    precise dvec3 q = -0.5LF * (dvec3(lo) + dvec3(hi));
    double rho = 0.0LF;
    for (uint r = r0; r < r1; ++r) {
        dvec3 u = dvec3(u_rec[6u * r + 4u].xyz);
        dvec3 v = dvec3(u_rec[6u * r + 5u].xyz);
        precise dvec3 dm = q + 0.5LF * (u + v);
        precise dvec3 uv = u - v;
        precise double x = norm64(dm) + 0.5LF * norm64(uv) + 1.2e-7LF * (norm64(u) + norm64(v));
        rho = max(rho, x);
    }
    vec3 q32 = vec3(q);
    precise dvec3 dq = q - dvec3(q32);
    precise double rw = (rho + norm64(dq)) * (1.0LF + 1e-9LF) + 1e-30LF;
    float rho32 = round_up(rw);
    precise double sw = (norm64(dvec3(q32)) + double(rho32)) * (1.0LF + 1e-9LF);
    float s32 = round_up(sw);
    o_hdr[2u * m] = uvec4(floatBitsToUint(q32), floatBitsToUint(rho32));
    o_hdr[2u * m + 1u] = uvec4(floatBitsToUint(dmin), floatBitsToUint(hmin), floatBitsToUint(s32),
                               16u * r0 + rg.y - 1u);
    o_key[m] = floatBitsToUint(dmin);
}
#elif defined(ORDER)
void main() {
    uint m = invocation();
    if (m >= u_count) {
        return;
    }
    uvec4 rg = u_range[m];
    uint key = o_key[m];
    uint rank = 0u;
    for (uint j = rg.z; j < rg.w; ++j) {
        uint kj = o_key[j];
        rank += (kj < key || (kj == key && j < m)) ? 1u : 0u;
    }
    uint at = rg.z + rank;
    o_sorted[2u * at] = o_hdr[2u * m];
    o_sorted[2u * at + 1u] = o_hdr[2u * m + 1u];
}
#else
dvec3 column(uint row, uint arc) {
    uint at = 20u * arc + row;
    return dvec3(u_arc[at], u_arc[at + 1u], u_arc[at + 2u]);
}

// numpy's einsum sum of three products: (x0 y0 + x2 y2) + x1 y1, plus 0
double einsum_dot(dvec3 x, dvec3 y) {
    precise double s = (x.x * y.x + x.z * y.z) + x.y * y.y + 0.0LF;
    return s;
}

void main() {
    uint k = invocation();
    if (k >= u_count) {
        return;
    }
    uvec2 pa = u_pair[k];
    uint arc = pa.y;
    dvec3 c = u_centre[pa.x].xyz;
    dvec3 a = column(0u, arc), b = column(3u, arc), n = column(6u, arc);
    dvec3 w1 = column(9u, arc), w2 = column(12u, arc), mid = column(15u, arc);
    double half_ = u_arc[20u * arc + 18u];
    precise dvec3 ea = c - a;
    precise dvec3 eb = c - b;
    precise double h = c.x * n.x + c.y * n.y + c.z * n.z;
    // D: the chord to the cap centre, its angle bounded below, less the cap's radius
    precise dvec3 dm = c - mid;
    double ch = fp64_sqrt(dm.x * dm.x + dm.y * dm.y + dm.z * dm.z);
    double ch2 = ch * ch;
    double ang = ch + ch * ch2 * (1.0LF / 24.0LF) + ch * ch2 * ch2 * (3.0LF / 640.0LF);
    double d = ang * (1.0LF - 1e-15LF) - half_ - CAP_SLACK;
    d = d > 0.0LF ? d * (1.0LF - 1e-7LF) : 0.0LF;
    double hz = (h < 0.0LF && h > -F32_TINY) ? -F32_TINY : h;
    precise double nh = -h - u_se;
    precise double ph = h - u_se;
    precise double va = u_chord_e - einsum_dot(ea, ea);
    precise double vb = u_chord_e - einsum_dot(eb, eb);
    uint o = 6u * k;
    o_rec[o] = vec4(float(d), float(u_code[k]), float(hz), float(nh));
    o_rec[o + 1u] = vec4(vec3(n), float(ph));
    o_rec[o + 2u] = vec4(vec3(w1), float(einsum_dot(c, w1)));
    o_rec[o + 3u] = vec4(vec3(w2), float(einsum_dot(c, w2)));
    o_rec[o + 4u] = vec4(vec3(ea), float(va));
    o_rec[o + 5u] = vec4(vec3(eb), float(vb));
}
#endif
