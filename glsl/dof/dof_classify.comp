#version 450
// Tiled depth of field, step 2: how far the gather of each tile must reach, and the tile's
// class. A sample behind a pixel reaches it no farther than the pixel's own CoC (the gathers'
// occlusion rule), so only foreground samples (in front of the focus plane) reach farther: the
// radius is the larger of the tile's own largest CoC radius and the largest foreground radius
// of any tile near enough to cover part of it (dilation). A far background next to a sharp
// subject or a nearer wall no longer sets their tiles' level (scene A: the sky's and the wall's
// CoC put the subject's chin on level 3, the wall's texture next to the sky blurred at 1/8
// resolution). The class: a copy,
// the exact full-resolution gather, or the gather at the pyramid level where that radius is
// at most LEVEL_RADIUS texels. Each tile is appended to its class's list, whose indirect
// dispatch counts its tiles; a level tile none of whose pixels is nearly sharp (its own smallest
// |CoC| radius at least small_radius_px, so every pixel's `blurred` in dof_composite.comp is 1,
// with half a pixel to spare) to its level's blurred list instead, which the composite takes
// without the exact gather.
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = 64) in;
layout(binding = 0, std430) readonly buffer TileCoc { vec2 tile_coc[]; };
layout(binding = 1, std430) buffer Args { uint args[]; };
layout(binding = 2, std430) writeonly buffer TileLists { uint tile_list[]; }; // LIST_COUNT lists of tile_count
// [0, n): the gather radius (px); [n, 2n): the largest radius of a foreground sample (in front
// of the focus plane) that reaches the tile; [2n, 3n): the class, as a float.
layout(binding = 3, std430) writeonly buffer TileRadius { float tile_radius_px[]; };

layout(push_constant) uniform Push {
    ivec2 tiles;
    int search_tiles;        // neighbours searched in each direction (max CoC radius / tile + 1)
    float small_radius_px;   // gather radius up to which a tile uses the exact full-res gather
} pc;

void main() {
    int t = int(gl_GlobalInvocationID.x);
    int tile_count = pc.tiles.x * pc.tiles.y;
    if (t == 0) {
        for (int c = 0; c < CLASS_COUNT; ++c) {
            args[ARGS_TILES(c) + 1] = 1u;
            args[ARGS_TILES(c) + 2] = 1u;
        }
        for (int level = 1; level <= LEVELS; ++level) {
            args[ARGS_LEVEL_GATHER(level) + 1] = 1u;
            args[ARGS_LEVEL_GATHER(level) + 2] = 1u;
            args[ARGS_BLURRED_TILES(level) + 1] = 1u;
            args[ARGS_BLURRED_TILES(level) + 2] = 1u;
        }
        args[ARGS_BIN_DISPATCH + 1] = 1u;
        args[ARGS_BIN_DISPATCH + 2] = 1u;
        args[ARGS_HIGHLIGHT_DISPATCH + 1] = 1u;
        args[ARGS_HIGHLIGHT_DISPATCH + 2] = 1u;
        args[ARGS_SPRITE_TILES + 1] = 1u;
        args[ARGS_SPRITE_TILES + 2] = 1u;
    }
    if (t >= tile_count) return;
    ivec2 tc = ivec2(t % pc.tiles.x, t / pc.tiles.x);
    float fg_radius = 0.0;
    for (int dy = -pc.search_tiles; dy <= pc.search_tiles; ++dy) {
        for (int dx = -pc.search_tiles; dx <= pc.search_tiles; ++dx) {
            ivec2 n = tc + ivec2(dx, dy);
            if (outside(n, pc.tiles)) continue;
            vec2 range = tile_coc[n.y * pc.tiles.x + n.x];
            // Gap in pixels between the two tiles' rectangles.
            vec2 gap = vec2(max(abs(dx) - 1, 0), max(abs(dy) - 1, 0)) * float(TILE_SIZE);
            float fg_n = range.x < 0.0 ? -0.5 * range.x : 0.0;
            if (fg_n + 1.0 > length(gap)) fg_radius = max(fg_radius, fg_n);
        }
    }
    vec2 own = tile_coc[t];
    float radius = max(0.5 * max(abs(own.x), abs(own.y)), fg_radius);
    int cls = CLASS_COPY;
    if (radius > 0.5) cls = CLASS_SMALL;
    if (radius > pc.small_radius_px) {
        int level = 1;
        while (level < LEVELS && radius > float(LEVEL_RADIUS << level)) ++level;
        cls = CLASS_LEVEL1 + level - 1;
    }
    tile_radius_px[t] = radius;
    tile_radius_px[tile_count + t] = fg_radius;
    tile_radius_px[2 * tile_count + t] = float(cls);
    // The tile's own pixels: the smallest |CoC| of its signed range (0 if the range holds 0).
    float own_min_radius = 0.5 * (own.x > 0.0 ? own.x : (own.y < 0.0 ? -own.y : 0.0));
    bool blurred = cls >= CLASS_LEVEL1
        && own_min_radius >= exact_radius_px(cls - CLASS_LEVEL1 + 1, pc.small_radius_px) + float(EXACT_BLEND_ABOVE_SMALL_PX);
    int list = blurred ? LIST_BLURRED_LEVEL1 + cls - CLASS_LEVEL1 : cls;
    uint slot = atomicAdd(args[blurred ? ARGS_BLURRED_TILES(cls - CLASS_LEVEL1 + 1) : ARGS_TILES(cls)], 1u);
    tile_list[list * tile_count + int(slot)] = uint(t);
}
