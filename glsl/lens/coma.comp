#version 450
// Coma (left out by Kyaw 2013, sec 7.6): an off-axis point spreads into a comet pointing along
// the radius. Third-order (Seidel) coma sends the pupil point (rho, theta) to the displacement
//     C rho^2 (2 + cos 2 theta, sin 2 theta)      in (radial, tangential) directions,
// so each pupil zone draws a circle of radius C rho^2 centred 2 C rho^2 out: a comet of length
// 3C (the tangential coma, which the lens table gives) and half-width C (the sagittal coma).
//
// Written as a gather: for each pupil sample the source q whose comet sample lands on p solves
// q + C(|q|) (a r_q + b t_q) = p (two fixed-point steps), and is weighted by 1 / det J(q), the
// area the map stretches (J = I + [C' a, -C/h b; C' b, C/h a] in (radial, tangential)), so
// energy is conserved when C changes with height. Sample counts follow the comet's size: about
// one sample per pixel along the comet and around its largest circle.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
// [heights mm (n), tangential coma mm (n)]
layout(binding = 2, std430) readonly buffer Table { float table[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    vec2 centre_px;
    float pixel_pitch_mm;
    int entries;
    float max_coma_px;   // the table's largest |tangential coma| in px (sets the sample counts)
    int band_top_px;     // the image is the band of the frame from this row (centre_px: the frame's)
} pc;

#include "height_table.glsl"

// Sagittal coma C (px) at a height in px: a third of the tangential coma.
float coma_c_px(float h_px) {
    return height_table_lookup(1, pc.entries, h_px * pc.pixel_pitch_mm) / (3.0 * pc.pixel_pitch_mm);
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

// C near p, linear in the height: the table is linear between its entries (millimetres, tens
// of pixels apart), so this is exact unless a comet straddles an entry, and it keeps the table
// lookups out of the sample loop.
float c_at_p, c_slope, h_at_p;
float c_near(float h) { return c_at_p + c_slope * (h - h_at_p); }

// Displacement of pupil sample (a, b) for a source at q (relative to the centre).
vec2 displacement(vec2 q, float a, float b) {
    float h = length(q);
    if (h < 1e-6) return vec2(0.0);
    vec2 r = q / h;
    return c_near(h) * (a * r + b * vec2(-r.y, r.x));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec2 x = vec2(p + ivec2(0, pc.band_top_px)) + 0.5 - pc.centre_px;
    // Samples for the largest comet that can reach p (comets near p are about as large).
    float h_p = length(x);
    float c_max = max(abs(coma_c_px(h_p)),
                      max(abs(coma_c_px(max(h_p - pc.max_coma_px, 0.0))), abs(coma_c_px(h_p + pc.max_coma_px))));
    if (c_max < 0.02) {
        imageStore(color_out, p, imageLoad(color_in, p));
        return;
    }
    h_at_p = h_p;
    c_at_p = coma_c_px(h_p);
    float lo = max(h_p - 0.5, 0.0);
    c_slope = (coma_c_px(h_p + 0.5) - coma_c_px(lo)) / (h_p + 0.5 - lo);
    int n_rho = clamp(int(ceil(3.0 * c_max)), 2, 48);
    int n_theta = clamp(int(ceil(2.0 * PI * c_max)), 4, 96);
    vec4 sum = vec4(0.0);
    for (int i = 0; i < n_rho; ++i) {
        float rho2 = (float(i) + 0.5) / float(n_rho);   // equal-area zones: rho^2 uniform
        for (int j = 0; j < n_theta; ++j) {
            float t2 = 2.0 * PI * (float(j) + 0.5) / float(n_theta);   // 2 theta over a full turn
            float a = rho2 * (2.0 + cos(t2));
            float b = rho2 * sin(t2);
            vec2 q = x - displacement(x, a, b);
            q = x - displacement(q, a, b);
            // Area factor of the map q -> p at q.
            float h = max(length(q), 1e-3);
            float c = c_near(h);
            float det = (1.0 + c_slope * a) * (1.0 + c / h * a) + c_slope * (c / h) * b * b;
            sum += bilinear(q + pc.centre_px) / max(det, 1e-3);
        }
    }
    imageStore(color_out, p, finite_or_zero(sum / float(n_rho * n_theta)));
}
