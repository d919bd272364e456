#version 450
// Tiled depth of field: the gather of the tiles of one pyramid level L (a pass per level,
// dispatched indirectly over its list: the level's tiles and their neighbours, see
// dof_level_lists.comp). Every texel of such a tile gathers the level's
// texels within the tile's radius in level units (at most LEVEL_RADIUS, 4 at the top level): the
// exact gather's rules (include/gather.glsl) on the pyramid, so its cost per tile falls as 1/4^L
// while the radius doubles. Writes the background, the foreground, and the foreground of large-CoC
// samples only (for nearly sharp pixels, see dof_composite.comp): the background the weighted
// mean of its samples' premultiplied RGBA (alpha is a channel of the picture like the colour), each
// foreground that mean times its coverage (so the composite's bilinear upsampling, across a
// foreground's edge, weighs each texel by its coverage), and the two coverages (coverage_level).
//
// The composite of a level-L tile upsamples bilinearly (texels h0 and h0 + 1 of pixel centre
// (p + 0.5) / 2^L - 0.5), so it reads the tile's own texels and a ring of one texel around it,
// nothing else. A neighbour tile of another class therefore gathers only its texels in that ring
// next to a level-L tile (an edge row or column, a corner texel) and stores zero in the others,
// which no pass reads (a gather of radius -1: its loops take no trip). A neighbour's invocations
// take its border texels first, around the ring, then the inner ones: lavapipe runs 8 lanes as
// one SIMD group and a loop costs only where some lane of the group enters it, so an edge's
// texels, contiguous on the ring, take one or two groups rather than all of them.
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
layout(binding = 10, rg32f) uniform writeonly image2D coverage_level;  // (foreground, large-CoC foreground)

layout(push_constant) uniform Push {
    ivec2 level_size;
    ivec2 tiles;
    int level;
    Aperture ap;                // in level units
    float layer_transition_px;  // in level units
    float small_radius_px;      // in level units: larger CoC samples also go to fg_big
} pc;

// Whether a composite reads texel xy (in the tile, of side `side`): the tiles it is next to, in
// the bits of level_list_near (the tile itself takes every texel), against `near`.
bool texel_read(ivec2 xy, int side, uint near) {
    uint xs = 2u | (xy.x == 0 ? 1u : 0u) | (xy.x == side - 1 ? 4u : 0u);
    uint ys = 2u | (xy.y == 0 ? 1u : 0u) | (xy.y == side - 1 ? 4u : 0u);
    uint next_to = ((ys & 1u) != 0u ? xs : 0u) | ((ys & 2u) != 0u ? xs << 3 : 0u) | ((ys & 4u) != 0u ? xs << 6 : 0u);
    return (next_to & near) != 0u;
}

// Texel k of a neighbour tile (of side `side`) in ring order: its border clockwise from the top
// left corner (the texels a composite may read), then the inner texels row by row.
ivec2 ring_texel(int k, int side) {
    if (side <= 2) return ivec2(k % side, k / side);
    int border = 4 * side - 4;
    if (k < side) return ivec2(k, 0);
    if (k < 2 * side - 1) return ivec2(side - 1, k - side + 1);
    if (k < 3 * side - 2) return ivec2(3 * side - 3 - k, side - 1);
    if (k < border) return ivec2(0, 4 * side - 4 - k);
    int inner = side - 2;
    return ivec2(1 + (k - border) % inner, 1 + (k - border) / inner);
}

// A sample's reach on the level (texels), less the blur the pyramid and the upsampling add.
float level_reach(float reach) {
    return sqrt(max(reach * reach - 1.0, 0.25));
}

