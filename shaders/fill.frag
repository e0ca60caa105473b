#version 430
// The "fill floor": one trivial pass over the output, what any renderer must pay.
out uint o_class;
void main() {
    o_class = uint(gl_FragCoord.x) & 1u;
}
