#version 450
// Tiled depth of field, step 3: level 1 of the pyramid (half resolution).
// Level texels hold the colour and CoC of the pixels that blur: each pixel weighs
// w = clamp(radius - 0.5, 0, 1), so sharp pixels (whose light stays where it is; the
// full-resolution exact gather draws them) do not leak into the blurred levels. The colour is
// premultiplied by the weight: color_half = sum w c / 4, coc_half = (the nearest blurring
// pixel's CoC, sum w / 4). The nearest, not the mean: a texel across a depth edge (a defocused
// pole before the sky, a card with holes) would take a mean CoC near 0 and keep its mixed light
// sharp, a seam along every such edge (scene A f/2: 5.1% -> 3.4% of the tiles off the
// reference by more than 5%; docs/measurements.md, "The tiled path's picture, tile by tile").
// Also lists the texels holding a highlight candidate (a bright pixel of large CoC) for dof_highlights.comp, which
// tests them against their background. The test has its own dispatch over that short list:
// lavapipe runs both sides of every branch, so a test written here would cost its ring of
// 24 reads for every pixel.
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform writeonly image2D color_half;
layout(binding = 3, rg32f) uniform writeonly image2D coc_half;
layout(binding = 4, std430) buffer Args { uint args[]; };
// Candidate texels, x | y << 16, in any order.
layout(binding = 5, std430) writeonly buffer Candidates { uint candidates[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 half_size;
    float small_radius_px;   // highlights are pixels of a larger CoC radius ...
    float highlight_min;     // ... at least this bright (luminance)
    // Luminance of R, G, B in the frame's colour space: the Y row of its RGB to XYZ matrix
    // (three floats: a vec3 would be aligned to 16 bytes).
    float luminance_r;
    float luminance_g;
    float luminance_b;
} pc;

float luminance(vec3 c) { return dot(c, vec3(pc.luminance_r, pc.luminance_g, pc.luminance_b)); }

void main() {
    ivec2 ph = ivec2(gl_GlobalInvocationID.xy);
    if (outside(ph, pc.half_size)) return;
    vec4 sum = vec4(0.0);
    float weight = 0.0, coc_near = 1e30;
    bool candidate = false;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 p = ph * 2 + ivec2(i, j);
            if (outside(p, pc.size)) continue;
            vec4 c = finite_or_zero(imageLoad(color_in, p));
            float coc = imageLoad(coc_px, p).r;
            float radius = 0.5 * abs(coc);
            candidate = candidate || (radius > pc.small_radius_px && luminance(c.rgb) > pc.highlight_min);
            float w = clamp(radius - 0.5, 0.0, 1.0);
            sum += w * c;
            weight += w;
            if (w > 0.0) coc_near = min(coc_near, coc);
        }
    }
    imageStore(color_half, ph, 0.25 * sum);
    imageStore(coc_half, ph, vec4(weight > 0.0 ? coc_near : 0.0, 0.25 * weight, 0.0, 0.0));
    if (candidate) {
        uint slot = atomicAdd(args[ARGS_HIGHLIGHT_COUNT], 1u);
        candidates[slot] = uint(ph.x) | (uint(ph.y) << 16);
        if (slot % uint(GROUP_SIZE) == 0u) atomicAdd(args[ARGS_HIGHLIGHT_DISPATCH], 1u);
    }
}
