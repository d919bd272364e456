#version 450
// The ghost-sprite kernel: every flare sprite (a ghost's aperture polygon, a starburst spike, a
// glow) added to the frame, each output pixel written once whatever the number of sprites (the
// fill rate of integrated GPUs). One workgroup per 16x16 tile, reading its tile's bin words
// (flare_bins.comp sorted every sprite against the tiles its bounds touch): invocations 0-2 sum
// the covering channels once (in sprite order: the same bits every run), invocation 0 lists
// the crossing sprites by kind (in batches where they may be more than a list holds), every
// pixel shades the lists (each pixel decoding the bin words itself measured 2.7x slower on
// lavapipe at 16 lights). The light's own pixels give up the share of their light its
// starburst and halo took. The flare is added to the colour in place: each pixel is read and
// written by its own invocation only, and a frame without a light dispatches no group and
// keeps its colour untouched (no copy).
// Walch's fitted primitives (ch. 6-8) are binned like the others: here each adds I_i once to
// the tiles it covers; fitted_ghosts.comp shades the tiles they cross (kind 3 is never listed).
#include "common.glsl"
#include "flare.glsl"
// Only aperture_sdf is used: the mask and shape-table bindings are declared, never read.
#define APERTURE_MASK_BINDING 7
#define APERTURE_SHAPE_BINDING 8
#include "aperture.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform image2D color;   // the flare added in place
layout(binding = 1, std430) readonly buffer FlareParams { FlareConstants fc; };
layout(binding = 2, std430) readonly buffer FlareTiles { float tile_data[]; };
layout(binding = 3, std430) readonly buffer FlareLights { float light_data[]; };
layout(binding = 4, std430) readonly buffer FlareSprites { float sprite_data[]; };
layout(binding = 5, std430) readonly buffer FlareArgs { uint args[]; };
layout(binding = 6, std430) readonly buffer FlareBins { uint bins[]; };

// size: the image; words_per_tile: the bin words of one tile.
layout(push_constant) uniform Push { ivec2 size; int words_per_tile; } pc;

#include "ghost_sprite.glsl"

// Specialization constants (src/passes/flare/ghost_sprites.rs `specialization`; 0 and 1 are
// aperture.glsl's): whether the frame has ghost sprites and spike sprites. A pipeline without
// them has no loop for them, whose body lavapipe would run once per batch even with none listed.
layout(constant_id = 2) const bool SPRITE_GHOSTS = true;
layout(constant_id = 3) const bool SPRITE_SPIKES = true;
// Whether a tile's sprites may be more than one list holds (SPRITE_LIST per kind): then they
// are listed and shaded in batches. Without, there is no loop around the barriers and the
// shading: with it, the kernel took 1.8x as long on lavapipe with the Tessar's ghosts in frame,
// and 1.1x where no light was found and the loop never ran.
layout(constant_id = 4) const bool SPRITE_BATCHES = true;
// Whether the frame has fitted sprites (Walch's primitives): their covering light.
layout(constant_id = 5) const bool SPRITE_FITTED = true;

#define GROUP (TILE_SIZE * TILE_SIZE)
shared float s_covering[3];
// The crossing sprites (of a batch) by kind (0 ghosts, 1 spikes, 2 glows), in sprite order.
shared uint s_list[3][SPRITE_LIST];
shared uint s_listed[3];

// The spike's light in the pixel square lo..lo+1, channel by channel.
vec3 spike_light(uint b, vec2 lo) {
    uint d = b + SPRITE_DATA;
    vec2 t = ray_in_box(vec2(sprite_data[d], sprite_data[d + 1]), vec2(sprite_data[d + 2], sprite_data[d + 3]),
                        sprite_data[d + 4], sprite_data[d + 5], lo, lo + 1.0);
    if (t.y <= t.x) return vec3(0.0);
    return vec3(sprite_data[d + 6], sprite_data[d + 7], sprite_data[d + 8]) * (1.0 / t.x - 1.0 / t.y);
}

vec3 glow_light(uint b, vec2 q) {
    uint d = b + SPRITE_DATA;
    float r = distance(q, vec2(sprite_data[d], sprite_data[d + 1]));
    if (r < sprite_data[d + 2] || r > sprite_data[d + 3]) return vec3(0.0);
    vec3 diffraction = vec3(sprite_data[d + 4], sprite_data[d + 5], sprite_data[d + 6]) / (r * r * r);
    float rho = sprite_data[d + 10];
    // (1 + r^2/rho^2)^-1.5 as x sqrt(x).
    float x = rho > 0.0 ? 1.0 / (1.0 + r * r / (rho * rho)) : 0.0;
    vec3 halo = vec3(sprite_data[d + 7], sprite_data[d + 8], sprite_data[d + 9]) * (x * sqrt(x));
    return diffraction + halo;
}

// Invocation 0 lists the crossing sprites of the tile's bin words first .. last - 1 (at most
// SPRITE_LIST sprites) by kind, in sprite order; the fitted ones are fitted_ghosts.comp's.
void list_sprites(uint base, uint first, uint last) {
    if (gl_LocalInvocationIndex == 0u) {
        uint n[3] = uint[3](0u, 0u, 0u);
        for (uint w = first; w < last; ++w) {
            uint cross = bins[base + w] & 0x07070707u;
            while (cross != 0u) {
                uint k = uint(findLSB(cross)) / 8u;
                uint s = w * BIN_SPRITES_PER_WORD + k;
                int kind = int(sprite_data[s * SPRITE_WORDS + SPRITE_KIND]);
                uint list = kind == KIND_GHOST ? 0u : (kind == KIND_SPIKE ? 1u : 2u);
                if (kind != KIND_FITTED) s_list[list][n[list]++] = s | (((cross >> (8u * k)) & 7u) << 24);
                cross &= ~(0xFFu << (8u * k));
            }
        }
        for (uint k = 0; k < 3; ++k) s_listed[k] = n[k];
    }
}

