#version 430
// One level of the raster engine (DESIGN.md, "The raster engine").
// Drawn over the frontier bins only (bins.vert). Each fragment is a cell (column x,
// row y; row 0 north) of level l: if its parent is contained or outside it takes
// that class, else it is classified against its bin's candidate arcs:
// 0 outside, 1 frontier, 2 contained (at the output level only 0 or 2).
#include "lib/lonlat.glsl"
#include "lib/cube.glsl"
#include "lib/arcs.glsl"
#include GRID_GLSL

const uint OUTSIDE = 0u;
const uint FRONTIER = 1u;
const uint CONTAINED = 2u;
const int RECORD_TEXELS = 6;
const uint CLUSTER_TEXELS = 2u;

uniform usampler2D u_parent;   // classes of level l-1 (R8UI), valid inside frontier bins
uniform usampler2D u_bins;     // per bin: first cluster, cluster count (in its buffer), status bits
uniform usampler2D u_bin_geo;  // per bin: its geo row and column (index the geometry below)
layout(std430, binding = 0) readonly buffer Records {
    vec4 records[];            // arc records, RECORD_TEXELS vec4 each (lib/arcs.glsl)
};
layout(std430, binding = 1) readonly buffer Clusters {
    uvec4 clusters[];          // CLUSTER_TEXELS uvec4 per cluster of records (lib/arcs.glsl)
};
#ifdef GRID_CUBE
uniform vec3 u_face_e;         // cube face axis; u_face_u, u_face_v: directions of s and t
uniform vec3 u_face_u;
uniform vec3 u_face_v;
uniform float u_px;            // face coordinate (2 s - 1) per output pixel: 2 / size
#elif defined(GRID_GLSL)
// a grid's own GLSL function (GRID_GLSL names its file, lib/grids/): grid_centre(px),
// the unit vector in double of output-pixel coordinates px, from u_grid
uniform sampler2D u_bin_centre;    // per canvas bin: its centre c (unit vector), float32
uniform sampler2D u_bin_centre_lo; // and the float64 centre less that (c = hi + lo to 48 bits)
#elif defined(GRID_TEXTURE)
uniform sampler2D u_bin_centre; // per canvas bin: its centre c (unit vector)
uniform sampler2D u_cell_delta; // per canvas cell of level l: its centre minus c (float64-made)
#else
uniform sampler2D u_bin_lat;   // per geo row: (cos, sin) of the bin centre latitude
uniform sampler2D u_bin_lon;   // per geo column: (cos, sin) of the bin centre longitude
uniform sampler2D u_row_dphi;  // (sub-row, geo row): the cell row's latitude minus its bin's (float64-made)
uniform sampler2D u_col_dlam;  // (sub-column, geo column): the same for longitudes
#endif
uniform sampler2D u_margins;   // (2 sub-row + k, geo row): k = 0 (mu_lo, mu_hi, mu_rho, _), 1 (nu_lo, nu_hi, nu_rho, _)
uniform int u_shift;           // l - bin level
uniform float u_block;         // output pixels per cell side at level l
uniform float u_bin_block;     // output pixels per bin side
uniform bool u_final;          // output level: decide every cell at its centre
uniform bool u_positive;       // d >= 0 (grow) or d < 0 (shrink)
uniform float u_e;             // |d|, radians
uniform float u_rho_max;       // the largest cell bound rho of level l (0 at the output level)

out uint o_class;

const float F32_ERR = 4.8e-7;  // 4 ulp: rounding allowance for the margins at coarse levels

