#version 430
// One level of the raster engine (DESIGN.md, "The raster engine").
// Drawn over the frontier bins only (bins.vert). Each fragment is a cell (column x,
// row y; row 0 north) of level l: if its parent is contained or outside it takes
// that class, else it is classified against its bin's candidate arcs:
// 0 outside, 1 frontier, 2 contained (at the output level only 0 or 2).
#include "lib/lonlat.glsl"
#include "lib/cube.glsl"
#include "lib/arcs.glsl"

const uint OUTSIDE = 0u;
const uint FRONTIER = 1u;
const uint CONTAINED = 2u;
const int RECORD_TEXELS = 6;

uniform usampler2D u_parent;   // classes of level l-1 (R8UI), valid inside frontier bins
uniform usampler2D u_bins;     // per bin: first record (in its buffer), record count, status bits
uniform usampler2D u_bin_geo;  // per bin: its geo row and column (index the geometry below)
layout(std430, binding = 0) readonly buffer Records {
    vec4 records[];            // arc records, RECORD_TEXELS vec4 each (lib/arcs.glsl)
};
#ifdef GRID_CUBE
uniform vec3 u_face_e;         // cube face axis; u_face_u, u_face_v: directions of s and t
uniform vec3 u_face_u;
uniform vec3 u_face_v;
uniform float u_px;            // face coordinate (2 s - 1) per output pixel: 2 / size
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
    for (uint k = 0u; k < info.y; ++k) {
        int r = int(info.x + k) * RECORD_TEXELS;
        vec4 t0 = records[r];
        if (t0.x > skip) {
            break;  // too far for a distance test and to cross p -> c, as are all after it
        }
        vec4 t1 = records[r + 1];
        vec4 t2 = records[r + 2];
        vec4 t3 = records[r + 3];
        vec4 t4 = records[r + 4];
        vec4 t5 = records[r + 5];
        uint code = uint(t0.y);
        uint flags = code & 7u;
        bool line = ((flags & ARC_IS_ARC) != 0u) && arc_in_wedge(delta, t2, t3);
        float v = line ? arc_line_value(delta, t0, t1) : arc_point_value(delta, t4, t5);
        bool dist = (flags & ARC_HAS_DISTANCE) != 0u;
        bool ring = (flags & ARC_RING) != 0u;
        if (ring && arc_crosses(delta, c, t0, t1, t4, t5)) {
            bits ^= 1u << (code >> 3u);
        }
        if (u_final) {
            if (dist && v <= 0.0) {
                within = true;  // decides the cell whatever the inside status
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
                break;  // decides the cell (contained for d >= 0, outside for d < 0)
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
