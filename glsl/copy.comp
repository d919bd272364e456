#version 450
// The bare pass: read every pixel of the frame and write it, nothing else. The benchmark's unit
// of cost: every pass's GPU time is also given as a multiple of this one, measured in the same
// run on the same device (src/passes/copy.rs).
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;

layout(push_constant) uniform Push { ivec2 size; } pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    imageStore(color_out, p, imageLoad(color_in, p));
}
