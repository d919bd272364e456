#version 450
// Lens flare, step 5 (only for a lens with Walch's fitted ghosts): the fitted sprites' light
// added to the tiles they cross (ghost_sprites.comp added their light to the tiles they cover).
// One invocation per 16x16 tile, no shared memory and no barrier: the invocation goes through
// its tile's crossing fitted sprites in sprite order; searches each one's distance at the
// tile's five nodes (fitted_ghost.glsl); adds the smooth ones' corner light to four sums; and
// shades each of the others by blocks (the tile, its quarters, theirs; pixels searched one by
// one where a 4 px block is still not near linear), every search in one loop. The smooth sums are added last, in one
// sweep of the tile.
// Why one invocation per tile (src/passes/flare/fitted_ghosts.rs has the measurements): inside
// ghost_sprites' 256-invocation groups, the search's code made that whole kernel 2-5x slower
// on lavapipe, whether it ran or not.
#include "common.glsl"
#include "flare.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0, rgba32f) uniform image2D color;   // the light added in place
layout(binding = 1, std430) readonly buffer FlareParams { FlareConstants fc; };
layout(binding = 2, std430) readonly buffer FlareSprites { float sprite_data[]; };
layout(binding = 3, std430) readonly buffer FlareArgs { uint args[]; };
layout(binding = 4, std430) readonly buffer FlareBins { uint bins[]; };

// size: the image (a band of the frame from fc.band_top_px); words_per_tile: the bin words of
// one tile.
layout(push_constant) uniform Push { ivec2 size; int words_per_tile; } pc;

#include "fitted_ghost.glsl"

// `add` added to pixel p (whole-frame coordinates) of the image, where the band holds it.
void add_light(ivec2 p, vec3 add) {
    ivec2 texel = p - ivec2(0, fc.band_top_px);
    if (outside(texel, pc.size)) return;
    vec4 c = finite_or_zero(imageLoad(color, texel));
    imageStore(color, texel, vec4(c.rgb + add, c.a));
}

// The light of sprite base b (of colour `colour`) over the n-px block at `at`, its distance
// interpolated from the nodes `g`.
void add_interpolated(uint b, ivec2 at, int n, float g[FITTED_NODES], vec3 colour) {
    for (int y = 0; y < n; ++y) {
        for (int x = 0; x < n; ++x) {
            add_light(at + ivec2(x, y), fitted_transfer(b, fitted_interpolated(g, vec2(x, y), n)) * colour);
        }
    }
}

// The blocks still to shade, depth first: the tile, then quarters of blocks not near linear
// (at most 3 + 3 waiting), then a 4 px block's pixels (`n` negative: searched one by one).
#define FITTED_STACK 8
#define FITTED_PIXELS (FITTED_SMALLEST_BLOCK * FITTED_SMALLEST_BLOCK)

// The light of sprite base b (of colour `colour`) over the tile at `origin`: added to `corners`
// (the tile's corner pixels) where smooth (then returns true), else block by block. Every distance is searched in
// one loop (one copy of the search in the pipeline: unrolled at each place it is called, it
// made the pipeline's first compile on lavapipe take 5.8 s).
bool shade_sprite(uint b, ivec2 origin, vec3 colour, inout vec3 corners[4]) {
    ivec3 stack[FITTED_STACK];
    int depth = 0;
    stack[depth++] = ivec3(origin, TILE_SIZE);
    while (depth > 0) {
        ivec3 block = stack[--depth];
        ivec2 at = block.xy;
        int n = block.z;
        bool pixels = n < 0;
        int count = pixels ? FITTED_PIXELS : FITTED_NODES;
        float d[FITTED_PIXELS];
        for (int j = 0; j < count; ++j) {
            vec2 q = pixels ? vec2(at + ivec2(j % FITTED_SMALLEST_BLOCK, j / FITTED_SMALLEST_BLOCK)) + 0.5
                            : fitted_node(vec2(at) + 0.5, n, j);
            d[j] = fitted_distance(b, q);
        }
        if (pixels) {
            for (int j = 0; j < FITTED_PIXELS; ++j) {
                add_light(at + ivec2(j % FITTED_SMALLEST_BLOCK, j / FITTED_SMALLEST_BLOCK), fitted_transfer(b, d[j]) * colour);
            }
            continue;
        }
        float g[FITTED_NODES] = float[FITTED_NODES](d[0], d[1], d[2], d[3], d[4]);
        if (n == TILE_SIZE && fitted_smooth(b, g)) {
            for (int j = 0; j < 4; ++j) corners[j] += fitted_transfer(b, g[j]) * colour;
            return true;
        } else if (fitted_linear(g)) {
            add_interpolated(b, at, n, g, colour);
        } else if (n > FITTED_SMALLEST_BLOCK) {
            for (int k = 3; k >= 0; --k) stack[depth++] = ivec3(at + (n / 2) * ivec2(k & 1, k >> 1), n / 2);
        } else {
            stack[depth++] = ivec3(at, -n);
        }
    }
    return false;
}

void main() {
    // The tile in the whole frame's coordinates: the band's tile rows from fc.band_top_px.
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (t.x >= fc.tiles_x || t.y * TILE_SIZE >= pc.size.y) return;
    ivec2 tile = t + ivec2(0, fc.band_top_px / TILE_SIZE);
    ivec2 origin = tile * TILE_SIZE;
    uint base = (uint(tile.y) * uint(fc.tiles_x) + uint(tile.x)) * uint(pc.words_per_tile);
    uint slots = uint(fc.slots_per_light);
    // The smooth sprites' light at the tile's corner pixels, summed in sprite order.
    vec3 corners[4] = vec3[4](vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0));
    bool smooth_any = false;
    for (uint l = 0; l < args[ARGS_LIGHTS]; ++l) {
        for (uint k = 0; k < uint(fc.fitted_count); ++k) {
            uint s = l * slots + uint(fc.ghost_count) + k;
            uint word = base + s / BIN_SPRITES_PER_WORD;
            // The crossing channels' bits (covering ones are ghost_sprites' I_i).
            if (((bins[word] >> (8u * (s % BIN_SPRITES_PER_WORD))) & 7u) == 0u) continue;
            uint b = s * SPRITE_WORDS;
            uint c = b + SPRITE_DATA + BEZIER_COLOUR;
            vec3 colour = vec3(sprite_data[c], sprite_data[c + 1], sprite_data[c + 2]);
            if (shade_sprite(b, origin, colour, corners)) smooth_any = true;
        }
    }
    if (!smooth_any) return;
    for (int y = 0; y < TILE_SIZE; ++y) {
        for (int x = 0; x < TILE_SIZE; ++x) {
            vec2 f = vec2(x, y) / float(TILE_SIZE - 1);
            add_light(origin + ivec2(x, y), mix(mix(corners[0], corners[1], f.x), mix(corners[2], corners[3], f.x), f.y));
        }
    }
}
