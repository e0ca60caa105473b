#version 430
// The lists of a distance field's walk (shaders/field_walk.comp), each written in chunks of
// its pool, gathered into one array by cell (gloffset/gl/walk_pass.py): one invocation per
// cell of u_id copies its count ids, from its first chunk on, to its start (the counts'
// prefix sum, from the host). A list is no longer than its walk's steps (at most u_max_steps),
// so the loop stays within llvmpipe's iterations.
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Cells { uvec2 u_cell[]; };  // first chunk, count
layout(std430, binding = 1) readonly buffer Start { uvec2 u_start[]; };  // cell, start
layout(std430, binding = 2) readonly buffer Pool { uint u_pool[]; };
layout(std430, binding = 3) writeonly buffer Out { uint o_id[]; };

uniform uint u_cells;
uniform uint u_chunk;  // ids a chunk (then the start of the next chunk)

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= u_cells) {
        return;
    }
    uvec2 cs = u_start[k];
    uvec2 fc = u_cell[cs.x];
    uint to = cs.y;
    uint at = fc.x;
    uint pi = 0u;
    for (uint e = 0u; e < fc.y; ++e) {
        o_id[to + e] = u_pool[at];
        ++at;
        ++pi;
        if (pi == u_chunk && e + 1u < fc.y) {
            at = u_pool[at];
            pi = 0u;
        }
    }
}
