#include "lib/fp64.glsl"
// grid_centre(px): the unit vector (Earth frame, float64) of the point at output-pixel
// coordinates px (the grid's own: (0, 0) its top-left corner, pixel (i, j)'s centre at
// (i + 0.5, j + 0.5)) of a polar stereographic grid, on the sphere or the ellipsoid
// (gloffset/grids/projected.py, polar_glsl, makes u_grid from pyproj's CRS).
// Double add, multiply and fma only (lib/fp64.glsl):
//   (X, Y) = (u_grid[0] + px.x u_grid[1], u_grid[2] + px.y u_grid[3]): the plane
//     coordinates less the false origin, over 2 a k_p / sqrt((1+e)^(1+e) (1-e)^(1-e)),
//     so that X^2 + Y^2 = tan^2(pi/4 - |chi|/2), chi the conformal latitude;
//   the conformal sphere's point, rational: (M (X, Y), sg (1 - r^2)) / (1 + r^2),
//     r^2 = X^2 + Y^2, M = u_grid[4..7] (the central meridian and the axes' signs),
//     sg = u_grid[8] (+1 north, -1 south);
//   the geodetic latitude phi = chi + delta, delta = sum a_2k sin(2k chi) (the
//     conformal latitude's Fourier series, 6 terms: the next is below 1e-17 on WGS84)
//     written delta = cos(chi) S, S = sin(chi) G(cos^2 chi), G's coefficients g_0..g_5
//     = u_grid[9..14]; then sin(phi) = sin(chi) cos(delta) + cos^2(chi) S sinc(delta)
//     and cos(phi) / cos(chi) = cos(delta) - sin(chi) S sinc(delta) (Taylor series to
//     delta^6: |delta| < 0.004): no square root, no division, nothing singular at the
//     pole. On a sphere G = 0.
uniform double u_grid[16];

dvec3 grid_centre(dvec2 px) {
    double X = fma(px.x, u_grid[1], u_grid[0]);
    double Y = fma(px.y, u_grid[3], u_grid[2]);
    double r2 = fma(X, X, Y * Y);
    double w = fp64_recip(1.0LF + r2);
    double qx = fma(u_grid[4], X, u_grid[5] * Y) * w;
    double qy = fma(u_grid[6], X, u_grid[7] * Y) * w;
    double s = u_grid[8] * ((1.0LF - r2) * w);  // sin(chi)
    double c2 = fma(qx, qx, qy * qy);         // cos^2(chi)
    double g = u_grid[14];
    g = fma(g, c2, u_grid[13]);
    g = fma(g, c2, u_grid[12]);
    g = fma(g, c2, u_grid[11]);
    g = fma(g, c2, u_grid[10]);
    g = fma(g, c2, u_grid[9]);
    return fp64_geodetic(qx, qy, s, c2, g);
}
