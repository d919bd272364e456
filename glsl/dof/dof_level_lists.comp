#version 450
// Tiled depth of field: which tiles each pyramid level gathers. A level's composite upsamples
// bilinearly, reaching a texel beyond its tile's own, so the level gathers its tiles and their
// eight neighbours (whatever their class): every texel a composite reads is then written, once,
// by the workgroup of the tile that holds it, with that tile's own radius. Each entry also says
// which of the tile's neighbours are of the level (dof_tiles.glsl). One invocation per
// tile; each level list grows the level gather's dispatch by a workgroup per
// GROUP_SIZE / (texels of a tile at the level) tiles.
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = 64) in;
layout(binding = 0, std430) buffer Args { uint args[]; };
layout(binding = 1, std430) readonly buffer TileRadius { float tile_radius_px[]; };
layout(binding = 2, std430) writeonly buffer LevelLists { uint level_list[]; }; // LEVELS lists of tile_count

layout(push_constant) uniform Push {
    ivec2 tiles;
} pc;

uint tiles_per_group(int level) {
    int side = TILE_SIZE >> level;
    return uint(GROUP_SIZE / (side * side));
}

void main() {
    int t = int(gl_GlobalInvocationID.x);
    int tile_count = pc.tiles.x * pc.tiles.y;
    if (t >= tile_count) return;
    ivec2 tc = ivec2(t % pc.tiles.x, t / pc.tiles.x);
    // Per level L (word L-1, bit (dy + 1) * 3 + dx + 1): the tile or a neighbour is of level L.
    uint near[LEVELS] = uint[LEVELS](0u, 0u, 0u, 0u);
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 n = tc + ivec2(dx, dy);
            if (outside(n, pc.tiles)) continue;
            int cls = int(tile_radius_px[2 * tile_count + n.y * pc.tiles.x + n.x]);
            if (cls >= CLASS_LEVEL1) near[cls - CLASS_LEVEL1] |= 1u << uint((dy + 1) * 3 + dx + 1);
        }
    }
    for (int level = 1; level <= LEVELS; ++level) {
        if (near[level - 1] == 0u) continue;
        uint slot = atomicAdd(args[ARGS_LEVEL_TILES(level)], 1u);
        level_list[(level - 1) * tile_count + int(slot)] = uint(t) | (near[level - 1] << LEVEL_LIST_TILE_BITS);
        if (slot % tiles_per_group(level) == 0u) atomicAdd(args[ARGS_LEVEL_GATHER(level)], 1u);
    }
}
