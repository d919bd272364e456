#version 450
// Tiled depth of field, step 1: the signed CoC range of every 16x16 tile.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, r32f) uniform readonly image2D coc_px;
layout(binding = 1, std430) writeonly buffer TileCoc { vec2 tile_coc[]; }; // (min, max) signed CoC px

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
} pc;

shared float s_min[TILE_SIZE * TILE_SIZE];
shared float s_max[TILE_SIZE * TILE_SIZE];

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint i = gl_LocalInvocationIndex;
    float c = outside(p, pc.size) ? 0.0 : imageLoad(coc_px, p).r;
    bool valid = !outside(p, pc.size);
    s_min[i] = valid ? c : 3.0e38;
    s_max[i] = valid ? c : -3.0e38;
    barrier();
    for (uint stride = TILE_SIZE * TILE_SIZE / 2; stride > 0; stride >>= 1) {
        if (i < stride) {
            s_min[i] = min(s_min[i], s_min[i + stride]);
            s_max[i] = max(s_max[i], s_max[i + stride]);
        }
        barrier();
    }
    if (i == 0) {
        ivec2 t = ivec2(gl_WorkGroupID.xy);
        tile_coc[t.y * pc.tiles.x + t.x] = vec2(s_min[0], s_max[0]);
    }
}
