#include "lib/fp64.glsl"
// cube_point: the unit vector (double) at face coordinates (sc, tc) of a face (e, u, v
// axis-aligned: each coordinate of e + sc u + tc v is one of 1, sc, tc up to sign, so
// exact), normalized with fp64_sqrt and fp64_recip (lib/fp64.glsl): within 3 ulp of
// gloffset.grids.cube.face_points' division by the norm.
dvec3 cube_point(double sc, double tc, dvec3 e, dvec3 u, dvec3 v) {
    precise dvec3 q = e + sc * u + tc * v;
    precise double s = q.x * q.x + q.y * q.y + q.z * q.z;
    return q * fp64_recip(fp64_sqrt(s));
}
