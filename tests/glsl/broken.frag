#version 430
#include "lib/precise.glsl"
out vec4 o_out;
void main() {
    o_out = vec4(precise_sin(1.0), undefined_name, 0.0, 1.0);
}
