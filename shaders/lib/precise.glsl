// precise_sin(x): sin(x) with full float32 relative accuracy for small |x|.
//   x: angle in radians. GPU sin() is only accurate in absolute terms (about 1e-6 on
//   some drivers), which would swamp the tiny offsets the engine works with, so
//   arguments below 0.25 use the Taylor series to x^9 (error < 1e-12 relative).
// precise_versin(x): 1 - cos(x) = 2 sin^2(x/2), accurate for small |x|.
float precise_sin(float x) {
    if (abs(x) >= 0.25) {
        return sin(x);
    }
    float x2 = x * x;
    return x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))));
}

float precise_versin(float x) {
    float s = precise_sin(0.5 * x);
    return 2.0 * s * s;
}
