#version 450
// Tiled depth of field, step 3: the half-resolution colour and CoC for the large-CoC path, and
// the highlights: a pixel with a large CoC much brighter than its neighbours gives its excess
// energy to a sprite (scattered with the exact aperture shape by dof_sprites.comp) instead of
// to the sparse half-resolution gather, which could not draw a crisp bokeh shape from it. Also
// writes the full-resolution colour without the sprites' energy.
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform writeonly image2D color_half;
layout(binding = 3, r32f) uniform writeonly image2D coc_half;
layout(binding = 4, std430) buffer Args { uint args[]; };
layout(binding = 5, std430) writeonly buffer Sprites { Sprite sprites[]; };
// The full-resolution colour less the energy given to sprites: what the large tiles' exact
// gather (dof_composite) reads, so a highlight is not counted twice.
layout(binding = 6, rgba32f) uniform writeonly image2D color_base;

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 half_size;
    float small_radius_px;
    float highlight_min;     // a highlight is at least this bright (luminance) ...
    float highlight_ratio;   // ... and this many times its neighbours' mean
    int sprite_capacity;
    float sprite_visibility;  // smallest visible excess per pixel, relative to the surroundings
} pc;

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

void main() {
    ivec2 ph = ivec2(gl_GlobalInvocationID.xy);
    if (outside(ph, pc.half_size)) return;
    vec4 sum = vec4(0.0);
    float coc_sum = 0.0;
    float n = 0.0;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 p = ph * 2 + ivec2(i, j);
            if (outside(p, pc.size)) continue;
            vec4 c = finite_or_zero(imageLoad(color_in, p));
            float coc = imageLoad(coc_px, p).r;
            float lum = luminance(c.rgb);
            if (0.5 * abs(coc) > pc.small_radius_px && lum > pc.highlight_min) {
                // The surroundings: the ring of pixels 3 px away, so a highlight a few pixels
                // wide (a small bright sphere) is measured against what is around it, not
                // against its own other pixels.
                float neighbours = 0.0, count = 0.0;
                for (int k = -3; k < 3; ++k) {
                    ivec2 ring[4] = ivec2[4](ivec2(k, -3), ivec2(3, k), ivec2(-k, 3), ivec2(-3, -k));
                    for (int m = 0; m < 4; ++m) {
                        ivec2 q = p + ring[m];
                        if (outside(q, pc.size)) continue;
                        neighbours += luminance(finite_or_zero(imageLoad(color_in, q)).rgb);
                        count += 1.0;
                    }
                }
                float mean = neighbours / max(count, 1.0);
                float reference = max(pc.highlight_min, pc.highlight_ratio * mean);
                // A sprite is worth drawing only if its disk stands out: the excess spread over
                // the CoC's area must be a visible fraction of the surroundings. A faint disk is
                // left to the gather (its shape would not show), which keeps the scatter's cost
                // from growing with the square of the CoC.
                float area = PI * 0.25 * coc * coc;
                bool visible = (lum - reference) / max(area, 1.0) > pc.sprite_visibility * max(mean, pc.highlight_min * 0.01);
                if (lum > reference && visible) {
                    vec3 excess = c.rgb * (1.0 - reference / lum);
                    uint slot = atomicAdd(args[ARGS_SPRITE_COUNT], 1u);
                    if (slot < uint(pc.sprite_capacity)) {
                        sprites[slot] = Sprite(vec2(p) + 0.5, coc, 0.0, vec4(excess, 0.0));
                        c.rgb -= excess;
                    } else {
                        atomicAdd(args[ARGS_SPRITES_DROPPED], 1u);
                    }
                }
            }
            imageStore(color_base, p, c);
            sum += c;
            coc_sum += coc;
            n += 1.0;
        }
    }
    imageStore(color_half, ph, sum / max(n, 1.0));
    imageStore(coc_half, ph, vec4(coc_sum / max(n, 1.0)));
}