void main() {
    int side = TILE_SIZE >> pc.level;
    int texels = side * side;
    int slot = int(gl_WorkGroupID.x) * (GROUP_SIZE / texels) + int(gl_LocalInvocationIndex) / texels;
    if (slot >= int(args[ARGS_LEVEL_TILES(pc.level)])) return;
    int tile_count = pc.tiles.x * pc.tiles.y;
    uint entry = level_list[(pc.level - 1) * tile_count + slot];
    uint t = level_list_tile(entry);
    int lane = int(gl_LocalInvocationIndex) % texels;
    ivec2 tc = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x));
    uint near = level_list_near(entry);
    // A tile of the level: its texels row by row; a neighbour: in ring order.
    ivec2 xy = (near & 16u) != 0u ? ivec2(lane % side, lane / side) : ring_texel(lane, side);
    ivec2 p = tc * side + xy;
    if (outside(p, pc.level_size)) return;
    float to_level = 1.0 / float(1 << pc.level);
    Aperture ap = pc.ap;
    float coc_p = imageLoad(coc_level, p).r * to_level;
    float radius_p = max(0.5 * abs(coc_p), 0.5);
    // The taps' disc (aperture.glsl): no sample near the tile reaches farther than the tile's
    // radius (its CoC here is a weighted mean of CoCs that radius bounds). No composite reads
    // the texel: a disc of radius -1, so the gather's loops take no trip and it stores zero
    // (the CPU twin's value).
    float tap_disc = texel_read(xy, side, near) ? tap_disc_px(tile_radius_px[t] * to_level) : -1.0;
    int r = int(floor(tap_disc));
    vec4 bg = vec4(0.0), fg = vec4(0.0), fg_big = vec4(0.0), hidden = vec4(0.0);
    float bg_w = 0.0, fg_w = 0.0, fg_big_w = 0.0, hidden_n = 0.0, hidden_near_w = 0.0, own_n = 0.0;
    // A sample spread over p's own (level-shortened) CoC would carry 1 / (this) at p.
    float reach_p = level_reach(radius_p);
    float area_p = ap.area_factor * reach_p * reach_p;
    for (int dy = -r; dy <= r; ++dy) {
        // The disc's row (a loop bound, not a skipped tap: lavapipe runs a skipped tap's work
        // anyway).
        int half_width = int(floor(sqrt(tap_disc * tap_disc - float(dy * dy))));
        for (int dx = -half_width; dx <= half_width; ++dx) {
            ivec2 q = clamp(p + ivec2(dx, dy), ivec2(0), pc.level_size - 1);
            vec2 cw = imageLoad(coc_level, q).rg;
            if (cw.y <= 0.0) continue;
            float coc_q = cw.x * to_level;
            float radius_q = max(0.5 * abs(coc_q), 0.5);
            // The level's own blur: the pyramid's 2^L box (variance 1/12 texel^2 per axis) and
            // the composite's bilinear tent (1/6) add 1/4 texel^2 to the disc's r^2 / 4, so the
            // disc reaches sqrt(r^2 - 1): the sum blurs as the CoC asks.
            float reach = level_reach(coc_q > coc_p ? min(radius_q, radius_p) : radius_q);
            float d2 = float(dx * dx + dy * dy);
            float w = 0.0;
            if (d2 <= (reach + 1.0) * (reach + 1.0)) {
                int flip = coc_q < 0.0 ? -1 : 1;
                ivec2 o = ivec2(-dx, -dy) * flip;
                w = aperture_weight_at(o, reach, ap, vec2(p + ivec2(dx, dy)) + 0.5, float(flip), 1.0)
                    * sa_weight(vec2(o), radius_q, coc_q, ap);
            }
            vec4 c = imageLoad(color_level, q);
            float f = clamp((coc_p - coc_q) / pc.layer_transition_px, 0.0, 1.0);
            // The background p's own surface hides, as in the exact gather (include/gather.glsl,
            // the fill's rules): within p's CoC, the positions behind p whose light does not
            // reach p, their colour from the nearest of them on their own CoC's scale. Each
            // texel counts by its weight (the share of its pixels the level holds).
            float in_p = d2 <= radius_p * radius_p ? 1.0 : 0.0;
            float behind = clamp((coc_q - coc_p) / pc.layer_transition_px, 0.0, 1.0);
            float unreached = in_p * behind * (1.0 - min(w * area_p, 1.0));
            float closeness = radius_q * radius_q / (radius_q * radius_q + d2);
            float near = unreached * closeness * closeness * closeness;
            hidden += near * c;   // c is premultiplied by the texel's weight cw.y
            hidden_near_w += near * cw.y;
            hidden_n += unreached * cw.y;
            own_n += in_p * (1.0 - f) * cw.y;
            if (w <= 0.0) continue;
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
    // The weight missing from p's own layer and behind, up to the share of p's disc that is
    // background not reaching p, is that background's (the exact gather's fill); the rest
    // normalises. Without it a defocused foreground's rim over a background of a smaller CoC
    // kept the foreground's full light where the background shows through (scene A's pole:
    // 3.4% -> 1.7% of the tiles off the reference at f/2). Counting the share by positions
    // instead of by 1 - bg_w filled too much on the coarse levels (5.0%).
    float hidden_share = own_n > 0.0 ? hidden_n / own_n : 0.0;
    float missing = min(max(1.0 - bg_w, 0.0), hidden_share);
    vec4 hidden_colour = hidden_near_w > 0.0 ? hidden / hidden_near_w : vec4(0.0);
    float lit_w = bg_w + missing;
    vec4 background = lit_w > 0.0 ? (bg + missing * hidden_colour) / lit_w : vec4(0.0);
    vec4 foreground = fg_w > 0.0 ? fg / fg_w : vec4(0.0);
    imageStore(bg_level, p, background);
    float coverage = clamp(fg_w, 0.0, 1.0), big_coverage = clamp(fg_big_w, 0.0, 1.0);
    imageStore(fg_level, p, foreground * coverage);
    // The foreground of large-CoC samples only: what nearly sharp pixels, whose exact gather
    // already holds the small ones, composite over themselves.
    vec4 big = fg_big_w > 0.0 ? fg_big / fg_big_w : vec4(0.0);
    imageStore(fg_big_level, p, big * big_coverage);
    imageStore(coverage_level, p, vec4(coverage, big_coverage, 0.0, 0.0));
}
