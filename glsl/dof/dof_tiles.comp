#version 450
// Tiled depth of field, step 1: the signed CoC range of every 16x16 tile. One invocation per
// tile walks its pixels (no shared memory, no barrier: a CPU Vulkan driver runs invocations with
// barriers as coroutines, which costs more than the whole reduction).
#include "common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0, r32f) uniform readonly image2D coc_px;
layout(binding = 1, std430) writeonly buffer TileCoc { vec2 tile_coc[]; }; // (min, max) signed CoC px

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
} pc;

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (outside(t, pc.tiles)) return;
    ivec2 origin = t * TILE_SIZE;
    ivec2 end = min(origin + TILE_SIZE, pc.size);
    float lo = 3.0e38, hi = -3.0e38;
    for (int y = origin.y; y < end.y; ++y) {
        for (int x = origin.x; x < end.x; ++x) {
            float c = imageLoad(coc_px, ivec2(x, y)).r;
            lo = min(lo, c);
            hi = max(hi, c);
        }
    }
    tile_coc[t.y * pc.tiles.x + t.x] = vec2(lo, hi);
}
