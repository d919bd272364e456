#version 450
// Distortion and lateral colour (Kyaw 2013 eq 6.8, sec 6.4): every output pixel, at real height
// R on the film, reads the input at the ideal height r with r (1 + D(r)/100) = R, per channel
// (red and blue carry their extra lateral-colour distortion), bilinearly; so barrel and
// pincushion are exact inverse mappings with no holes.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
// [heights (n), green %, red extra %, blue extra %], n each.
layout(binding = 2, std430) readonly buffer Table { float table[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    vec2 centre_px;
    float pixel_pitch_mm;
    int entries;
    int band_top_px;   // the image is the band of the frame from this row (centre_px: the frame's)
} pc;

#include "height_table.glsl"

float percent(int channel, float r_mm) {
    float g = height_table_lookup(1, pc.entries, r_mm);
    if (channel == 0) return g + height_table_lookup(2, pc.entries, r_mm);
    if (channel == 2) return g + height_table_lookup(3, pc.entries, r_mm);
    return g;
}

vec4 load_clamped(ivec2 q) { return imageLoad(color_in, clamp(q, ivec2(0), pc.size - 1)); }

// At x in the whole frame's pixels; the image is the band from row pc.band_top_px (the frame:
// 0), so a band weighs its texels exactly as the whole frame's render.
vec4 bilinear(vec2 x) {
    vec2 t = x - 0.5;
    ivec2 i = ivec2(floor(t));
    vec2 f = t - vec2(i);
    i.y -= pc.band_top_px;
    return mix(mix(load_clamped(i), load_clamped(i + ivec2(1, 0)), f.x),
               mix(load_clamped(i + ivec2(0, 1)), load_clamped(i + ivec2(1, 1)), f.x), f.y);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec2 d = vec2(p + ivec2(0, pc.band_top_px)) + 0.5 - pc.centre_px;
    float real_mm = length(d) * pc.pixel_pitch_mm;
    vec4 out_color = imageLoad(color_in, p);
    for (int c = 0; c < 3; ++c) {
        // Fixed-point inverse of eq 6.8 (src/optics/distortion.rs). It contracts by about the
        // distortion's slope per step (a few percent), so it stops once a step moves r by less
        // than float precision, usually after 3 to 5 steps.
        float r = real_mm;
        for (int k = 0; k < 12; ++k) {
            float next = real_mm / (1.0 + percent(c, r) / 100.0);
            bool done = abs(next - r) <= 2.0e-7 * real_mm;
            r = next;
            if (done) break;
        }
        float scale = real_mm > 0.0 ? r / real_mm : 1.0;
        out_color[c] = bilinear(pc.centre_px + d * scale)[c];
    }
    imageStore(color_out, p, finite_or_zero(out_color));
}
