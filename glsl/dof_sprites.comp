#version 450
// Tiled depth of field, last step: the highlight sprites, each the exact aperture shape of its
// CoC with its energy spread over its area, added to the large-CoC tiles. Each workgroup (one
// tile) first keeps, in shared memory, the sprites whose bounds overlap it (binning per tile),
// then every pixel sums those. Same occlusion rule as the gather: a sprite behind a pixel
// spreads no farther than the pixel's own CoC.
#include "common.glsl"
#define APERTURE_MASK_BINDING 5
#include "aperture.glsl"
#include "dof_tiles.glsl"

#define BATCH (TILE_SIZE * TILE_SIZE)

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, r32f) uniform readonly image2D coc_px;
layout(binding = 1, rgba32f) uniform image2D color_out;
layout(binding = 2, std430) readonly buffer Args { uint args[]; };
layout(binding = 3, std430) readonly buffer Sprites { Sprite sprites[]; };
layout(binding = 4, std430) readonly buffer TileLists { uint tile_list[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
    Aperture ap;
    int sprite_capacity;
} pc;

shared Sprite s_batch[BATCH];
shared uint s_count;

void main() {
    uint t = tile_list[CLASS_LARGE * pc.tiles.x * pc.tiles.y + int(gl_WorkGroupID.x)];
    ivec2 tile_origin = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x)) * TILE_SIZE;
    ivec2 p = tile_origin + ivec2(gl_LocalInvocationID.xy);
    bool inside = !outside(p, pc.size);
    Aperture ap = pc.ap;
    float coc_p = inside ? imageLoad(coc_px, p).r : 0.0;
    float radius_p = max(0.5 * abs(coc_p), 0.5);
    uint total = min(args[ARGS_SPRITE_COUNT], uint(pc.sprite_capacity));
    vec3 sum = vec3(0.0);
    for (uint first = 0; first < total; first += BATCH) {
        if (gl_LocalInvocationIndex == 0) s_count = 0;
        barrier();
        uint i = first + gl_LocalInvocationIndex;
        if (i < total) {
            Sprite s = sprites[i];
            float r = 0.5 * abs(s.coc_px) + 1.0;
            vec2 lo = vec2(tile_origin), hi = vec2(tile_origin + TILE_SIZE);
            if (s.centre_px.x + r >= lo.x && s.centre_px.x - r <= hi.x && s.centre_px.y + r >= lo.y && s.centre_px.y - r <= hi.y) {
                s_batch[atomicAdd(s_count, 1u)] = s;
            }
        }
        barrier();
        for (uint k = 0; k < s_count; ++k) {
            Sprite s = s_batch[k];
            float radius_q = max(0.5 * abs(s.coc_px), 0.5);
            float reach = s.coc_px > coc_p ? min(radius_q, radius_p) : radius_q;
            float flip = s.coc_px < 0.0 ? -1.0 : 1.0;
            vec2 o = (vec2(p) + 0.5 - s.centre_px) * flip;
            sum += s.color.rgb * (aperture_weight(o, reach, ap, s.centre_px, flip, 1.0)
                * sa_intensity(length(o) / radius_q, sa_strength(s.coc_px, ap)));
        }
        barrier();
    }
    if (inside && total > 0u) {
        vec4 c = imageLoad(color_out, p);
        imageStore(color_out, p, vec4(c.rgb + sum, c.a));
    }
}
