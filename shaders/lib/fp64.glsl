// Double-precision helpers for the grids' GLSL functions (lib/grids/). GLSL promises
// correctly rounded double add and multiply, but not double division or sqrt: these
// helpers use only add, multiply and fma, and their stated errors hold whether fma is
// fused or not (Mesa's llvmpipe was measured not to fuse it; the tests probe there).
// fp64_recip(x): 1 / x for x > 0, within 2 ulp: a float32 seed (relative error below
// 1e-6) and two Newton steps r + r (1 - x r), each squaring the relative error
// (1e-12, then below the rounding of the last step).
double fp64_recip(double x) {
    double r = double(1.0 / float(x));
    r = fma(r, fma(-x, r, 1.0LF), r);
    return fma(r, fma(-x, r, 1.0LF), r);
}
// fp64_sqrt(x): sqrt(x) for x >= 0 (0 for x <= 0), within 2 ulp for x above 1e-30: the
// float32 inverse square root as a seed (relative error below 1e-6), two Newton steps
// y + y (1 - x y^2) / 2 (1e-12, then below the rounding), then s = x y and one step
// s + y (x - s^2) / 2 on the square root itself.
double fp64_sqrt(double x) {
    if (x <= 0.0LF) {
        return 0.0LF;
    }
    double y = double(inversesqrt(float(x)));
    y = fma(0.5LF * y, fma(-x * y, y, 1.0LF), y);
    y = fma(0.5LF * y, fma(-x * y, y, 1.0LF), y);
    double s = x * y;
    return fma(0.5LF * y, fma(-s, s, x), s);
}
// 1 / n (n = 1..30) and 1 / (n (n + 1)) (n = 1..26), as double literals (rounded once)
const double FP64_INV[30] = double[](
    1.0LF, 0.5LF, 0.3333333333333333LF, 0.25LF, 0.2LF, 0.16666666666666666LF,
    0.14285714285714285LF, 0.125LF, 0.1111111111111111LF, 0.1LF, 0.09090909090909091LF,
    0.08333333333333333LF, 0.07692307692307693LF, 0.07142857142857142LF,
    0.06666666666666667LF, 0.0625LF, 0.058823529411764705LF, 0.05555555555555555LF,
    0.05263157894736842LF, 0.05LF, 0.047619047619047616LF, 0.045454545454545456LF,
    0.043478260869565216LF, 0.041666666666666664LF, 0.04LF, 0.038461538461538464LF,
    0.037037037037037035LF, 0.03571428571428571LF, 0.034482758620689655LF,
    0.03333333333333333LF);
const double FP64_INV2[26] = double[](
    0.5LF, 0.16666666666666666LF, 0.08333333333333333LF, 0.05LF, 0.03333333333333333LF,
    0.023809523809523808LF, 0.017857142857142856LF, 0.013888888888888888LF,
    0.011111111111111112LF, 0.00909090909090909LF, 0.007575757575757576LF,
    0.00641025641025641LF, 0.005494505494505495LF, 0.004761904761904762LF,
    0.004166666666666667LF, 0.003676470588235294LF, 0.0032679738562091504LF,
    0.0029239766081871343LF, 0.002631578947368421LF, 0.002380952380952381LF,
    0.0021645021645021645LF, 0.001976284584980237LF, 0.0018115942028985507LF,
    0.0016666666666666668LF, 0.0015384615384615385LF, 0.0014245014245014246LF);

// fp64_exp(x): e^x for |x| <= 2.5, within 4 ulp (relative): Taylor's series of e^|x| to
// |x|^29 (the rest below 1e-20 of it) nested as 1 + t (1 + t/2 (1 + t/3 (...))), every
// term positive, and its reciprocal for x < 0 (no cancellation).
double fp64_exp(double x) {
    double t = abs(x);
    double p = 1.0LF;
    for (int n = 29; n >= 1; --n) {
        p = fma(t * FP64_INV[n - 1], p, 1.0LF);
    }
    return x < 0.0LF ? fp64_recip(p) : p;
}

