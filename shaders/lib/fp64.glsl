// Double-precision helpers for the grids' GLSL functions (lib/grids/). GLSL promises
// correctly rounded double add, multiply and fma, but not double division or sqrt:
// these helpers use only the former.
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
