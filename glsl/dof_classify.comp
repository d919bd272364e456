#version 450
// Tiled depth of field, step 2: how far the gather of each tile must reach (the largest CoC
// radius of any tile near enough to cover part of it: dilation), and the tile's class, appended
// to that class's list with the indirect dispatch counts.
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = 64) in;
layout(binding = 0, std430) readonly buffer TileCoc { vec2 tile_coc[]; };
layout(binding = 1, std430) buffer Args { uint args[]; };
layout(binding = 2, std430) writeonly buffer TileLists { uint tile_list[]; }; // CLASS_COUNT lists of tile_count
// [0, tile_count): the gather radius; [tile_count, 2 tile_count): the largest radius of a
// foreground sample (in front of the focus plane) that reaches the tile.
layout(binding = 3, std430) writeonly buffer TileRadius { float tile_radius_px[]; };

layout(push_constant) uniform Push {
    ivec2 tiles;
    int search_tiles;        // neighbours searched in each direction (max CoC radius / tile + 1)
    float small_radius_px;   // gather radius up to which a tile uses the exact full-res gather
} pc;

void main() {
    int t = int(gl_GlobalInvocationID.x);
    int tile_count = pc.tiles.x * pc.tiles.y;
    if (t == 0) {
        for (int c = 0; c < CLASS_COUNT; ++c) {
            args[ARGS_DISPATCH(c) + 1] = 1u;
            args[ARGS_DISPATCH(c) + 2] = 1u;
        }
    }
    if (t >= tile_count) return;
    ivec2 tc = ivec2(t % pc.tiles.x, t / pc.tiles.x);
    float radius = 0.0, fg_radius = 0.0;
    for (int dy = -pc.search_tiles; dy <= pc.search_tiles; ++dy) {
        for (int dx = -pc.search_tiles; dx <= pc.search_tiles; ++dx) {
            ivec2 n = tc + ivec2(dx, dy);
            if (outside(n, pc.tiles)) continue;
            vec2 range = tile_coc[n.y * pc.tiles.x + n.x];
            float r_n = 0.5 * max(abs(range.x), abs(range.y));
            // Gap in pixels between the two tiles' rectangles.
            vec2 gap = vec2(max(abs(dx) - 1, 0), max(abs(dy) - 1, 0)) * float(TILE_SIZE);
            if (r_n + 1.0 > length(gap)) radius = max(radius, r_n);
            float fg_n = range.x < 0.0 ? -0.5 * range.x : 0.0;
            if (fg_n + 1.0 > length(gap)) fg_radius = max(fg_radius, fg_n);
        }
    }
    int cls = radius <= 0.5 ? CLASS_COPY : (radius <= pc.small_radius_px ? CLASS_SMALL : CLASS_LARGE);
    tile_radius_px[t] = radius;
    tile_radius_px[tile_count + t] = fg_radius;
    uint slot = atomicAdd(args[ARGS_DISPATCH(cls)], 1u);
    tile_list[cls * tile_count + int(slot)] = uint(t);
}
