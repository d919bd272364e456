#version 450
// Potmesil & Chakravarty 1981 focus processor (sec. 3.2, eq 20) as a gather: every input pixel
// is a point source whose diffraction pattern (eq 13), integrated over the pixels, is read
// from the lookup tables of its depth, linearly interpolated between the two nearest levels.
// Output pixel p sums, over the sources q within the table radius, weight(q, p - q) * color(q)
// per channel (the numerators) and the weights themselves (the denominators: the density of
// samples around p seen through each channel's pattern, which normalises the image borders;
// one per channel since the patterns differ by wavelength), then divides. No float atomics,
// no occlusion (every source spreads regardless of depth order: the paper's model).
// CPU reference: src/optics/focus_processor.rs (process_cpu); tables and layout: build_tables.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D depth_m;
layout(binding = 2, rgba32f) uniform writeonly image2D color_out;
// [level][channel 0..3][sub-pixel offset][(2R+1)^2]; only offset 0 (pixel centres) is read.
layout(binding = 3, std430) readonly buffer Tables { float psf_table[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    int radius_px;        // R: tables are (2R+1)^2
    int levels;
    int subpixel;         // offsets per axis in the table layout (stride only)
    int knot_level;       // level at defocus_knot (the focus distance when inside the range)
    float inv_focus_per_m;            // 1/S
    float defocus_near_per_m;         // w = 1/S - 1/u of level 0
    float defocus_far_per_m;          // w of the last level
    float defocus_knot_per_m;         // w of the knot level
    float near_levels_per_defocus_m;  // levels per unit w below the knot
    float far_levels_per_defocus_m;   // levels per unit w above the knot
} pc;

// Fractional level of a depth (metres): LevelMapping::coordinate in f32. Depths beyond the
// range clamp to the end levels: u <= 0 (and nearer than the nearest level) to level 0,
// NaN and +inf to the last.
float level_coordinate(float depth) {
    float inv_depth = isnan(depth) ? 0.0 : 1.0 / max(depth, 1.0e-30);
    float w = clamp(pc.inv_focus_per_m - inv_depth, pc.defocus_near_per_m, pc.defocus_far_per_m);
    float x = w < pc.defocus_knot_per_m
        ? (w - pc.defocus_near_per_m) * pc.near_levels_per_defocus_m
        : float(pc.knot_level) + (w - pc.defocus_knot_per_m) * pc.far_levels_per_defocus_m;
    return clamp(x, 0.0, float(pc.levels - 1));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    int r = pc.radius_px;
    int side = 2 * r + 1;
    int channel_stride = pc.subpixel * pc.subpixel * side * side;
    int level_stride = 3 * channel_stride;
    vec3 numerator = vec3(0.0);
    vec3 denominator = vec3(0.0);
    // The tables are cut at a circle of radius <= R + 1/2 around the point: entries whose
    // pixel centre lies farther than that plus half a pixel diagonal are exactly zero.
    float reach = float(r) + 1.25;
    for (int dy = -r; dy <= r; ++dy) {
        int qy = p.y - dy;
        if (qy < 0 || qy >= pc.size.y) continue;
        for (int dx = -r; dx <= r; ++dx) {
            int qx = p.x - dx;
            if (qx < 0 || qx >= pc.size.x || float(dx * dx + dy * dy) > reach * reach) continue;
            ivec2 q = ivec2(qx, qy);
            // The source q reaches p at table entry (dx, dy) = p - q.
            float x = level_coordinate(imageLoad(depth_m, q).r);
            int l0 = min(int(floor(x)), pc.levels - 1);
            int l1 = min(l0 + 1, pc.levels - 1);
            float t = x - float(l0);
            int e = (dy + r) * side + (dx + r);
            int b0 = l0 * level_stride + e;
            int b1 = l1 * level_stride + e;
            vec3 w0 = vec3(psf_table[b0], psf_table[b0 + channel_stride], psf_table[b0 + 2 * channel_stride]);
            vec3 w1 = vec3(psf_table[b1], psf_table[b1 + channel_stride], psf_table[b1 + 2 * channel_stride]);
            vec3 w = (1.0 - t) * w0 + t * w1;
            vec3 c = finite_or_zero(imageLoad(color_in, q)).rgb;
            numerator += w * c;
            denominator += w;
        }
    }
    vec3 rgb = mix(vec3(0.0), numerator / max(denominator, vec3(1.0e-30)), greaterThan(denominator, vec3(0.0)));
    imageStore(color_out, p, vec4(rgb, imageLoad(color_in, p).a));
}
