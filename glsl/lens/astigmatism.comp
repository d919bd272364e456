#version 450
// Astigmatism (Kyaw 2013 sec 6.3.3; the aberration passes of sec 7.3 and appendix 11.4): a 1D
// box blur along the tangential direction (perpendicular to the radius) or the sagittal one
// (along the radius), as long as the lens's table says at this image height. The number of
// samples follows the blur's length (one per pixel), so a long blur is not undersampled.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
// [heights (n), tangential blur mm (n), sagittal blur mm (n)]
layout(binding = 2, std430) readonly buffer Table { float table[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    vec2 centre_px;
    float pixel_pitch_mm;
    int entries;
    int direction;   // 0: tangential, 1: sagittal
    int band_top_px; // the image is the band of the frame from this row (centre_px: the frame's)
} pc;

#include "height_table.glsl"

float blur_mm(float h_mm) { return height_table_lookup(1 + pc.direction, pc.entries, h_mm); }

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
    ivec2 pw = p + ivec2(0, pc.band_top_px);
    vec2 d = vec2(pw) + 0.5 - pc.centre_px;
    float h_px = length(d);
    float length_px = blur_mm(h_px * pc.pixel_pitch_mm) / pc.pixel_pitch_mm;
    if (length_px <= 0.0 || h_px == 0.0) {
        imageStore(color_out, p, imageLoad(color_in, p));
        return;
    }
    vec2 radial = d / h_px;
    vec2 axis = pc.direction == 0 ? vec2(-radial.y, radial.x) : radial;
    // n samples at the centres of n equal parts of [-L/2, L/2], at most one pixel apart, so the
    // box is L long whatever n is.
    int n = max(1, int(ceil(length_px)));
    vec4 sum = vec4(0.0);
    for (int i = 0; i < n; ++i) {
        float s = ((float(i) + 0.5) / float(n) - 0.5) * length_px;
        sum += bilinear(vec2(pw) + 0.5 + s * axis);
    }
    imageStore(color_out, p, finite_or_zero(sum / float(n)));
}
