// The sign of a distance field's pixel from its nearest boundary feature, in float32
// (gloffset/raster/fields/sign.py has the derivation and the float64 rule).
//
// A pixel p whose nearest boundary point is the foot on a ring edge a -> b is inside iff
// p . n > 0 (n, the edge's unit left normal: rings have their interior on the left);
// one whose nearest point is a vertex v (its foot off both edges at v) is inside iff
// the corner at v is reflex. The corner flags come from the CPU (float64): per arc,
// bits 0-1 the rule at its start a, bits 2-3 at its end b (FIELD_OUTSIDE,
// FIELD_INSIDE or FIELD_UNDECIDED: a pinch, a seam or a degenerate edge next to it,
// nearly straight), bit 4 set for a ring edge with distance and a direction
// (gloffset.raster.fields.sign.Corners.flags).
//
// The arc comes as the records of shaders/nearest.frag: r0 = (a, n.x), r1 = (b, n.y),
// r2 = (n x a, n.z), r3 = (b x n, ok). The pixel centre and the records are float64
// values rounded to float32 (each within 2^-24 |x| per component: 1.1e-7 for a unit
// vector) and a float32 dot product of unit vectors adds at most 3 roundings (1.8e-7):
// a value p . x is within 4e-7 of its float64 value. FIELD_SIGN_EPS (1e-6) leaves a
// margin: a side or lune value within it of 0 is not trusted. The feature's kind (0 the
// foot on the arc, 1 its end a, 2 its end b, as nearest.frag reports it) may be wrong
// where a lune value is that near 0, so a foot near an end also asks the end's corner
// and an end near the lune's boundary also asks the side; they must agree. Near-ties
// between features are the caller's: it asks each and keeps an answer they agree on.
// A pixel whose least chord is below FIELD_SIGN_NEAR is undecided (the caller's test:
// the float64 rule, then the levels, decide it).

const uint FIELD_OUTSIDE = 0u;
const uint FIELD_INSIDE = 1u;
const uint FIELD_UNDECIDED = 2u;
const uint FIELD_SIGN_OK = 16u;
const float FIELD_SIGN_EPS = 1e-6;
const float FIELD_SIGN_NEAR = 1e-5;

// Combine an answer with another: the same, or undecided.
uint field_sign_agree(uint now, uint other) {
    return now == other ? now : FIELD_UNDECIDED;
}

// The side rule: inside iff p . n > 0, undecided within FIELD_SIGN_EPS of 0.
uint field_sign_side(vec3 p, vec3 n) {
    float s = dot(p, n);
    if (abs(s) <= FIELD_SIGN_EPS) {
        return FIELD_UNDECIDED;
    }
    return s > 0.0 ? FIELD_INSIDE : FIELD_OUTSIDE;
}

// The answer for a pixel whose nearest feature is the foot on an arc (corner flags
// `corner`), its side's answer `side` and its lune values la = p . (n x a), lb = p . (b x n)
// given: a foot within FIELD_SIGN_EPS of an end also asks the end's corner.
uint field_sign_foot(uint side, float la, float lb, uint corner) {
    if ((corner & FIELD_SIGN_OK) == 0u) {
        return FIELD_UNDECIDED;
    }
    uint ans = side;
    if (la <= FIELD_SIGN_EPS) {
        ans = field_sign_agree(ans, corner & 3u);
    }
    if (lb <= FIELD_SIGN_EPS) {
        ans = field_sign_agree(ans, (corner >> 2) & 3u);
    }
    return ans;
}

// The answer for pixel p whose nearest feature is `kind` of the arc (records r0..r3,
// corner flags `corner`), or FIELD_UNDECIDED.
uint field_sign(vec3 p, uint kind, vec4 r0, vec4 r1, vec4 r2, vec4 r3, uint corner) {
    if ((corner & FIELD_SIGN_OK) == 0u || kind > 2u) {
        return FIELD_UNDECIDED;
    }
    vec3 n = vec3(r0.w, r1.w, r2.w);
    float la = dot(p, r2.xyz);
    float lb = dot(p, r3.xyz);
    uint at_a = corner & 3u;
    uint at_b = (corner >> 2) & 3u;
    uint ans;
    if (kind == 0u) {
        return field_sign_foot(field_sign_side(p, n), la, lb, corner);
    }
    ans = kind == 1u ? at_a : at_b;
    float l = kind == 1u ? la : lb;
    if (l >= -FIELD_SIGN_EPS) {  // near the lune's boundary: the foot may be on the arc
        ans = field_sign_agree(ans, field_sign_side(p, n));
    }
    return ans;
}