// fp64_sin_cos(x, s, c): sin(x) and cos(x) for |x| <= 2, within 5e-16 (absolute):
// Taylor's series to x^25 and x^26 (the rest below 2e-20), nested as x (1 - x^2/(2 3)
// (1 - x^2/(4 5) (...))) and 1 - x^2/(1 2) (1 - x^2/(3 4) (...)).
void fp64_sin_cos(double x, out double s, out double c) {
    double x2 = x * x;
    s = 1.0LF;
    for (int n = 24; n >= 2; n -= 2) {
        s = fma(-x2 * FP64_INV2[n - 1], s, 1.0LF);
    }
    s *= x;
    c = 1.0LF;
    for (int n = 25; n >= 1; n -= 2) {
        c = fma(-x2 * FP64_INV2[n - 1], c, 1.0LF);
    }
}

// The point of the ellipsoid's geodetic latitude from a point of an auxiliary sphere
// (conformal or authalic latitude aux): (qx, qy) its horizontal components, s = sin(aux),
// c2 = qx^2 + qy^2 = cos^2(aux), g the latitude series in c2 (phi - aux = cos(aux) s g).
// Adds and multiplies only; the difference phi - aux is small (sin and cos of it to
// the seventh and sixth order).
dvec3 fp64_geodetic(double qx, double qy, double s, double c2, double g) {
    double S = s * g;
    double d2 = c2 * S * S;  // delta^2
    double cosd = 1.0LF + d2 * (-0.5LF + d2 * (0.041666666666666666667LF
                                             + d2 * -0.0013888888888888888889LF));
    double sincd = 1.0LF + d2 * (-0.16666666666666666667LF + d2 * (0.0083333333333333333333LF
                                             + d2 * -0.00019841269841269841270LF));
    double f = cosd - s * S * sincd;  // cos(phi) / cos(aux)
    return dvec3(qx * f, qy * f, fma(s, cosd, c2 * S * sincd));
}

// ln 2 in two parts (fdlibm's): FP64_LN2_HI has its last 32 bits zero, so that k
// FP64_LN2_HI is exact for |k| < 2^20 whether or not fma is fused; FP64_LN2_LO the rest
const double FP64_LN2_HI = 6.93147180369123816490e-01LF;
const double FP64_LN2_LO = 1.90821492927058770002e-10LF;

// fp64_log(x): ln(x) for x > 0 (normal doubles), within 1e-16 + 2 ulp of it (absolute
// plus relative): x = m 2^k (frexp) with m in [sqrt(1/2), sqrt(2)), then ln(m) = 2
// atanh(s), s = (m - 1) / (m + 1) (|s| <= 0.172, s^2 <= 0.0295: the odd series of
// atanh to s^25, the rest below 1e-20 of it), and k ln 2 from its two parts.
double fp64_log(double x) {
    int k;
    double m = frexp(x, k);
    if (m < 0.70710678118654752LF) {
        m *= 2.0LF;
        k -= 1;
    }
    double s = (m - 1.0LF) * fp64_recip(m + 1.0LF);
    double s2 = s * s;
    double p = FP64_INV[24];
    for (int n = 23; n >= 1; n -= 2) {
        p = fma(p, s2, FP64_INV[n - 1]);
    }
    double dk = double(k);
    return dk * FP64_LN2_HI + fma(2.0LF * s, p, dk * FP64_LN2_LO);
}

// fp64_exp_wide(x): e^x for |x| <= 700, within 5 ulp (relative): k = round(x / ln 2),
// r = (x - k FP64_LN2_HI) - k FP64_LN2_LO (the first difference exact: |r| <= 0.35,
// within 1e-16 of r), e^r by fp64_exp, then ldexp by k.
double fp64_exp_wide(double x) {
    double k = floor(x * 1.4426950408889634LF + 0.5LF);
    double r = (x - k * FP64_LN2_HI) - k * FP64_LN2_LO;
    return ldexp(fp64_exp(r), int(k));
}

// fp64_atan2(y, x): the angle of (x, y) for x > 0, within 3e-16 (absolute): the float32
// angle as a seed (within 1e-6) and one Newton step on f(t) = y cos(t) - x sin(t), whose
// f'' = -f is zero at the root, so the step is cubic (1e-18), then the roundings.
double fp64_atan2(double y, double x) {
    double t = double(atan(float(y), float(x)));
    double s, c;
    fp64_sin_cos(t, s, c);
    return t + fma(y, c, -x * s) * fp64_recip(fma(x, c, y * s));
}
