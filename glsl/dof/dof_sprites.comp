#version 450
// variant dof_sprites_plain: NO_SUBGROUP_OPS
#ifndef NO_SUBGROUP_OPS
#extension GL_KHR_shader_subgroup_ballot : require  // subgroupBroadcast
#endif
// Tiled depth of field, the last step: the highlight sprites binned to a level tile
// (dof_bin.comp, in dof_bin_order.comp's order) added to the composite's pixels, each with the
// exact aperture shape, under the gather's occlusion rule: a sprite behind a pixel spreads no
// farther than the pixel's own CoC. One workgroup per tile, dispatched over the tiles whose bin
// holds a sprite (dof_bin_order.comp lists them). In the composite's own code the sprite loop
// cost every tile its body once, sprites or none: lavapipe runs a loop's body (masked) before
// it knows that no lane stays in it, and most level tiles have no sprite.
#include "common.glsl"
#define APERTURE_MASK_BINDING 7
#define APERTURE_SHAPE_BINDING 8
#include "aperture.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform image2D color;   // the composite's output, the sprites added
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, std430) readonly buffer TileLists { uint tile_list[]; };
layout(binding = 3, std430) readonly buffer Sprites { Sprite sprites[]; };
layout(binding = 4, std430) readonly buffer BinCounts { uint bin_count[]; };
layout(binding = 5, std430) readonly buffer Bins { uint bin[]; };
layout(binding = 6, std430) readonly buffer Args { uint args[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
    Aperture ap;
    int sprite_capacity;
} pc;

// The light of one sprite at pixel p (of signed CoC coc_p).
vec3 sprite_light(Sprite s, ivec2 p, float coc_p, Aperture ap) {
    float radius_p = max(0.5 * abs(coc_p), 0.5);
    float radius_q = max(0.5 * abs(s.coc_px), 0.5);
    float reach = s.coc_px > coc_p ? min(radius_q, radius_p) : radius_q;
    int flip = s.coc_px < 0.0 ? -1 : 1;
    // Sprites sit at pixel centres: the offset is a whole number of pixels.
    ivec2 o = (p - ivec2(floor(s.centre_px))) * flip;
    return s.color.rgb * (aperture_weight_at(o, reach, ap, s.centre_px, float(flip), 1.0)
        * sa_weight(vec2(o), radius_q, s.coc_px, ap));
}

void main() {
    int tile_count = pc.tiles.x * pc.tiles.y;
    uint t = tile_list[LIST_SPRITE_TILES * tile_count + int(gl_WorkGroupID.x)];
    ivec2 tile_p = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x)) * TILE_SIZE + ivec2(gl_LocalInvocationID.xy);
    // A pixel beyond the image's edge (in a partial tile) computes its nearest edge pixel and
    // stores nothing (as the composite).
    bool inside = !outside(tile_p, pc.size);
    ivec2 p = min(tile_p, pc.size - 1);
    vec4 composite = imageLoad(color, p);
    float coc_here = imageLoad(coc_px, p).r;
    Aperture ap = pc.ap;
    vec3 light = composite.rgb;
    // The sprites of the tile's bin; all of them if the bin overflowed.
    uint count = bin_count[t];
    uint listed = min(count, uint(BIN_CAPACITY));
    uint total = count > uint(BIN_CAPACITY) ? min(args[ARGS_SPRITE_COUNT], uint(pc.sprite_capacity)) : listed;
#ifndef NO_SUBGROUP_OPS
    // Lane k of each subgroup reads sprite base + k, and the subgroup shades them one by
    // one from the lane that read it: one buffer read per lane for gl_SubgroupSize sprites.
    // (lavapipe reads a buffer at an index it cannot prove uniform lane by lane, in a loop:
    // read by every lane, the sprites cost 97 of dof_sprites' 99 ms at a CoC radius of 32.)
    // `total` is the same for the whole workgroup, so every lane takes every trip.
    for (uint base = 0u; base < total; base += gl_SubgroupSize) {
        uint k = base + gl_SubgroupInvocationID;
        Sprite mine = Sprite(vec2(0.0), 0.0, 0.0, vec4(0.0));
        if (k < total) mine = sprites[count > uint(BIN_CAPACITY) ? k : bin[int(t) * BIN_CAPACITY + int(k)]];
        uint n = min(gl_SubgroupSize, total - base);
        for (uint j = 0u; j < n; ++j) {
            Sprite s = Sprite(subgroupBroadcast(mine.centre_px, j), subgroupBroadcast(mine.coc_px, j), 0.0,
                              subgroupBroadcast(mine.color, j));
            light += sprite_light(s, p, coc_here, ap);
        }
    }
#else
    // The variant for devices that cannot broadcast within a subgroup in compute shaders
    // (VK_SUBGROUP_FEATURE_BALLOT_BIT; src/passes/dof/sprites.rs picks it): every lane reads.
    for (uint k = 0u; k < total; ++k) {
        uint i = count > uint(BIN_CAPACITY) ? k : bin[int(t) * BIN_CAPACITY + int(k)];
        light += sprite_light(sprites[i], p, coc_here, ap);
    }
#endif
    if (inside) imageStore(color, p, vec4(light, composite.a));
}
