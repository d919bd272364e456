#version 450
// Tiled depth of field: each tile's bin put in a fixed order. dof_bin appends sprites to bins
// with atomics, so their order changes from run to run, and with it the order in which
// dof_sprites adds their light: the output's last bits. Sorted by the sprites' centres
// (unique: one sprite per texel, dof_highlights), a tile sums its sprites in the same order on
// every run. One invocation per tile, an insertion sort: a bin holds at most BIN_CAPACITY
// entries and most hold none. A tile whose bin holds a sprite is appended to the list of
// sprite tiles, whose indirect dispatch (dof_sprites.comp) it counts.
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = GROUP_SIZE) in;
layout(binding = 0, std430) readonly buffer Sprites { Sprite sprites[]; };
layout(binding = 1, std430) readonly buffer BinCounts { uint bin_count[]; };
layout(binding = 2, std430) buffer Bins { uint bin[]; };
layout(binding = 3, std430) buffer Args { uint args[]; };
layout(binding = 4, std430) writeonly buffer TileLists { uint tile_list[]; };

layout(push_constant) uniform Push {
    int tile_count;
} pc;

// Whether sprite a's centre comes before sprite b's: by row, then by column.
bool before(uint a, uint b) {
    vec2 ca = sprites[a].centre_px, cb = sprites[b].centre_px;
    return ca.y < cb.y || (ca.y == cb.y && ca.x < cb.x);
}

void main() {
    int t = int(gl_GlobalInvocationID.x);
    if (t >= pc.tile_count) return;
    // dof_bin bins level tiles only: these are level tiles.
    if (bin_count[t] > 0u) {
        uint slot = atomicAdd(args[ARGS_SPRITE_TILES], 1u);
        tile_list[LIST_SPRITE_TILES * pc.tile_count + int(slot)] = uint(t);
    }
    // An overflowed bin is not read (dof_sprites then takes every sprite).
    uint n = bin_count[t] > uint(BIN_CAPACITY) ? 0u : bin_count[t];
    int base = t * BIN_CAPACITY;
    for (uint i = 1u; i < n; ++i) {
        uint entry = bin[base + int(i)];
        uint j = i;
        for (; j > 0u && before(entry, bin[base + int(j) - 1]); --j) {
            bin[base + int(j)] = bin[base + int(j) - 1];
        }
        bin[base + int(j)] = entry;
    }
}
