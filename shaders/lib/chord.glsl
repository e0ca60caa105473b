// chord2_bounds(dp, rec): bounds on the float64 squared chord |p - g|^2 from float32 data.
//   dp  = p - c: the cell centre p relative to the bin centre c (unit sphere, from
//         lonlat_offset or cube_offset), relative error below 2e-6 of |dp|
//         (tests/test_shaders.py; cube_offset: tests/test_raster_input.py);
//   rec = (g - c, |g - c|): an intersected cell's centre g relative to c, made in
//         float64 on the CPU (gloffset/raster/rasterized/curve_gpu.py) and rounded to float32.
// Returns (lower, upper) with lower <= |p - g|^2 <= upper for the float64 value the
// CPU reference computes: the error of v = dp - (g - c) is at most
// e = CHORD_REL (|dp| + |g - c|), so that of |v|^2 is at most e (2|v| + e), plus
// float32 rounding of the dot product (CHORD_DOT |v|^2). CHORD_REL is five times the
// measured bound of lonlat_offset (and of cube_offset).
const float CHORD_REL = 1e-5;
const float CHORD_DOT = 1e-6;

vec2 chord2_bounds(vec3 dp, vec4 rec) {
    vec3 v = dp - rec.xyz;
    float c2 = dot(v, v);
    float e = CHORD_REL * (length(dp) + rec.w);
    float err = e * (2.0 * sqrt(c2) + e) + CHORD_DOT * c2;
    return vec2(c2 - err, c2 + err);
}
