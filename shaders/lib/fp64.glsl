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
