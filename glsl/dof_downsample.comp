#version 450
// Tiled depth of field, step 3: level 1 of the pyramid (half resolution) and the highlights.
// Level texels hold the colour and CoC of the pixels that blur: each pixel weighs
// w = clamp(radius - 0.5, 0, 1), so sharp pixels (whose light stays where it is; the
// full-resolution exact gather draws them) do not leak into the blurred levels. The colour is
// premultiplied by the weight: color_half = sum w c / 4, coc_half = (sum w coc / sum w, sum w / 4).
//
// A pixel of large CoC much brighter than the dimmest side of the ring 3 px around it gives its
// excess over that background to a sprite (drawn with the exact aperture shape by the composite)
// instead of to the levels, which could not draw a crisp bokeh shape from it. Also writes the
// full-resolution colour without the sprites' energy, and counts the sprite binning's dispatch.
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform writeonly image2D color_half;
layout(binding = 3, rg32f) uniform writeonly image2D coc_half;
layout(binding = 4, std430) buffer Args { uint args[]; };
layout(binding = 5, std430) writeonly buffer Sprites { Sprite sprites[]; };
// The full-resolution colour less the energy given to sprites: what the exact gathers read, so
// a highlight is not counted twice.
layout(binding = 6, rgba32f) uniform writeonly image2D color_base;

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 half_size;
    float small_radius_px;   // sprites come from pixels of a larger CoC radius
    float highlight_min;     // a highlight is at least this bright (luminance) ...
    float highlight_ratio;   // ... and this many times its background
    int sprite_capacity;
    float sprite_visibility;  // smallest visible excess per pixel, relative to the background
    // Luminance of R, G, B in the frame's colour space: the Y row of its RGB to XYZ matrix
    // (three floats: a vec3 would be aligned to 16 bytes).
    float luminance_r;
    float luminance_g;
    float luminance_b;
} pc;

float luminance(vec3 c) { return dot(c, vec3(pc.luminance_r, pc.luminance_g, pc.luminance_b)); }

// The background of a highlight at p: the mean, over the four sides of the ring 3 px away, of
// each side's dimmest pixel (the other pixels of the same highlight or of a neighbouring one
// brighten some sides, not all).
float background(ivec2 p) {
    float sum = 0.0, sides = 0.0;
    for (int side = 0; side < 4; ++side) {
        float dimmest = 3.0e38;
        for (int k = -3; k < 3; ++k) {
            ivec2 ring[4] = ivec2[4](ivec2(k, -3), ivec2(3, k), ivec2(-k, 3), ivec2(-3, -k));
            ivec2 q = p + ring[side];
            if (outside(q, pc.size)) continue;
            dimmest = min(dimmest, luminance(finite_or_zero(imageLoad(color_in, q)).rgb));
        }
        if (dimmest < 3.0e38) {
            sum += dimmest;
            sides += 1.0;
        }
    }
    return sum / max(sides, 1.0);
}

void main() {
    ivec2 ph = ivec2(gl_GlobalInvocationID.xy);
    if (outside(ph, pc.half_size)) return;
    vec4 sum = vec4(0.0);
    float coc_sum = 0.0, weight = 0.0;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 p = ph * 2 + ivec2(i, j);
            if (outside(p, pc.size)) continue;
            vec4 c = finite_or_zero(imageLoad(color_in, p));
            float coc = imageLoad(coc_px, p).r;
            float radius = 0.5 * abs(coc);
            float lum = luminance(c.rgb);
            if (radius > pc.small_radius_px && lum > pc.highlight_min) {
                float bg = background(p);
                float reference = max(pc.highlight_min, pc.highlight_ratio * bg);
                // A sprite is worth drawing only if its disk stands out: the excess spread over
                // the CoC's area must be a visible fraction of the background. A faint disk is
                // left to the levels (its shape would not show), which keeps the number of
                // sprites, and their cost, bounded.
                float area = PI * 0.25 * coc * coc;
                bool visible = (lum - reference) / max(area, 1.0) > pc.sprite_visibility * max(bg, pc.highlight_min * 0.01);
                if (lum > reference && visible) {
                    vec3 excess = c.rgb * (1.0 - bg / lum);
                    uint slot = atomicAdd(args[ARGS_SPRITE_COUNT], 1u);
                    if (slot < uint(pc.sprite_capacity)) {
                        sprites[slot] = Sprite(vec2(p) + 0.5, coc, 0.0, vec4(excess, 0.0));
                        c.rgb -= excess;
                        if (slot % uint(GROUP_SIZE) == 0u) atomicAdd(args[ARGS_BIN_DISPATCH], 1u);
                    } else {
                        atomicAdd(args[ARGS_SPRITES_DROPPED], 1u);
                    }
                }
            }
            imageStore(color_base, p, c);
            float w = clamp(radius - 0.5, 0.0, 1.0);
            sum += w * c;
            coc_sum += w * coc;
            weight += w;
        }
    }
    imageStore(color_half, ph, 0.25 * sum);
    imageStore(coc_half, ph, vec4(weight > 0.0 ? coc_sum / weight : 0.0, 0.25 * weight, 0.0, 0.0));
}