// The listed sprites' light at pixel p (centre q) added to `sum`, one loop per kind: lavapipe
// runs both sides of every `if`, but leaves a loop no lane is still in (a branch on the kind
// would run all three per sprite).
void shade_listed(ivec2 p, vec2 q, inout vec3 sum) {
    for (uint i = 0; i < (SPRITE_GHOSTS ? s_listed[0] : 0u); ++i) {
        uint entry = s_list[0][i];
        uint b = (entry & 0xFFFFFFu) * SPRITE_WORDS;
        float ramp = sprite_data[b + SPRITE_SOFTNESS];
        // The crossing channels only (each costs an aperture distance), in channel order.
        for (uint channels = entry >> 24; channels != 0u; channels &= channels - 1u) {
            uint c = uint(findLSB(channels));
            float value = sprite_data[b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS + 3];
            sum[c] += value * clamp(0.5 - ghost_sdf(b, c, q) / ramp, 0.0, 1.0);
        }
    }
    for (uint i = 0; i < (SPRITE_SPIKES ? s_listed[1] : 0u); ++i) sum += spike_light((s_list[1][i] & 0xFFFFFFu) * SPRITE_WORDS, vec2(p));
    for (uint i = 0; i < s_listed[2]; ++i) sum += glow_light((s_list[2][i] & 0xFFFFFFu) * SPRITE_WORDS, q);
}

void main() {
    // Tiles and pixels in the whole frame's coordinates; the image holds the band of pc.size.y
    // rows from fc.band_top_px (the whole frame: 0), a multiple of TILE_SIZE, whose tile rows
    // the dispatch covers.
    ivec2 tile = ivec2(gl_WorkGroupID.xy) + ivec2(0, fc.band_top_px / TILE_SIZE);
    ivec2 origin = tile * TILE_SIZE;
    ivec2 p = origin + ivec2(gl_LocalInvocationID.xy);
    vec2 q = vec2(p) + 0.5;
    uint total = args[ARGS_LIGHTS] * uint(fc.slots_per_light);
    uint words = min((total + BIN_SPRITES_PER_WORD - 1) / BIN_SPRITES_PER_WORD, uint(pc.words_per_tile));
    uint base = (uint(tile.y) * uint(fc.tiles_x) + uint(tile.x)) * uint(pc.words_per_tile);
    vec3 sum = vec3(0.0);
    // The covering light, the same at every pixel: summed once per tile, invocation c summing
    // channel c in sprite order (the same bits as before the bins), shared after a barrier.
    // Only ghosts (matrix or fitted) cover a tile: without them, no walk over the bin words.
    if (gl_LocalInvocationIndex < 3u) {
        uint c = gl_LocalInvocationIndex;
        float acc = 0.0;
        for (uint w = 0; w < (SPRITE_GHOSTS || SPRITE_FITTED ? words : 0u); ++w) {
            uint bits = (bins[base + w] >> (BIN_COVERING_SHIFT + c)) & 0x01010101u;
            while (bits != 0u) {
                uint k = uint(findLSB(bits)) / 8u;
                bits &= bits - 1u;
                uint b = (w * BIN_SPRITES_PER_WORD + k) * SPRITE_WORDS;
                bool fitted = int(sprite_data[b + SPRITE_KIND]) == KIND_FITTED;
                acc += sprite_data[fitted ? b + SPRITE_INNER : b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS + 3];
            }
        }
        s_covering[c] = acc;
    }
    barrier();
    // The crossing sprites, listed by invocation 0 from the bins (in sprite order), then shaded
    // by every pixel from the lists; in batches of SPRITE_LIST sprites where they may be more.
    if (SPRITE_BATCHES) {
        for (uint first = 0; first < words; first += SPRITE_LIST / BIN_SPRITES_PER_WORD) {
            list_sprites(base, first, min(words, first + SPRITE_LIST / BIN_SPRITES_PER_WORD));
            barrier();
            shade_listed(p, q, sum);
            // Every pixel has read the lists before the next batch's replace them.
            barrier();
        }
    } else {
        list_sprites(base, 0u, words);
        barrier();
        shade_listed(p, q, sum);
    }
    ivec2 texel = p - ivec2(0, fc.band_top_px);
    if (outside(texel, pc.size)) return;
    vec4 c = finite_or_zero(imageLoad(color, texel));
    // The light's own pixels give up what its starburst and halo took.
    int light = int(tile_data[(uint(tile.y) * uint(fc.tiles_x) + uint(tile.x)) * TILE_WORDS + TILE_LIGHT]);
    if (light >= 0 && max(c.r, max(c.g, c.b)) >= fc.threshold) {
        uint lb = uint(light) * LIGHT_WORDS + LIGHT_MOVED;
        c.rgb *= vec3(1.0) - vec3(light_data[lb], light_data[lb + 1], light_data[lb + 2]);
    }
    imageStore(color, texel, vec4(c.rgb + vec3(s_covering[0], s_covering[1], s_covering[2]) + sum, c.a));
}
