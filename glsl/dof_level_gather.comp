#version 450
// Tiled depth of field: the gather of the tiles of one pyramid level L (a pass per level,
// dispatched indirectly over its list: the level's tiles and their neighbours, see
// dof_level_lists.comp). Every texel of such a tile gathers the level's
// texels within the tile's radius in level units (at most LEVEL_RADIUS, 4 at the top level): the
// exact gather's rules (include/gather.glsl) on the pyramid, so its cost per tile falls as 1/4^L
// while the radius doubles. Writes the background, the foreground with its coverage (alpha), and
// the foreground of large-CoC samples only (for nearly sharp pixels, see dof_composite.comp).
#include "common.glsl"
#define APERTURE_MASK_BINDING 6
#define APERTURE_SHAPE_BINDING 9
#include "aperture.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = GROUP_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_level;   // premultiplied by the weight
layout(binding = 1, rg32f) uniform readonly image2D coc_level;       // (CoC in full-res px, weight)
layout(binding = 2, rgba32f) uniform writeonly image2D bg_level;
layout(binding = 3, rgba32f) uniform writeonly image2D fg_level;
layout(binding = 4, std430) readonly buffer LevelLists { uint level_list[]; };
layout(binding = 5, std430) readonly buffer TileRadius { float tile_radius_px[]; };
layout(binding = 7, rgba32f) uniform writeonly image2D fg_big_level;
layout(binding = 8, std430) readonly buffer Args { uint args[]; };

layout(push_constant) uniform Push {
    ivec2 level_size;
    ivec2 tiles;
    int level;
    Aperture ap;                // in level units
    float layer_transition_px;  // in level units
    float small_radius_px;      // in level units: larger CoC samples also go to fg_big
} pc;

void main() {
    int side = TILE_SIZE >> pc.level;
    int texels = side * side;
    int slot = int(gl_WorkGroupID.x) * (GROUP_SIZE / texels) + int(gl_LocalInvocationIndex) / texels;
    if (slot >= int(args[ARGS_LEVEL_TILES(pc.level)])) return;
    int tile_count = pc.tiles.x * pc.tiles.y;
    uint t = level_list[(pc.level - 1) * tile_count + slot];
    int texel = int(gl_LocalInvocationIndex) % texels;
    ivec2 p = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x)) * side + ivec2(texel % side, texel / side);
    if (outside(p, pc.level_size)) return;
    float to_level = 1.0 / float(1 << pc.level);
    Aperture ap = pc.ap;
    float coc_p = imageLoad(coc_level, p).r * to_level;
    float radius_p = max(0.5 * abs(coc_p), 0.5);
    int r = int(ceil(tile_radius_px[t] * to_level)) + 1;
    vec4 bg = vec4(0.0), fg = vec4(0.0), fg_big = vec4(0.0);
    float bg_w = 0.0, fg_w = 0.0, fg_big_w = 0.0;
    for (int dy = -r; dy <= r; ++dy) {
        // The row of the disc dx^2 + dy^2 <= r^2 + r (a loop bound, not a skipped tap: lavapipe
        // runs a skipped tap's work anyway).
        int half_width = int(floor(sqrt(float(r * r + r - dy * dy))));
        for (int dx = -half_width; dx <= half_width; ++dx) {
            ivec2 q = clamp(p + ivec2(dx, dy), ivec2(0), pc.level_size - 1);
            vec2 cw = imageLoad(coc_level, q).rg;
            if (cw.y <= 0.0) continue;
            float coc_q = cw.x * to_level;
            float radius_q = max(0.5 * abs(coc_q), 0.5);
            float reach = coc_q > coc_p ? min(radius_q, radius_p) : radius_q;
            if (float(dx * dx + dy * dy) > (reach + 1.0) * (reach + 1.0)) continue;
            int flip = coc_q < 0.0 ? -1 : 1;
            ivec2 o = ivec2(-dx, -dy) * flip;
            float w = aperture_weight_at(o, reach, ap, vec2(p + ivec2(dx, dy)) + 0.5, float(flip), 1.0)
                * sa_weight(vec2(o), radius_q, coc_q, ap);
            if (w <= 0.0) continue;
            vec4 c = imageLoad(color_level, q);
            float f = clamp((coc_p - coc_q) / pc.layer_transition_px, 0.0, 1.0);
            fg += (f * w) * c;
            fg_w += f * w * cw.y;
            if (radius_q > pc.small_radius_px) {
                fg_big += (f * w) * c;
                fg_big_w += f * w * cw.y;
            }
            bg += ((1.0 - f) * w) * c;
            bg_w += (1.0 - f) * w * cw.y;
        }
    }
    vec4 background = bg_w > 0.0 ? bg / bg_w : vec4(0.0);
    vec4 foreground = fg_w > 0.0 ? fg / fg_w : vec4(0.0);
    imageStore(bg_level, p, background);
    imageStore(fg_level, p, vec4(foreground.rgb, clamp(fg_w, 0.0, 1.0)));
    // The foreground of large-CoC samples only: what nearly sharp pixels, whose exact gather
    // already holds the small ones, composite over themselves.
    vec4 big = fg_big_w > 0.0 ? fg_big / fg_big_w : vec4(0.0);
    imageStore(fg_big_level, p, vec4(big.rgb, clamp(fg_big_w, 0.0, 1.0)));
}
