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

// Whether the frame has ghost sprites and fitted sprites (flare_lights made none of a kind the
// lens lacks): a pipeline without a kind has none of its test's code, which on lavapipe is
// compiled at the first dispatch (the demo's cold flare_bins 0.47 s).
layout(constant_id = 2) const bool BIN_GHOSTS = true;
layout(constant_id = 3) const bool BIN_FITTED = true;

// Sprite `s` against the tile at `origin`: its bin byte (bits 0-2 crossing channels, bits 3-5
// covering channels, 0: away from it, its bounds or a ghost channel whose edge lies more than
// the tile's half-diagonal plus half the ramp from the tile's centre, outward).
uint sprite_bin(uint s, ivec2 origin) {
    uint b = s * SPRITE_WORDS;
    vec4 box = vec4(sprite_data[b], sprite_data[b + 1], sprite_data[b + 2], sprite_data[b + 3]);
    bool meets = box.x <= box.z && box.x < float(origin.x + TILE_SIZE) && box.z >= float(origin.x)
        && box.y < float(origin.y + TILE_SIZE) && box.w >= float(origin.y);
    if (!meets) return 0u;
    int kind = int(sprite_data[b + SPRITE_KIND]);
    if (BIN_GHOSTS && kind == KIND_GHOST) {
        vec2 tile_centre = vec2(origin) + 0.5 * float(TILE_SIZE);
        float half_ramp = 0.5 * sprite_data[b + SPRITE_SOFTNESS];
        uint mode = 0u;
        for (uint c = 0; c < 3; ++c) {
            float value = sprite_data[b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS + 3];
            if (value <= 0.0) continue;
            float d = ghost_sdf(b, c, tile_centre);
            if (d <= -(TILE_REACH + half_ramp)) {
                mode |= 1u << (c + BIN_COVERING_SHIFT);
            } else if (d < TILE_REACH + half_ramp) {
                mode |= 1u << c;
            }
        }
        return mode;
    } else if (kind == KIND_SPIKE) {
        uint d = b + SPRITE_DATA;
        vec2 t = ray_in_box(vec2(sprite_data[d], sprite_data[d + 1]), vec2(sprite_data[d + 2], sprite_data[d + 3]),
                            sprite_data[d + 4], sprite_data[d + 5], vec2(origin), vec2(origin + TILE_SIZE));
        return t.y > t.x ? 7u : 0u;
    } else if (kind == KIND_GLOW) {
        return 7u;
    }
    // A fitted sprite: its channels; the same light I_i at every pixel past F_i inside, none
    // past F_o outside (eq 6.4's fades end there). A loop, not an `if`: lavapipe runs both sides
    // of an `if` (the search for every sprite), but skips a loop no lane enters.
    uint mode = 0u;
    for (bool fitted = BIN_FITTED && kind == KIND_FITTED; fitted; fitted = false) {
        uint w = b + SPRITE_DATA;
        uint channels = 0u;
        for (uint c = 0; c < 3; ++c) {
            if (sprite_data[w + BEZIER_COLOUR + c] > 0.0) channels |= 1u << c;
        }
        float d = fitted_distance(b, vec2(origin) + 0.5 * float(TILE_SIZE));
        float reach = TILE_REACH + FITTED_MARGIN;
        mode = d >= sprite_data[w + BEZIER_TRANSFER + 2] + reach ? channels << BIN_COVERING_SHIFT
             : (d <= -(sprite_data[w + BEZIER_TRANSFER + 3] + reach) ? 0u : channels);
    }
    return mode;
}

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
