#version 430
// An orthographic globe drawn from cube maps in one pass: each pixel of the disc is a
// direction in the Earth frame (x to 0N 0E, z to the north pole), which samples the
// cube-map masks of the offset region and of the input (GL cube-map face selection,
// as gloffset writes its faces), then graticule and shading on top.
uniform samplerCube u_region;   // r > 0.5: inside the region within the distance
uniform samplerCube u_input;    // r > 0.5: the input (its polygons, its lines drawn thin)
uniform mat3 u_frame;           // columns: east, north, centre of the view (Earth frame)
uniform vec2 u_size;            // the image in pixels
uniform vec4 u_background;      // outside the disc
uniform vec4 u_ocean;           // the sphere
uniform vec4 u_input_color;     // the input
uniform vec4 u_fill;            // the region, alpha-blended over the sphere and the input
uniform vec4 u_grid_color;      // graticule lines
uniform float u_grid_step;      // graticule spacing in degrees; 0: none
uniform float u_shading;        // 0: flat, 1: full Lambert shading towards the viewer
out vec4 o_color;

const float PI = 3.14159265358979;

float grid_line(float v, float step) {
    // distance in pixels to the nearest multiple of step, for lines one pixel wide
    float w = max(fwidth(v), 1e-6);
    float d = abs(v - step * round(v / step));
    return 1.0 - clamp(d / w - 0.5, 0.0, 1.0);
}

void main() {
    vec2 q = gl_FragCoord.xy / u_size * 2.0 - 1.0;
    float r2 = dot(q, q);
    if (r2 > 1.0) {
        o_color = u_background;
        return;
    }
    vec3 local = vec3(q, sqrt(1.0 - r2));
    vec3 dir = normalize(u_frame * local);
    vec3 color = u_ocean.rgb;
    if (texture(u_input, dir).r > 0.5) {
        color = u_input_color.rgb;
    }
    if (texture(u_region, dir).r > 0.5) {
        color = mix(color, u_fill.rgb, u_fill.a);
    }
    if (u_grid_step > 0.0) {
        float lon = degrees(atan(dir.y, dir.x));
        float lat = degrees(asin(clamp(dir.z, -1.0, 1.0)));
        // meridians stop short of the poles, where they would crowd
        float meridian = grid_line(lon, u_grid_step) * step(abs(lat), 90.0 - u_grid_step * 0.5);
        float line = max(meridian, grid_line(lat, u_grid_step));
        color = mix(color, u_grid_color.rgb, u_grid_color.a * line);
    }
    color *= 1.0 - u_shading + u_shading * (0.35 + 0.65 * local.z);
    o_color = vec4(color, 1.0);
}
