#include "lib/precise.glsl"
// lonlat_offset: the vector p - c from a bin centre c to a point p, both on the unit
// sphere and given by latitude and longitude (equirectangular and mercator grids),
// without cancellation.
//   cs_phi = (cos, sin) of the latitude of c, cs_lam = (cos, sin) of its longitude;
//   dphi, dlam: latitude and longitude of p minus those of c (radians, small).
// Returns p - c (unit-sphere coordinates, Earth frame: x to 0N 0E, z to the north
// pole) with relative accuracy of a few float32 ulp of |p - c|: only differences of
// cosines and sines enter, never the full coordinates.
vec3 lonlat_offset(vec2 cs_phi, vec2 cs_lam, float dphi, float dlam) {
    float s1 = precise_sin(dphi);
    float c1m = -precise_versin(dphi);           // cos(dphi) - 1
    float s2 = precise_sin(dlam);
    float c2m = -precise_versin(dlam);
    float dcphi = cs_phi.x * c1m - cs_phi.y * s1;  // cos(phi) - cos(phi_c)
    float dsphi = cs_phi.y * c1m + cs_phi.x * s1;  // sin(phi) - sin(phi_c)
    float dclam = cs_lam.x * c2m - cs_lam.y * s2;
    float dslam = cs_lam.y * c2m + cs_lam.x * s2;
    return vec3(
        cs_phi.x * dclam + dcphi * cs_lam.x + dcphi * dclam,
        cs_phi.x * dslam + dcphi * cs_lam.y + dcphi * dslam,
        dsphi);
}
