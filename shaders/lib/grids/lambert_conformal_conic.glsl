#include "lib/fp64.glsl"
// grid_centre(px): the unit vector (Earth frame, float64) of the point at output-pixel
// coordinates px (the grid's own: (0, 0) its top-left corner, pixel (i, j)'s centre at
// (i + 0.5, j + 0.5)) of a Lambert conformal conic grid (1SP and 2SP: EPSG:3978, 2154,
// 3347), on the sphere or the ellipsoid (gloffset/grids/conic.py, lcc_glsl, makes u_grid
// from pyproj's CRS): PROJ's inverse in double add, multiply and fma (lib/fp64.glsl:
// log, exp, atan2, sin and cos):
//   (X, Y) = (u_grid[0] + px.x u_grid[1], u_grid[2] + px.y u_grid[3]): sign(n) (x', rho0
//     - y') over a F (x', y' the plane less the false origin, rho0 the origin's distance
//     from the apex), so that X^2 + Y^2 = t^(2n) (t = tan(pi/4 - chi/2), chi the conformal
//     latitude) and Y > 0 (lcc_clear: the grid below the apex);
//   theta = atan2(X, Y), lambda - lambda0 = theta / n (|theta / n| <= 3.8) from the sine
//     and cosine of its half, u_grid[4] = 1 / (2 n), turned by (cos lambda0, sin
//     lambda0) = u_grid[5..6];
//   t = exp(ln(X^2 + Y^2) / (2 n)); sin(chi) = (1 - t^2) / (1 + t^2), cos(chi) = 2 t /
//     (1 + t^2);
//   the geodetic latitude from the conformal one as in polar_stereographic.glsl, G's
//     coefficients g_0..g_5 = u_grid[7..12] (0 on a sphere).
uniform double u_grid[16];

dvec3 grid_centre(dvec2 px) {
    double X = fma(px.x, u_grid[1], u_grid[0]);
    double Y = fma(px.y, u_grid[3], u_grid[2]);
    double h = fp64_atan2(X, Y) * u_grid[4];     // (lambda - lambda0) / 2
    double sh, ch;
    fp64_sin_cos(h, sh, ch);
    double cl = (ch - sh) * (ch + sh);
    double sl = 2.0LF * sh * ch;
    double t = fp64_exp_wide(fp64_log(fma(X, X, Y * Y)) * u_grid[4]);
    double w = fp64_recip(fma(t, t, 1.0LF));
    double s = fma(-t, t, 1.0LF) * w;            // sin(chi)
    double cc = 2.0LF * t * w;                   // cos(chi)
    double qx = cc * fma(u_grid[5], cl, -u_grid[6] * sl);
    double qy = cc * fma(u_grid[6], cl, u_grid[5] * sl);
    double c2 = cc * cc;
    double g = u_grid[12];
    g = fma(g, c2, u_grid[11]);
    g = fma(g, c2, u_grid[10]);
    g = fma(g, c2, u_grid[9]);
    g = fma(g, c2, u_grid[8]);
    g = fma(g, c2, u_grid[7]);
    return fp64_geodetic(qx, qy, s, c2, g);
}
