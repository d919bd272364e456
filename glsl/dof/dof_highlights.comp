#version 450
#extension GL_EXT_control_flow_attributes : require  // [[dont_unroll]]
// Tiled depth of field, step 3b: the highlights of the candidate texels dof_downsample.comp
// listed. A pixel of large CoC much brighter than the dimmest side of the ring 3 px around it
// gives its excess over that background to a sprite (drawn with the exact aperture shape by
// the composite) instead of to the pyramid, which could not draw a crisp bokeh shape from it:
// the excess leaves its level-1 texel here, and the pixel of the input colour in
// dof_sprite_excess.comp (not here: the rings this dispatch reads would race with writes). One
// invocation per texel, so its level-1 texel has one writer. Counts the sprite binning's (and
// dof_sprite_excess's) dispatch.
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = GROUP_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform image2D color_half;
layout(binding = 3, std430) buffer Args { uint args[]; };
layout(binding = 4, std430) readonly buffer Candidates { uint candidates[]; };
layout(binding = 5, std430) writeonly buffer Sprites { Sprite sprites[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    float small_radius_px;   // sprites come from pixels of a larger CoC radius
    float highlight_min;     // a highlight is at least this bright (luminance) ...
    float highlight_ratio;   // ... and this many times its background
    int sprite_capacity;
    float sprite_visibility;  // smallest visible excess per pixel, relative to the background
    // Luminance of R, G, B in the frame's colour space (as in dof_downsample.comp).
    float luminance_r;
    float luminance_g;
    float luminance_b;
} pc;

float luminance(vec3 c) { return dot(c, vec3(pc.luminance_r, pc.luminance_g, pc.luminance_b)); }

// The background of a highlight at p: the mean, over the four sides of the ring 3 px away, of
// each side's dimmest pixel (the other pixels of the same highlight or of a neighbouring one
// brighten some sides, not all).
//
// The sides are a loop that stays a loop ([[dont_unroll]]): lavapipe creates the pipeline's
// code at vkCreateComputePipelines, and the 24 unrolled reads (with the 9 of
// neighbourhood_peak) were half its cost, ~6.5 -> ~3.3 ms of start-up CPU on scene A, for a
// pass that runs over a short list. Each side is the one before turned by a quarter turn:
// (k, -3), (3, k), (-k, 3), (-3, -k), as a table of four offsets indexed by the side read, but
// with no array (an array indexed by the loop's counter went to per-lane memory: the pass ran
// 2x slower).
float background(ivec2 p) {
    float sum = 0.0, sides = 0.0;
    ivec2 along = ivec2(1, 0), out_dir = ivec2(0, -1);  // side 0: the row 3 px above
    [[dont_unroll]] for (int side = 0; side < 4; ++side) {
        float dimmest = 3.0e38;
        for (int k = -3; k < 3; ++k) {
            ivec2 q = p + k * along + 3 * out_dir;
            if (outside(q, pc.size)) continue;
            dimmest = min(dimmest, luminance(finite_or_zero(imageLoad(color_in, q)).rgb));
        }
        if (dimmest < 3.0e38) {
            sum += dimmest;
            sides += 1.0;
        }
        // A quarter turn, (x, y) -> (-y, x): the next side, its pixels in the same order.
        along = ivec2(-along.y, along.x);
        out_dir = ivec2(-out_dir.y, out_dir.x);
    }
    return sum / max(sides, 1.0);
}

// The brightest luminance of p's 3x3 neighbourhood: the visibility test's, so a highlight's
// anti-aliased fringe, dimmer than its core, joins the core's sprites (left to the levels, it
// spread a soft halo around the crisp disc: faint highlights of scene A 2-6% too large).
// Its rows stay a loop too (as background's sides).
float neighbourhood_peak(ivec2 p) {
    float peak = -3.0e38;
    [[dont_unroll]] for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = p + ivec2(dx, dy);
            if (outside(q, pc.size)) continue;
            peak = max(peak, luminance(finite_or_zero(imageLoad(color_in, q)).rgb));
        }
    }
    return peak;
}

void main() {
    uint index = gl_GlobalInvocationID.x;
    if (index >= args[ARGS_HIGHLIGHT_COUNT]) return;
    uint packed = candidates[index];
    ivec2 ph = ivec2(packed & 0xffffu, packed >> 16);
    vec3 removed = vec3(0.0);  // sum of w * excess over the texel's pixels
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 p = ph * 2 + ivec2(i, j);
            if (outside(p, pc.size)) continue;
            vec4 c = finite_or_zero(imageLoad(color_in, p));
            float coc = imageLoad(coc_px, p).r;
            float radius = 0.5 * abs(coc);
            float lum = luminance(c.rgb);
            if (radius <= pc.small_radius_px || lum <= pc.highlight_min) continue;
            float bg = background(p);
            float reference = max(pc.highlight_min, pc.highlight_ratio * bg);
            // A sprite is worth drawing only if its disk stands out: the excess spread over the
            // CoC's area must be a visible fraction of the background. A faint disk is left to
            // the levels (its shape would not show), which keeps the number of sprites, and
            // their cost, bounded.
            float area = PI * 0.25 * coc * coc;
            // The disc stands out if its brightest pixel's does: the fringe goes with the core.
            bool visible = (neighbourhood_peak(p) - reference) / max(area, 1.0) > pc.sprite_visibility * max(bg, pc.highlight_min * 0.01);
            if (lum <= reference || !visible) continue;
            vec3 excess = c.rgb * (1.0 - bg / lum);
            uint slot = atomicAdd(args[ARGS_SPRITE_COUNT], 1u);
            if (slot < uint(pc.sprite_capacity)) {
                sprites[slot] = Sprite(vec2(p) + 0.5, coc, 0.0, vec4(excess, 0.0));
                removed += clamp(radius - 0.5, 0.0, 1.0) * excess;
                if (slot % uint(GROUP_SIZE) == 0u) atomicAdd(args[ARGS_BIN_DISPATCH], 1u);
            } else {
                atomicAdd(args[ARGS_SPRITES_DROPPED], 1u);
            }
        }
    }
    vec4 half_texel = imageLoad(color_half, ph);
    imageStore(color_half, ph, vec4(half_texel.rgb - 0.25 * removed, half_texel.a));
}