#ifdef PREPASS
// Drawn before a level's pass over the same bins (from the second level below the
// bins on; at the first every cell is a child of its frontier bin): a cell whose
// parent is decided takes its class here, and the depth buffer gets 1 at the children
// of frontier cells, 0 elsewhere. The level's pass (depth 0.5, test LESS) then runs
// only where the depth is 1: llvmpipe skips whole 4x4 blocks that fail the test before
// shading, instead of running the whole shader under an empty mask.
void main() {
    uint parent = texelFetch(u_parent, ivec2(gl_FragCoord.xy) >> 1, 0).r;
    o_class = parent;
    gl_FragDepth = parent == FRONTIER ? 1.0 : 0.0;
}
#else
void main() {
    ivec2 cell = ivec2(gl_FragCoord.xy);
    uint parent = texelFetch(u_parent, cell >> 1, 0).r;
    if (parent != FRONTIER) {
        o_class = parent;
        return;
    }
    ivec2 bin = cell >> u_shift;          // on the canvas
    ivec2 sub = cell - (bin << u_shift);  // the cell within its bin
    uvec4 info = texelFetch(u_bins, bin, 0);
    ivec2 geo = ivec2(texelFetch(u_bin_geo, bin, 0).yx);  // (column, row)
#ifdef GRID_CUBE
    vec2 bpx = (vec2(geo) + 0.5) * u_bin_block;  // bin centre, output pixels of the face
    vec2 dpx = (vec2(sub) + 0.5) * u_block - 0.5 * u_bin_block;
    vec3 c;
    vec3 delta = cube_offset(bpx.x * u_px - 1.0, bpx.y * u_px - 1.0, dpx.x * u_px, dpx.y * u_px,
                             u_face_e, u_face_u, u_face_v, c);
#elif defined(GRID_GLSL)
    // the cell's centre minus its bin's, in double, then cast: no cancellation
    vec3 c = texelFetch(u_bin_centre, bin, 0).xyz;
    dvec3 cd = dvec3(c) + dvec3(texelFetch(u_bin_centre_lo, bin, 0).xyz);
    dvec2 px = (dvec2((geo << u_shift) + sub) + 0.5LF) * double(u_block);
    vec3 delta = vec3(grid_centre(px) - cd);
#elif defined(GRID_TEXTURE)
    vec3 c = texelFetch(u_bin_centre, bin, 0).xyz;
    vec3 delta = texelFetch(u_cell_delta, cell, 0).xyz;
#else
    vec2 cs_phi = texelFetch(u_bin_lat, ivec2(geo.y, 0), 0).xy;
    vec2 cs_lam = texelFetch(u_bin_lon, ivec2(geo.x, 0), 0).xy;
    vec3 c = vec3(cs_phi.x * cs_lam.x, cs_phi.x * cs_lam.y, cs_phi.y);
    float dphi = texelFetch(u_row_dphi, ivec2(sub.y, geo.y), 0).x;
    float dlam = texelFetch(u_col_dlam, ivec2(sub.x, geo.x), 0).x;
    vec3 delta = lonlat_offset(cs_phi, cs_lam, dphi, dlam);
#endif

    vec4 mu = u_final ? vec4(0.0) : texelFetch(u_margins, ivec2(2 * sub.y, geo.y), 0);
    vec4 nu = u_final ? vec4(0.0) : texelFetch(u_margins, ivec2(2 * sub.y + 1, geo.y), 0);

    uint bits = info.z;
    bool within = false;    // some arc within e (output level)
    bool near_lo = false;   // surely within e - rho
    bool near_hi = false;   // possibly within e + rho
    bool near_rho = false;  // a ring edge possibly within rho
    // arcs farther than e + rho + angle(c, p) from c cannot matter. The angle, not the
    // chord l = |delta| (bins of coarse tiles span tens of degrees), bounded above by
    // l (1 + l^2 / 20) for l <= 1 (GPU asin is not accurate in relative terms for tiny l)
    float l = length(delta);
    float reach = l <= 1.0 ? l * (1.0 + l * l / 20.0) : 2.0 * asin(min(1.0, 0.5 * l)) + 1e-5;
    float skip = (u_e + u_rho_max + reach) * (1.0 + 1e-5) + 1e-12;

    // Cluster culling (lib/arcs.glsl, "clusters"). A cluster is passed over only when
    // none of its records, evaluated as below, could change anything; the records
    // evaluated otherwise are those with t0.x <= skip as without clusters, and the
    // results are ORs and XORs of per-record tests (the early breaks come only once the
    // class is decided), so the classes are the same bit for bit. A far cluster
    // (test 1) that may hold a crossing (test 2 fails) has its crossings evaluated.
    // (1) Distances. Every test that sets within, near_lo, near_hi or near_rho implies
    // v <= m.y + slack (m.x <= m.y, m.z <= m.y; within: v <= 0, m = 0), which needs a
    // point of the arc within chord T = e + rho_max (>= chord(T)) of P = c + delta plus:
    // for the line part |h + delta.n| - sin e, the slack F32_ERR (scale + sum|m|) and
    // float32 errors of a few ulp of S + l + sin e (S >= |x - c| for every point x of
    // the cluster's arcs, so S >= |h|, |t4.xyz|, |t5.xyz|), the wedge test's few ulp of
    // S + l (a foot that far beyond an end), all divided by the slope of sin (> 0.5 for
    // T <= 1); for the point part, a squared chord, slack and errors below
    // 1e-6 (e^2 + (S + l)^2 + sum|m|), i.e. 1e-3 (e + S + l + sqrt(sum|m|)) in chord;
    // delta itself is good to a few ulp of l. So a cluster whose ball lies farther than
    // kdist + 1.1e-3 S from P (kdist = T (1 + 1e-4) + 1.1e-3 (sqrt(sum|m| + e^2) + l))
    // passes no distance test. Off where T > 1, and where a margin is the "never" value
    // (-1e30: then the slack passes every record).
    // (2) Crossings (arc_crosses) of the ring records. If |t0.z| >= hmin > l (1 + 1e-4)
    // + 1e-30 >= |delta.n| (float32, |n| = 1) with room for the rounding of the sum,
    // t0.z + delta.n has the sign of t0.z: sp == sq. Or, with M = c x delta: the
    // endpoints' offsets a - c lie in the ball (Q, rho), so sign(delta.((c - a) x c)) =
    // sign((c - a).M) = -sign(Q.M) for all of them when |Q.M| > l ((1 + 1e-4) rho +
    // 1e-4 S) + 1e-30 (float32 errors: a few ulp of l S): sa == sb. Either way no arc
    // of the cluster crosses.
    vec3 side = cross(c, delta);
    float l_up = l * (1.0 + 1e-4) + 1e-30;
    float t_cull = u_e + u_rho_max;
    float m_sum = dot(abs(mu.xyz), vec3(1.0)) + dot(abs(nu.xyz), vec3(1.0));
    float kdist = (t_cull <= 1.0 && m_sum < 1e4)
        ? t_cull * (1.0 + 1e-4) + 1.1e-3 * (sqrt(m_sum + u_e * u_e) + l)
        : 1e30;

    bool done = false;
    for (uint k = 0u; k < info.y && !done; ++k) {
        uint hc = (info.x + k) * CLUSTER_TEXELS;
        uvec4 h1 = clusters[hc + 1u];
        if (uintBitsToFloat(h1.x) > skip) {
            break;  // its records and all after it are beyond skip (sorted by Dmin)
        }
        vec4 cap = uintBitsToFloat(clusters[hc]);
        float S = uintBitsToFloat(h1.z);
        bool far = length(delta - cap.xyz) - cap.w > kdist + 1.1e-3 * S;
        if (far && (l_up < uintBitsToFloat(h1.y)
                    || abs(dot(cap.xyz, side)) > l * ((1.0 + 1e-4) * cap.w + 1e-4 * S) + 1e-30)) {
            continue;  // nothing to find in this cluster
        }
        uint r1 = (h1.w >> 4u) + (h1.w & 15u) + 1u;
        for (uint r = h1.w >> 4u; r < r1; ++r) {
            int t = int(r) * RECORD_TEXELS;
            vec4 t0 = records[t];
            if (t0.x > skip) {
                continue;  // too far for a distance test and to cross p -> c
            }
            vec4 t1 = records[t + 1];
            vec4 t4 = records[t + 4];
            vec4 t5 = records[t + 5];
            uint code = uint(t0.y);
            uint flags = code & 7u;
            bool ring = (flags & ARC_RING) != 0u;
            if (ring && arc_crosses(delta, c, t0, t1, t4, t5)) {
                bits ^= 1u << (code >> 3u);
            }
            if (far) {
                continue;  // only crossings can matter here
            }
            vec4 t2 = records[t + 2];
            vec4 t3 = records[t + 3];
            bool line = ((flags & ARC_IS_ARC) != 0u) && arc_in_wedge(delta, t2, t3);
            float v = line ? arc_line_value(delta, t0, t1) : arc_point_value(delta, t4, t5);
            bool dist = (flags & ARC_HAS_DISTANCE) != 0u;
            if (u_final) {
                if (dist && v <= 0.0) {
                    within = true;  // decides the cell whatever the inside status
                    done = true;
                    break;
                }
            } else {
                float scale = line ? abs(t1.w) + abs(t0.w) + abs(dot(delta, t1.xyz))
                                   : max(abs(t4.w), abs(t5.w)) + dot(delta, delta)
                                     + 2.0 * length(delta) * max(length(t4.xyz), length(t5.xyz));
                vec3 m = line ? mu.xyz : nu.xyz;
                float slack = F32_ERR * (scale + abs(m.x) + abs(m.y) + abs(m.z));
                near_lo = near_lo || (dist && v <= m.x - slack);
                near_hi = near_hi || (dist && v <= m.y + slack);
                near_rho = near_rho || (ring && v <= m.z + slack);
                if (near_lo) {
                    done = true;
                    break;  // decides the cell (contained for d >= 0, outside for d < 0)
                }
            }
        }
    }
    bool inside = bits != 0u;
    if (u_final) {
        bool member = u_positive ? (inside || within) : (inside && !within);
        o_class = member ? CONTAINED : OUTSIDE;
        return;
    }
    uint cls = FRONTIER;
    if (u_positive) {
        if (near_lo || (inside && !near_rho)) cls = CONTAINED;
        else if (!inside && !near_rho && !near_hi) cls = OUTSIDE;
    } else {
        if (inside && !near_rho && !near_hi) cls = CONTAINED;
        else if (near_lo || (!inside && !near_rho)) cls = OUTSIDE;
    }
    o_class = cls;
}
#endif
