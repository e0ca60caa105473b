#include "lib/fp64.glsl"
// grid_centre(px): the unit vector (Earth frame, float64) of the point at output-pixel
// coordinates px (the grid's own: (0, 0) its top-left corner, pixel (i, j)'s centre at
// (i + 0.5, j + 0.5)) of a transverse Mercator grid (UTM, national grids), on the
// sphere or the ellipsoid (gloffset/grids/transverse.py, tm_glsl, makes u_grid from
// pyproj's CRS): PROJ's inverse (Poder/Engsager, Krueger's series), in double add,
// multiply and fma (lib/fp64.glsl: exp, sin and cos by Taylor's series):
//   zeta = xi + i eta = (u_grid[0] + px.y u_grid[1]) + i (u_grid[2] + px.x u_grid[3]):
//     northing and easting over k0 A (A the rectifying radius), the origin's
//     rectifying latitude added (|xi| <= 2, |eta| <= 1);
//   zeta' = zeta + sum b_k sin(2k zeta) (complex, Clenshaw's sum; b_1..b_5 =
//     u_grid[6..10], read from pyproj: 0 on a sphere);
//   the conformal sphere's point (cos xi' sech eta', tanh eta', sin xi' sech eta')
//     (from the central meridian), turned by (cos lon0, sin lon0) = u_grid[4..5];
//   its z is sin(chi), chi the conformal latitude; the geodetic latitude phi = chi +
//     delta as in polar_stereographic.glsl, G's coefficients g_0..g_4 = u_grid[11..15]
//     (five terms: the next is below 1e-16 on WGS84).
uniform double u_grid[16];

dvec2 fp64_cmul(dvec2 a, dvec2 b) {
    return dvec2(fma(a.x, b.x, -a.y * b.y), fma(a.x, b.y, a.y * b.x));
}

dvec3 grid_centre(dvec2 px) {
    double xi = fma(px.y, u_grid[1], u_grid[0]);
    double eta = fma(px.x, u_grid[3], u_grid[2]);
    double s, c;
    fp64_sin_cos(xi, s, c);
    double e = fp64_exp(2.0LF * abs(eta));
    double ei = fp64_recip(e);
    double ch = 0.5LF * (e + ei);                   // cosh(2 eta)
    double sh = sign(eta) * (0.5LF * (e - ei));     // sinh(2 eta)
    double s2 = 2.0LF * s * c;                      // sin(2 xi)
    double c2 = (c - s) * (c + s);                  // cos(2 xi)
    dvec2 sin2z = dvec2(s2 * ch, c2 * sh);          // sin(2 zeta)
    dvec2 r = dvec2(2.0LF * c2 * ch, -2.0LF * s2 * sh);  // 2 cos(2 zeta)
    dvec2 y1 = dvec2(0.0LF);
    dvec2 y2 = dvec2(0.0LF);
    for (int k = 10; k >= 6; --k) {
        dvec2 y0 = dvec2(u_grid[k], 0.0LF) + fp64_cmul(r, y1) - y2;
        y2 = y1;
        y1 = y0;
    }
    dvec2 dz = fp64_cmul(y1, sin2z);
    xi += dz.x;
    eta += dz.y;
    fp64_sin_cos(xi, s, c);
    double t = fp64_exp(-abs(eta));                 // e^-|eta'|
    double w = fp64_recip(fma(t, t, 1.0LF));
    double sech = 2.0LF * t * w;
    double th = sign(eta) * (fma(-t, t, 1.0LF) * w);
    double m = c * sech;
    double qx = fma(u_grid[4], m, -u_grid[5] * th);
    double qy = fma(u_grid[5], m, u_grid[4] * th);
    double sz = s * sech;                           // sin(chi)
    double c2c = fma(qx, qx, qy * qy);              // cos^2(chi)
    double g = u_grid[15];
    g = fma(g, c2c, u_grid[14]);
    g = fma(g, c2c, u_grid[13]);
    g = fma(g, c2c, u_grid[12]);
    g = fma(g, c2c, u_grid[11]);
    return fp64_geodetic(qx, qy, sz, c2c, g);
}
