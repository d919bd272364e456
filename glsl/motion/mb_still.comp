#version 450
// Motion blur, step 3b: the tiles mb_neighbor listed as still (nothing near them moves half a
// pixel while the shutter is open), copied as the gather copies a pixel: one workgroup per tile.
#include "common.glsl"
#include "motion.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
layout(binding = 2, std430) readonly buffer TileList { uint tile_list[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
} pc;

void main() {
    uint first_still = uint(pc.tiles.x * pc.tiles.y);
    ivec2 p = listed_tile_pixel(tile_list[first_still + gl_WorkGroupID.x], gl_LocalInvocationID.xy);
    if (outside(p, pc.size)) return;
    imageStore(color_out, p, finite_or_zero(imageLoad(color_in, p)));
}
