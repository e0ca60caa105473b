#version 430
// One level of the offset of a rasterized curve (paper Sec. 5.2; the float64
// reference is gloffset/raster/rasterized/offset.py, the planner
// gloffset/raster/rasterized/curve_gpu.py, the passes gloffset/gl/rasterized_pass.py).
// Drawn over the frontier bins only (bins.vert). Each fragment is a cell (column x,
// row y; row 0 north) of level l: if its parent is contained or outside it takes
// that class, else it compares the smallest squared chord to the intersected cells
// listed for its bin with the row's thresholds:
// 0 outside, 1 frontier, 2 contained, 3 ambiguous (too close to a threshold for
// float32: decided in float64 on the CPU). Grids whose rows are parallels and
// columns meridians (equirectangular, web-mercator tiles); with GRID_CUBE defined,
// one face of a cube map per pass (cells in face pixels, lib/cube.glsl).
#include "lib/lonlat.glsl"
#include "lib/cube.glsl"
#include "lib/chord.glsl"

const uint FRONTIER = 1u;
const uint OUTSIDE = 0u;
const uint CONTAINED = 2u;
const uint AMBIGUOUS = 3u;

uniform usampler2D u_parent;     // classes of level l-1 (R8UI), no ambiguous cell
uniform usampler2D u_bins;       // per bin: (first record, record count, 0, 0)
uniform sampler2D u_records;     // per record: (g - c, |g - c|), c the bin centre
uniform int u_record_row;        // records per row of u_records
uniform sampler2D u_thresholds;  // per row of level l: (lo-, lo+, hi-, hi+) squared chords
                                 // with lo- <= t_lo <= lo+ and hi- <= t_hi <= hi+
#ifdef GRID_CUBE
uniform vec3 u_face_e;           // the face's axis; u_face_u, u_face_v: directions of s and t
uniform vec3 u_face_u;
uniform vec3 u_face_v;
uniform float u_px;              // face coordinate (2 s - 1) per output pixel: 2 / size
uniform float u_block;           // output pixels per cell side at level l
uniform float u_bin_block;       // output pixels per bin side
#else
uniform sampler2D u_bin_lat;     // per bin row: (cos, sin) of the bin centre latitude
uniform sampler2D u_bin_lon;     // per bin column: (cos, sin) of the bin centre longitude
uniform sampler2D u_row_dphi;    // per cell row of level l: latitude minus its bin row's
uniform sampler2D u_col_dlam;    // per cell column of level l: longitude minus its bin column's
#endif
uniform int u_shift;             // l - bin level

out uint o_class;

void main() {
    ivec2 cell = ivec2(gl_FragCoord.xy);
    uint parent = texelFetch(u_parent, cell >> 1, 0).r;
    if (parent != FRONTIER) {
        o_class = parent;
        return;
    }
    ivec2 bin = cell >> u_shift;
    uvec4 info = texelFetch(u_bins, bin, 0);
#ifdef GRID_CUBE
    // bin and cell centres in output pixels (exact in float32), then face coordinates
    vec2 bpx = (vec2(bin) + 0.5) * u_bin_block;
    vec2 dpx = (vec2(cell) + 0.5) * u_block - bpx;
    vec3 c;
    vec3 dp = cube_offset(bpx.x * u_px - 1.0, bpx.y * u_px - 1.0, dpx.x * u_px, dpx.y * u_px,
                          u_face_e, u_face_u, u_face_v, c);
#else
    vec2 cs_phi = texelFetch(u_bin_lat, ivec2(bin.y, 0), 0).xy;
    vec2 cs_lam = texelFetch(u_bin_lon, ivec2(bin.x, 0), 0).xy;
    float dphi = texelFetch(u_row_dphi, ivec2(cell.y, 0), 0).x;
    float dlam = texelFetch(u_col_dlam, ivec2(cell.x, 0), 0).x;
    vec3 dp = lonlat_offset(cs_phi, cs_lam, dphi, dlam);
#endif

    vec2 best = vec2(1e30);  // (min of lower bounds, min of upper bounds)
    for (uint k = 0u; k < info.y; ++k) {
        int r = int(info.x + k);
        vec4 rec = texelFetch(u_records, ivec2(r % u_record_row, r / u_record_row), 0);
        best = min(best, chord2_bounds(dp, rec));
    }
    vec4 t = texelFetch(u_thresholds, ivec2(0, cell.y), 0);
    uint cls = AMBIGUOUS;
    if (best.y < t.x) {
        cls = CONTAINED;
    } else if (best.x >= t.y) {
        if (best.x >= t.w) cls = OUTSIDE;
        else if (best.y < t.z) cls = FRONTIER;
    }
    o_class = cls;
}
