#version 450
// Motion blur, step 2: for every tile, the longest next and previous velocity among the tiles
// within `search_tiles` (McGuire et al. 2012, NeighborMax, widened to the longest blur): the
// directions and reach of the gather, and whether the tile is copied (nothing near it moves).
#include "common.glsl"

layout(local_size_x = 64) in;
layout(binding = 0, std430) readonly buffer TileMotion { vec4 tile_motion[]; };
layout(binding = 1, std430) writeonly buffer NeighborMotion { vec4 neighbor_motion[]; };

layout(push_constant) uniform Push {
    ivec2 tiles;
    int search_tiles;
} pc;

void main() {
    int t = int(gl_GlobalInvocationID.x);
    if (t >= pc.tiles.x * pc.tiles.y) return;
    ivec2 c = ivec2(t % pc.tiles.x, t / pc.tiles.x);
    vec4 best = vec4(0.0);
    vec2 best_len = vec2(-1.0);
    for (int dy = -pc.search_tiles; dy <= pc.search_tiles; ++dy) {
        for (int dx = -pc.search_tiles; dx <= pc.search_tiles; ++dx) {
            ivec2 n = c + ivec2(dx, dy);
            if (outside(n, pc.tiles)) continue;
            vec4 v = tile_motion[n.y * pc.tiles.x + n.x];
            precise float ln = v.x * v.x + v.y * v.y;
            precise float lp = v.z * v.z + v.w * v.w;
            if (ln > best_len.x) { best.xy = v.xy; best_len.x = ln; }
            if (lp > best_len.y) { best.zw = v.zw; best_len.y = lp; }
        }
    }
    neighbor_motion[t] = best;
}
