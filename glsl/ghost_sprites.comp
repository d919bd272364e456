#version 450
// The ghost-sprite kernel: every flare sprite (a ghost's aperture polygon, a starburst spike, a
// glow) added to the frame, each output pixel written once whatever the number of sprites (the
// fill rate of integrated GPUs). One workgroup per 16x16 tile:
//   - in batches of 256, each invocation sorts one sprite against the tile: away from it (its
//     bounds, or a ghost whose edge lies more than the tile's half-diagonal from the tile's
//     centre, outward), over all of it (a ghost channel whose edge lies that far inward: its
//     light is the same at every pixel, summed once for the tile), or across it (evaluated
//     per pixel). One invocation lists the crossing sprites and sums the covering ones in
//     sprite order: the same sums every run.
//   - every pixel adds the listed sprites; the light's own pixels give up the share of their
//     light its starburst and halo took.
// The shapes are convex with 1-Lipschitz distance functions (the polygon's edge distances, the
// clip circle's), so the tile's centre bounds every pixel of it.
// A later primitive (Walch's fitted Bezier ghosts) is one more kind here.
#include "common.glsl"
#include "flare.glsl"
// Only aperture_sdf is used: the mask and shape-table bindings are declared, never read.
#define APERTURE_MASK_BINDING 7
#define APERTURE_SHAPE_BINDING 8
#include "aperture.glsl"

#define GROUP (TILE_SIZE * TILE_SIZE)
// Half the diagonal of a tile's pixel centres.
#define TILE_REACH (0.5 * float(TILE_SIZE - 1) * 1.41421356)

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
layout(binding = 2, std430) readonly buffer FlareParams { FlareConstants fc; };
layout(binding = 3, std430) readonly buffer FlareTiles { float tile_data[]; };
layout(binding = 4, std430) readonly buffer FlareLights { float light_data[]; };
layout(binding = 5, std430) readonly buffer FlareSprites { float sprite_data[]; };
layout(binding = 6, std430) readonly buffer FlareArgs { uint args[]; };

layout(push_constant) uniform Push { ivec2 size; } pc;

shared uint s_mode[GROUP];
shared vec3 s_sum[GROUP];
shared uint s_list[GROUP];
shared uint s_listed;
shared vec3 s_tile;

// The ghost's distance (px, < 0 inside) at pixel centre q for channel c of sprite base b.
float ghost_sdf(uint b, uint c, vec2 q) {
    uint cb = b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS;
    vec2 centre = vec2(sprite_data[cb], sprite_data[cb + 1]);
    float signed_radius = sprite_data[cb + 2];
    float radius = abs(signed_radius);
    vec2 o = (q - centre) * (signed_radius < 0.0 ? -1.0 : 1.0);
    Aperture ap = Aperture(fc.blades, fc.rotation, fc.curvature, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0);
    // Past the corners the edge distance underestimates: the circumscribed circle bounds it.
    float d = max(aperture_sdf(o, radius, ap), length(o) - radius);
    return max(d, distance(q, vec2(sprite_data[cb + 4], sprite_data[cb + 5])) - sprite_data[cb + 6]);
}

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
    uint lid = gl_LocalInvocationIndex;
    vec2 q = vec2(p) + 0.5;
    vec2 tile_centre = vec2(origin) + 0.5 * float(TILE_SIZE);
    uint total = args[ARGS_LIGHTS] * uint(fc.slots_per_light);
    if (lid == 0) s_tile = vec3(0.0);
    vec3 sum = vec3(0.0);
    for (uint first = 0; first < total; first += GROUP) {
        // Sort sprite `first + lid` against the tile: bit c: channel c per pixel.
        uint s = first + lid;
        uint mode = 0u;
        vec3 covering = vec3(0.0);
        if (s < total) {
            uint b = s * SPRITE_WORDS;
            vec4 box = vec4(sprite_data[b], sprite_data[b + 1], sprite_data[b + 2], sprite_data[b + 3]);
            bool meets = box.x <= box.z && box.x < float(origin.x + TILE_SIZE) && box.z >= float(origin.x)
                && box.y < float(origin.y + TILE_SIZE) && box.w >= float(origin.y);
            int kind = int(sprite_data[b + SPRITE_KIND]);
            if (meets && kind == KIND_GHOST) {
                float half_ramp = 0.5 * sprite_data[b + SPRITE_SOFTNESS];
                for (uint c = 0; c < 3; ++c) {
                    float value = sprite_data[b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS + 3];
                    if (value <= 0.0) continue;
                    float d = ghost_sdf(b, c, tile_centre);
                    if (d <= -(TILE_REACH + half_ramp)) {
                        covering[c] = value;
                    } else if (d < TILE_REACH + half_ramp) {
                        mode |= 1u << c;
                    }
                }
            } else if (meets && kind == KIND_SPIKE) {
                uint d = b + SPRITE_DATA;
                vec2 t = ray_in_box(vec2(sprite_data[d], sprite_data[d + 1]), vec2(sprite_data[d + 2], sprite_data[d + 3]),
                                    sprite_data[d + 4], sprite_data[d + 5], vec2(origin), vec2(origin + TILE_SIZE));
                if (t.y > t.x) mode = 7u;
            } else if (meets && kind == KIND_GLOW) {
                mode = 7u;
            }
        }
        s_mode[lid] = mode;
        s_sum[lid] = covering;
        barrier();
        // One invocation lists the crossing sprites and sums the covering ones, in sprite
        // order: the same sums every run (and few barriers, which CPU drivers pay for).
        if (lid == 0) {
            uint n = 0;
            for (uint k = 0; k < GROUP; ++k) {
                if (s_mode[k] != 0u) s_list[n++] = (first + k) | (s_mode[k] << 24);
                s_tile += s_sum[k];
            }
            s_listed = n;
        }
        barrier();
        uint listed = s_listed;
        for (uint k = 0; k < listed; ++k) {
            uint entry = s_list[k];
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
        barrier();
    }
    if (outside(p, pc.size)) return;
    vec4 c = finite_or_zero(imageLoad(color_in, p));
    // The light's own pixels give up what its starburst and halo took.
    int light = int(tile_data[(uint(tile.y) * uint(fc.tiles_x) + uint(tile.x)) * TILE_WORDS + TILE_LIGHT]);
    if (light >= 0 && max(c.r, max(c.g, c.b)) >= fc.threshold) {
        uint lb = uint(light) * LIGHT_WORDS + LIGHT_MOVED;
        c.rgb *= vec3(1.0) - vec3(light_data[lb], light_data[lb + 1], light_data[lb + 2]);
    }
    imageStore(color_out, p, vec4(c.rgb + s_tile + sum, c.a));
}
