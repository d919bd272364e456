#version 450
// Tiled depth of field, large-CoC tiles: a gather at half resolution with a fixed number of
// taps on rings scaled to the tile's radius, so its cost does not grow with the CoC. Same
// layer rules as the exact gather; the rings are rotated per pixel to turn aliasing into fine
// noise. Writes the background colour and the foreground colour with its coverage (alpha), and
// the same foreground for large-CoC samples only.
#include "common.glsl"
#define APERTURE_MASK_BINDING 6
#include "aperture.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = TILE_SIZE / 2, local_size_y = TILE_SIZE / 2) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_half;
layout(binding = 1, r32f) uniform readonly image2D coc_half;
layout(binding = 2, rgba32f) uniform writeonly image2D bg_half;
layout(binding = 3, rgba32f) uniform writeonly image2D fg_half;
layout(binding = 4, std430) readonly buffer TileLists { uint tile_list[]; };
layout(binding = 5, std430) readonly buffer TileRadius { float tile_radius_px[]; };
layout(binding = 7, rgba32f) uniform writeonly image2D fg_big_half;

layout(push_constant) uniform Push {
    ivec2 half_size;
    ivec2 tiles;
    int rings;
    Aperture ap;
    float layer_transition_px;
    float small_radius_px;      // in half-resolution px: larger CoC samples also go to fg_big
} pc;

void main() {
    uint t = tile_list[CLASS_LARGE * pc.tiles.x * pc.tiles.y + int(gl_WorkGroupID.x)];
    ivec2 ph = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x)) * (TILE_SIZE / 2) + ivec2(gl_LocalInvocationID.xy);
    if (outside(ph, pc.half_size)) return;
    Aperture ap = pc.ap;
    // Half-resolution units: CoC diameters and distances halve.
    float coc_p = 0.5 * imageLoad(coc_half, ph).r;
    float radius_p = max(0.5 * abs(coc_p), 0.5);
    float extent = 0.5 * tile_radius_px[t] + 1.0;
    float spacing = extent / float(pc.rings);
    float ramp = max(spacing, 1.0);
    // Interleaved gradient noise: a per-pixel rotation of the rings.
    float jitter = fract(52.9829189 * fract(dot(vec2(ph), vec2(0.06711056, 0.00583715))));

    vec4 bg = vec4(0.0), fg = vec4(0.0), fg_big = vec4(0.0);
    float bg_w = 0.0, fg_w = 0.0, fg_big_w = 0.0;
    for (int k = 0; k <= pc.rings; ++k) {
        int n = k == 0 ? 1 : 6 * k;
        float rho = float(k) * spacing;
        // Area each tap stands for: the centre disk, or an equal share of the ring's annulus.
        float tap_area = k == 0 ? PI * 0.25 * spacing * spacing : PI * spacing * spacing / 3.0;
        for (int j = 0; j < n; ++j) {
            float theta = (float(j) + jitter) * 2.0 * PI / float(n);
            ivec2 q_unclamped = ph + ivec2(round(rho * vec2(cos(theta), sin(theta))));
            // Beyond the frame the edge pixels continue, as in the exact gather.
            ivec2 q = clamp(q_unclamped, ivec2(0), pc.half_size - 1);
            float coc_q = 0.5 * imageLoad(coc_half, q).r;
            float radius_q = max(0.5 * abs(coc_q), 0.5);
            float reach = coc_q > coc_p ? min(radius_q, radius_p) : radius_q;
            float flip = coc_q < 0.0 ? -1.0 : 1.0;
            vec2 o = vec2(ph - q_unclamped) * flip;
            float w = tap_area * aperture_weight(o, reach, ap, vec2(q_unclamped) + 0.5, flip, ramp)
                * sa_intensity(length(o) / radius_q, sa_strength(coc_q, ap));
            if (w <= 0.0) continue;
            vec4 c = imageLoad(color_half, q);
            float f = clamp((coc_p - coc_q) / pc.layer_transition_px, 0.0, 1.0);
            fg += (f * w) * c;
            fg_w += f * w;
            if (radius_q > pc.small_radius_px) {
                fg_big += (f * w) * c;
                fg_big_w += f * w;
            }
            bg += ((1.0 - f) * w) * c;
            bg_w += (1.0 - f) * w;
        }
    }
    vec4 background = bg_w > 0.0 ? bg / bg_w : imageLoad(color_half, ph);
    vec4 foreground = fg_w > 0.0 ? fg / fg_w : vec4(0.0);
    imageStore(bg_half, ph, background);
    imageStore(fg_half, ph, vec4(foreground.rgb, clamp(fg_w, 0.0, 1.0)));
    // The foreground of large-CoC samples only: what nearly sharp pixels, whose exact gather
    // already holds the small ones, composite over themselves.
    vec4 big = fg_big_w > 0.0 ? fg_big / fg_big_w : vec4(0.0);
    imageStore(fg_big_half, ph, vec4(big.rgb, clamp(fg_big_w, 0.0, 1.0)));
}
