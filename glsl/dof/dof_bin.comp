#version 450
// Tiled depth of field: every sprite is listed in the bins of the tiles its disk (plus a pixel
// of rim) overlaps, so the composite shades each pixel with only the sprites that reach its
// tile. One invocation per sprite; the tiles it reaches are a few, whatever the number of
// sprites. Only level tiles are binned: a sprite comes from a pixel of large CoC, and every tile
// its disk reaches has a gather radius at least as large (dof_classify's dilation).
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = GROUP_SIZE) in;
layout(binding = 0, std430) buffer Args { uint args[]; };
layout(binding = 1, std430) readonly buffer Sprites { Sprite sprites[]; };
layout(binding = 2, std430) readonly buffer TileRadius { float tile_radius_px[]; };
layout(binding = 3, std430) buffer BinCounts { uint bin_count[]; };
layout(binding = 4, std430) writeonly buffer Bins { uint bin[]; };

layout(push_constant) uniform Push {
    ivec2 tiles;
    int sprite_capacity;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= min(args[ARGS_SPRITE_COUNT], uint(pc.sprite_capacity))) return;
    Sprite s = sprites[i];
    float r = 0.5 * abs(s.coc_px) + 1.0;
    ivec2 lo = max(ivec2(floor((s.centre_px - r) / float(TILE_SIZE))), ivec2(0));
    ivec2 hi = min(ivec2(floor((s.centre_px + r) / float(TILE_SIZE))), pc.tiles - 1);
    int tile_count = pc.tiles.x * pc.tiles.y;
    for (int ty = lo.y; ty <= hi.y; ++ty) {
        for (int tx = lo.x; tx <= hi.x; ++tx) {
            int t = ty * pc.tiles.x + tx;
            if (tile_radius_px[2 * tile_count + t] < float(CLASS_LEVEL1)) continue;
            uint n = atomicAdd(bin_count[t], 1u);
            if (n < uint(BIN_CAPACITY)) {
                bin[t * BIN_CAPACITY + int(n)] = i;
            } else if (n == uint(BIN_CAPACITY)) {
                atomicAdd(args[ARGS_BIN_OVERFLOWS], 1u);
            }
        }
    }
}
