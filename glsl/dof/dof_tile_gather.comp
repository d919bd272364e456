#version 450
// Tiled depth of field, full-resolution tiles: a copy for tiles nothing defocused reaches, the
// exact gather (include/gather.glsl) with the tile's own radius for small CoC. Dispatched
// indirectly, one workgroup per tile of the class's list.
#include "common.glsl"
#define APERTURE_MASK_BINDING 5
#define APERTURE_SHAPE_BINDING 6
#include "aperture.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform writeonly image2D color_out;
layout(binding = 3, std430) readonly buffer TileLists { uint tile_list[]; };
layout(binding = 4, std430) readonly buffer TileRadius { float tile_radius_px[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
    int tile_class;
    Aperture ap;
    float layer_transition_px;
} pc;

#include "gather.glsl"

void main() {
    uint t = tile_list[pc.tile_class * pc.tiles.x * pc.tiles.y + int(gl_WorkGroupID.x)];
    ivec2 p = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x)) * TILE_SIZE + ivec2(gl_LocalInvocationID.xy);
    if (outside(p, pc.size)) return;
    if (pc.tile_class == CLASS_COPY) {
        imageStore(color_out, p, finite_or_zero(imageLoad(color_in, p)));
        return;
    }
    // Samples behind p reach no farther than p's own CoC; only foreground samples (in front of
    // the focus plane) can reach farther, and the tile knows the largest of those.
    float radius_p = 0.5 * abs(imageLoad(coc_px, p).r);
    float fg_radius = tile_radius_px[pc.tiles.x * pc.tiles.y + int(t)];
    Aperture ap = pc.ap;
    float disc_px = tap_disc_px(min(tile_radius_px[t], max(radius_p, fg_radius)));
    imageStore(color_out, p, gather_exact(p, pc.size, disc_px, ap, pc.layer_transition_px));
}
