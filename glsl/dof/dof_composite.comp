#version 450
// Tiled depth of field, the level tiles at full resolution: the background upsampled from the
// tile's pyramid level, or for pixels that are themselves nearly sharp the exact gather (so a
// sharp subject stays sharp at full resolution), the level's foreground composited over. The
// highlight sprites come after, over the tiles that have any (dof_sprites.comp). One workgroup
// per tile, dispatched over the lists of the four levels: each level's class list with the
// exact gather, its blurred list (tiles with no nearly sharp pixel, dof_classify.comp) with a
// pipeline that has no exact gather in its code at all.
#include "common.glsl"
#define APERTURE_MASK_BINDING 6
#define APERTURE_SHAPE_BINDING 10
#include "aperture.glsl"
#include "dof_tiles.glsl"

// Constants 0 and 1 are the aperture's (aperture.glsl). Off for the blurred lists: every pixel's
// `blurred` is 1 there, so the exact gather's loop would take no trip; but on lavapipe a loop
// that no lane enters still costs (its skeleton, ~6-9 ms of 34 at 1 thread in scene A's
// dof_composite_3), and an `if` on a constant removes it from the code.
layout(constant_id = 2) const bool EXACT_GATHER = true;

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;   // less the sprites' energy
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform readonly image2D bg_level;
layout(binding = 3, rgba32f) uniform readonly image2D fg_level;
layout(binding = 4, rgba32f) uniform writeonly image2D color_out;
layout(binding = 5, std430) readonly buffer TileLists { uint tile_list[]; };
layout(binding = 7, rg32f) uniform readonly image2D coc_level;
layout(binding = 8, rgba32f) uniform readonly image2D fg_big_level;
layout(binding = 9, std430) readonly buffer TileRadius { float tile_radius_px[]; };
layout(binding = 11, rg32f) uniform readonly image2D coverage_level;  // (foreground, large-CoC foreground)

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 level_size;
    ivec2 tiles;
    int level;
    float small_radius_px;
    Aperture ap;
    float layer_transition_px;
    int list;   // the tile list this dispatch takes (the level's class list, or its blurred list)
} pc;

#include "gather.glsl"

vec4 load_level(int which, ivec2 q) {
    q = clamp(q, ivec2(0), pc.level_size - 1);
    return which == 0 ? imageLoad(bg_level, q)
        : (which == 1 ? imageLoad(fg_level, q) : (which == 2 ? imageLoad(fg_big_level, q) : imageLoad(coverage_level, q)));
}

vec4 bilinear_level(int which, ivec2 h0, vec2 f) {
    return mix(mix(load_level(which, h0), load_level(which, h0 + ivec2(1, 0)), f.x),
               mix(load_level(which, h0 + ivec2(0, 1)), load_level(which, h0 + ivec2(1, 1)), f.x), f.y);
}

void main() {
    int tile_count = pc.tiles.x * pc.tiles.y;
    uint t = tile_list[pc.list * tile_count + int(gl_WorkGroupID.x)];
    ivec2 tile_p = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x)) * TILE_SIZE + ivec2(gl_LocalInvocationID.xy);
    // A pixel beyond the image's edge (in a partial tile) computes its nearest edge pixel and
    // stores nothing, rather than returning here: lavapipe masks everything after a return that
    // some lanes took, which cost ~1.2 ms of scene A's dof_composite_3_blurred (16.3 vs 17.5 at
    // f/2, 1 thread) although scene A has no partial tile at all.
    bool inside = !outside(tile_p, pc.size);
    ivec2 p = min(tile_p, pc.size - 1);
    float scale = float(1 << pc.level);
    // Bilinear upsampling: pixel centre (p + 0.5) is level position (p + 0.5) / 2^L - 0.5.
    vec2 h = (vec2(p) + 0.5) / scale - 0.5;
    ivec2 h0 = ivec2(floor(h));
    vec2 f = h - vec2(h0);
    // Joint bilateral upsampling of the background: each level texel also weighted by how close
    // its CoC is to this pixel's, so a blurred pixel next to a sharp subject (or an in-focus
    // highlight) does not pull that content in from the coarser grid.
    float coc_here = imageLoad(coc_px, p).r;
    vec4 bg = vec4(0.0);
    float bg_weight = 0.0;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 q = clamp(h0 + ivec2(i, j), ivec2(0), pc.level_size - 1);
            vec2 cw = imageLoad(coc_level, q).rg;
            float bilinear = (i == 0 ? 1.0 - f.x : f.x) * (j == 0 ? 1.0 - f.y : f.y);
            float similar = cw.y;
            bg += (bilinear * similar) * imageLoad(bg_level, q);
            bg_weight += bilinear * similar;
        }
    }
    bg = bg_weight > 0.0 ? bg / bg_weight : load_level(0, h0);
    vec4 fg = bilinear_level(1, h0, f);
    // The foregrounds' coverages (x: all foreground samples, y: the large-CoC ones).
    vec2 coverage = bilinear_level(3, h0, f).xy;
    float radius_p = 0.5 * abs(coc_here);
    // Pixels whose own CoC is small are gathered exactly, as in the small-CoC tiles (so nothing
    // changes across a tile border), with only the large-CoC foreground composited over them;
    // blurred pixels take the level's layers. A blend over the last half pixel below the
    // small-CoC radius joins the two (every pixel there weighs fully in the pyramid: radius
    // at least 1.5), so a pixel at or above it costs only the upsampling. A nearly sharp pixel
    // (radius below 1.5) takes nothing of the level's background: the pyramid holds little or
    // none of it (its weight clamp(radius - 0.5, 0, 1)), and the level would blur it by 2^L px.
    float blurred = smoothstep(pc.small_radius_px - 0.5, pc.small_radius_px + float(EXACT_BLEND_ABOVE_SMALL_PX), radius_p);
    vec4 base = bg;
    Aperture ap = pc.ap;
    if (EXACT_GATHER) {
        // A loop of one trip or none rather than an `if`: lavapipe runs an `if`'s body whatever
        // the condition (here the large-CoC foreground's four reads and the gather's set-up), but
        // it leaves a loop that no lane of the SIMD group is in, so fully blurred pixels skip it.
        int exact_trips = blurred < 1.0 ? 1 : 0;
        for (int once = 0; once < exact_trips; ++once) {
            // As in dof_tile_gather: only foreground samples reach farther than p's own CoC.
            float fg_radius = tile_radius_px[tile_count + int(t)];
            // The reach is capped: the larger foreground samples come with fg_big below.
            float disc_px = tap_disc_px(min(pc.small_radius_px + 1.0, max(radius_p, fg_radius)));
            vec4 exact = gather_exact(p, pc.size, disc_px, ap, pc.layer_transition_px);
            vec4 fg_big = bilinear_level(2, h0, f);
            exact = exact * (1.0 - coverage.y) + fg_big;
            base = mix(exact, bg, blurred);
            coverage.x *= blurred;
            fg *= blurred;
        }
    }
    // The foregrounds come premultiplied by their coverage. Alpha is a channel of the picture
    // (premultiplied, OpenEXR's convention): composited as the colour.
    vec4 color = base * (1.0 - coverage.x) + fg;
    if (inside) imageStore(color_out, p, color);
}
