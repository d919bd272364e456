#version 450
// The ghost-sprite kernel: every flare sprite (a ghost's aperture polygon, a starburst spike, a
// glow) added to the frame, each output pixel written once whatever the number of sprites (the
// fill rate of integrated GPUs). One workgroup per 16x16 tile, reading its tile's bin words
// (flare_bins.comp sorted every sprite against the tiles its bounds touch): invocations 0-2 sum
// the covering channels once (in sprite order: the same bits every run), invocation 0 lists
// the crossing sprites in batches of 256, every pixel shades the list (each pixel decoding the
// bin words itself measured 2.7x slower on lavapipe at 16 lights). The light's own pixels give
// up the share of their light its starburst and halo took.
// A later primitive (Walch's fitted Bezier ghosts) is one more kind here.
#include "common.glsl"
#include "flare.glsl"
// Only aperture_sdf is used: the mask and shape-table bindings are declared, never read.
#define APERTURE_MASK_BINDING 8
#define APERTURE_SHAPE_BINDING 9
#include "aperture.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
layout(binding = 2, std430) readonly buffer FlareParams { FlareConstants fc; };
layout(binding = 3, std430) readonly buffer FlareTiles { float tile_data[]; };
layout(binding = 4, std430) readonly buffer FlareLights { float light_data[]; };
layout(binding = 5, std430) readonly buffer FlareSprites { float sprite_data[]; };
layout(binding = 6, std430) readonly buffer FlareArgs { uint args[]; };
layout(binding = 7, std430) readonly buffer FlareBins { uint bins[]; };

// size: the image; words_per_tile: the bin words of one tile.
layout(push_constant) uniform Push { ivec2 size; int words_per_tile; } pc;

#include "ghost_sprite.glsl"

#define GROUP (TILE_SIZE * TILE_SIZE)
shared float s_covering[3];
shared uint s_list[GROUP];
shared uint s_listed;

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

void main() {
    ivec2 tile = ivec2(gl_WorkGroupID.xy);
    ivec2 origin = tile * TILE_SIZE;
    ivec2 p = origin + ivec2(gl_LocalInvocationID.xy);
    vec2 q = vec2(p) + 0.5;
    uint total = args[ARGS_LIGHTS] * uint(fc.slots_per_light);
    uint words = min((total + BIN_SPRITES_PER_WORD - 1) / BIN_SPRITES_PER_WORD, uint(pc.words_per_tile));
    uint base = (uint(tile.y) * uint(fc.tiles_x) + uint(tile.x)) * uint(pc.words_per_tile);
    vec3 sum = vec3(0.0);
    // The covering light, the same at every pixel: summed once per tile, invocation c summing
    // channel c in sprite order (the same bits as before the bins), shared after a barrier.
    if (gl_LocalInvocationIndex < 3u) {
        uint c = gl_LocalInvocationIndex;
        float acc = 0.0;
        for (uint w = 0; w < words; ++w) {
            uint bits = (bins[base + w] >> (BIN_COVERING_SHIFT + c)) & 0x01010101u;
            while (bits != 0u) {
                uint k = uint(findLSB(bits)) / 8u;
                bits &= bits - 1u;
                acc += sprite_data[(w * BIN_SPRITES_PER_WORD + k) * SPRITE_WORDS + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS + 3];
            }
        }
        s_covering[c] = acc;
    }
    barrier();
    // The crossing sprites, listed in batches of up to GROUP by invocation 0 from the bins (in
    // sprite order), then shaded by every pixel from the list.
    for (uint first = 0; first < words; first += GROUP / BIN_SPRITES_PER_WORD) {
        barrier();
        if (gl_LocalInvocationIndex == 0u) {
            uint n = 0;
            for (uint w = first; w < min(words, first + GROUP / BIN_SPRITES_PER_WORD); ++w) {
                uint cross = bins[base + w] & 0x07070707u;
                while (cross != 0u) {
                    uint k = uint(findLSB(cross)) / 8u;
                    s_list[n++] = (w * BIN_SPRITES_PER_WORD + k) | (((cross >> (8u * k)) & 7u) << 24);
                    cross &= ~(0xFFu << (8u * k));
                }
            }
            s_listed = n;
        }
        barrier();
        uint listed = s_listed;
        for (uint i = 0; i < listed; ++i) {
            uint entry = s_list[i];
            uint b = (entry & 0xFFFFFFu) * SPRITE_WORDS;
            uint channels = entry >> 24;
            int kind = int(sprite_data[b + SPRITE_KIND]);
            if (kind == KIND_GHOST) {
                float ramp = sprite_data[b + SPRITE_SOFTNESS];
                for (uint c = 0; c < 3; ++c) {
                    if ((channels & (1u << c)) == 0u) continue;
                    float value = sprite_data[b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS + 3];
                    sum[c] += value * clamp(0.5 - ghost_sdf(b, c, q) / ramp, 0.0, 1.0);
                }
            } else if (kind == KIND_SPIKE) {
                sum += spike_light(b, vec2(p));
            } else {
                sum += glow_light(b, q);
            }
        }
    }
    if (outside(p, pc.size)) return;
    vec4 c = finite_or_zero(imageLoad(color_in, p));
    // The light's own pixels give up what its starburst and halo took.
    int light = int(tile_data[(uint(tile.y) * uint(fc.tiles_x) + uint(tile.x)) * TILE_WORDS + TILE_LIGHT]);
    if (light >= 0 && max(c.r, max(c.g, c.b)) >= fc.threshold) {
        uint lb = uint(light) * LIGHT_WORDS + LIGHT_MOVED;
        c.rgb *= vec3(1.0) - vec3(light_data[lb], light_data[lb + 1], light_data[lb + 2]);
    }
    imageStore(color_out, p, vec4(c.rgb + vec3(s_covering[0], s_covering[1], s_covering[2]) + sum, c.a));
}
