// Tests of one point p = c + delta against one arc a -> b of a bin with centre c.
// The arc comes as a record of six float32 texels computed in float64 on the CPU
// relative to c (gloffset/raster/records.py, records), e = |d| the offset distance:
//   t0 = (D, flags + 8 * local component id, h, -h - sin e)
//        D <= distance from c to the arc (by its bounding cap, rounded down), h = c.n
//   t1 = (n, h - sin e)        n = unit normal of a x b (zero for a point)
//   t2 = (n x a, c.(n x a))    start of the arc's lune
//   t3 = (b x n, c.(b x n))    end of the arc's lune
//   t4 = (c - a, chord(e)^2 - |c - a|^2)
//   t5 = (c - b, chord(e)^2 - |c - b|^2)
// Values are "distance minus e" in the monotone measures sin (near the great circle)
// and squared chord (near an end): <= mu or <= nu means "within x" for the margins
// mu = sin(x) - sin(e), nu = chord(x)^2 - chord(e)^2 of a distance x.
//
// Clusters: a bin's records (in arc order) come in runs of up to 16 arcs that follow
// each other along a ring, each with a header of two uvec4 (float32 bits but for the
// last word):
//   h0 = (Q, rho)                every point x of the cluster's arcs has |x - c - Q| <= rho
//   h1 = (Dmin, hmin, S, range)  Dmin = min t0.x of its records, hmin = min |t0.z| of its
//                                ring records (inf if none), S >= |Q| + rho (so S >= |x - c|),
//                                range = 16 * first record + records - 1
// rho and S are rounded up, Dmin and hmin are the records' own float32 values. A bin's
// cluster headers come in increasing Dmin.

const uint ARC_IS_ARC = 1u;       // a != b: the line part applies
const uint ARC_HAS_DISTANCE = 2u; // not a seam
const uint ARC_RING = 4u;         // a ring edge: crosses count, bounds the inside

// sin(dist to the great circle) - sin(e): max of the two sides.
float arc_line_value(vec3 delta, vec4 t0, vec4 t1) {
    float dn = dot(delta, t1.xyz);
    return max(t1.w + dn, t0.w - dn);
}

// Whether p lies in the lune where the nearest point of the arc is interior.
bool arc_in_wedge(vec3 delta, vec4 t2, vec4 t3) {
    return (t2.w + dot(delta, t2.xyz) >= 0.0) && (t3.w + dot(delta, t3.xyz) >= 0.0);
}

// chord(p, nearer end)^2 - chord(e)^2.
float arc_point_value(vec3 delta, vec4 t4, vec4 t5) {
    float dd = dot(delta, delta);
    float va = 2.0 * dot(delta, t4.xyz) + dd - t4.w;
    float vb = 2.0 * dot(delta, t5.xyz) + dd - t5.w;
    return min(va, vb);
}

// Whether the short arc p -> c crosses the arc a -> b (half-open rule of
// gloffset.geometry.sphere.arcs_cross). c is the bin centre as a float32 unit vector.
bool arc_crosses(vec3 delta, vec3 c, vec4 t0, vec4 t1, vec4 t4, vec4 t5) {
    bool sa = dot(delta, cross(t4.xyz, c)) >= 0.0;  // (p x c).a = delta.(c x a) = delta.((c - a) x c)
    bool sb = dot(delta, cross(t5.xyz, c)) >= 0.0;
    bool sp = t0.z + dot(delta, t1.xyz) >= 0.0;      // orient(a, b, p)
    bool sq = t0.z >= 0.0;                           // orient(a, b, c)
    return (sa != sb) && (sp != sq) && (sp == sb);
}
