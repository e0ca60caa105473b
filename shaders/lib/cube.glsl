// cube_offset: the vector p - c between two points of one cube face, without
// cancellation, and the unit vector c.
//   sc, tc: face coordinates in [-1, 1] of the bin centre c (GL cube-map s, t mapped
//           by 2s - 1, 2t - 1); dsc, dtc: those of p minus those of c (small);
//   e, u, v: the face's axis and the directions of growing s and t, so that a point
//           is normalize(e + sc u + tc v) (gloffset/grids/cube.py, FACES).
// Only differences enter: p - c = dv / |v| - v_c (|v|^2 - |v_c|^2) / (|v||v_c|(|v| + |v_c|))
// with dv = dsc u + dtc v, so the result has a few float32 ulp of relative error.
vec3 cube_offset(float sc, float tc, float dsc, float dtc, vec3 e, vec3 u, vec3 v, out vec3 c) {
    vec3 vc = e + sc * u + tc * v;
    float nc2 = 1.0 + sc * sc + tc * tc;
    float dn2 = dsc * (2.0 * sc + dsc) + dtc * (2.0 * tc + dtc);
    float nc = sqrt(nc2);
    float nv = sqrt(nc2 + dn2);
    c = vc / nc;
    return (dsc * u + dtc * v) / nv - vc * (dn2 / (nv * nc * (nv + nc)));
}
