#include "lib/fp64.glsl"
// grid_centre(px): the unit vector (Earth frame, float64) of the point at output-pixel
// coordinates px (the grid's own: (0, 0) its top-left corner, pixel (i, j)'s centre at
// (i + 0.5, j + 0.5)) of a Lambert azimuthal equal-area grid, any aspect, on the sphere
// or the ellipsoid (gloffset/grids/laea.py, laea_glsl, makes u_grid from pyproj's CRS):
// PROJ's inverse, through the authalic sphere. Double add, multiply and fma only
// (lib/fp64.glsl):
//   (X, Y) = (u_grid[0] + px.x u_grid[1], u_grid[2] + px.y u_grid[3]): the plane
//     coordinates less the false origin, on the unit authalic sphere's plane (PROJ's
//     x / (a dd rq), y dd / (a rq)), so that r^2 = X^2 + Y^2 = 4 sin^2(c / 2), c the
//     angle from the origin;
//   the point cos(c) C + sin(c) (X E + Y N) / r = (1 - r^2 / 2) C + sqrt(1 - r^2 / 4)
//     (X E + Y N), C, E, N the origin and its east and north on the authalic sphere,
//     from u_grid[4..7] = (cos b0, sin b0, cos lon0, sin lon0), b0 the origin's
//     authalic latitude;
//   its z is sin(beta), beta the authalic latitude; the geodetic latitude phi = beta +
//     delta, delta = sum a_2k sin(2k beta) (pyproj's own series, read from pyproj)
//     written delta = cos(beta) S, S = sin(beta) G(cos^2 beta), G's coefficients
//     g_0..g_5 = u_grid[8..13]; then, as in polar_stereographic.glsl, sin(phi) =
//     sin(beta) cos(delta) + cos^2(beta) S sinc(delta) and cos(phi) / cos(beta) =
//     cos(delta) - sin(beta) S sinc(delta) (Taylor series to delta^6: |delta| < 0.003).
//     On a sphere G = 0.
uniform double u_grid[16];

dvec3 grid_centre(dvec2 px) {
    double X = fma(px.x, u_grid[1], u_grid[0]);
    double Y = fma(px.y, u_grid[3], u_grid[2]);
    double r2 = fma(X, X, Y * Y);
    double cc = fma(-0.5LF, r2, 1.0LF);                // cos(c)
    double w = fp64_sqrt(fma(-0.25LF, r2, 1.0LF));    // cos(c / 2)
    double xe = X * w;
    double yn = Y * w;
    double h = fma(cc, u_grid[4], -yn * u_grid[5]);   // along the origin's meridian plane
    double s = fma(cc, u_grid[5], yn * u_grid[4]);    // sin(beta)
    double qx = fma(h, u_grid[6], -xe * u_grid[7]);
    double qy = fma(h, u_grid[7], xe * u_grid[6]);
    double c2 = fma(qx, qx, qy * qy);                 // cos^2(beta)
    double g = u_grid[13];
    g = fma(g, c2, u_grid[12]);
    g = fma(g, c2, u_grid[11]);
    g = fma(g, c2, u_grid[10]);
    g = fma(g, c2, u_grid[9]);
    g = fma(g, c2, u_grid[8]);
    return fp64_geodetic(qx, qy, s, c2, g);
}
