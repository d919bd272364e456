#version 450
// Lens flare, step 3: the sprites binned to tiles, once per frame. One workgroup per sprite;
// its invocations walk the tiles its bounds touch and sort it against each (ghost_sprite.glsl's
// sprite_bin: away, covering or crossing, channel by channel), OR-ing its byte into the tile's
// bin words (cleared before). OR is order-free, so the bins are the same every run, and
// ghost_sprites reads them in sprite order: the same sums every run, no per-tile sorting.
#include "common.glsl"
#include "flare.glsl"
// Only aperture_sdf is used: the mask and shape-table bindings are declared, never read.
#define APERTURE_MASK_BINDING 4
#define APERTURE_SHAPE_BINDING 5
#include "aperture.glsl"

#define GROUP 64

layout(local_size_x = GROUP) in;
layout(binding = 0, std430) readonly buffer FlareParams { FlareConstants fc; };
layout(binding = 1, std430) readonly buffer FlareSprites { float sprite_data[]; };
layout(binding = 2, std430) readonly buffer FlareArgs { uint args[]; };
layout(binding = 3, std430) buffer FlareBins { uint bins[]; };

// words_per_tile: the bin words of one tile (the most sprites / BIN_SPRITES_PER_WORD).
layout(push_constant) uniform Push { int words_per_tile; } pc;

#include "ghost_sprite.glsl"

void main() {
    uint s = gl_WorkGroupID.x;
    uint total = args[ARGS_LIGHTS] * uint(fc.slots_per_light);
    if (s >= total || s / BIN_SPRITES_PER_WORD >= uint(pc.words_per_tile)) return;
    uint b = s * SPRITE_WORDS;
    vec4 box = vec4(sprite_data[b], sprite_data[b + 1], sprite_data[b + 2], sprite_data[b + 3]);
    if (!(box.x <= box.z) || !(box.y <= box.w)) return;
    // The tiles the bounds touch (sprite_bin tests each exactly; this only narrows the walk).
    // Clamped as floats first: the bounds may be far off the frame.
    vec2 last = vec2(fc.tiles_x - 1, fc.tiles_y - 1);
    ivec2 lo = ivec2(clamp(floor(box.xy / float(TILE_SIZE)), vec2(0.0), last));
    ivec2 hi = ivec2(clamp(floor(box.zw / float(TILE_SIZE)), vec2(0.0), last));
    int span = hi.x - lo.x + 1;
    int count = span * (hi.y - lo.y + 1);
    uint word = s / BIN_SPRITES_PER_WORD;
    uint shift = 8u * (s % BIN_SPRITES_PER_WORD);
    for (int k = int(gl_LocalInvocationIndex); k < count; k += GROUP) {
        ivec2 tile = lo + ivec2(k % span, k / span);
        uint mode = sprite_bin(s, tile * TILE_SIZE);
        if (mode != 0u) {
            atomicOr(bins[uint(tile.y * fc.tiles_x + tile.x) * uint(pc.words_per_tile) + word], mode << shift);
        }
    }
}
