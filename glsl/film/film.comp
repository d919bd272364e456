#version 450
// Exposure and film response. The sensor value is H / H_sat (Kyaw 2013 eq 4.1 and 4.9, with the
// saturation-based ISO speed), computed on the CPU as one gain. Then either the film's
// characteristic curve on log exposure (toe, straight part, shoulder; Kyaw 2013 sec 4.5) or,
// for compositing, the scene-referred linear value. Optional sensor noise, before the curve:
// shot-noise-like (standard deviation sigma * sqrt(value)), sigma growing with the square root of
// the ISO speed, from a hash of the pixel, the channel and a seed: deterministic. A film file may
// give the curve as a table instead (log10 sensor value against log10 output, linear between
// entries, constant beyond the ends; src/io/film_file.rs). Where the vignette pass runs, its
// falloff is applied here first (include/vignette.glsl): one read and write of the frame fewer
// than a dispatch of its own.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
// [log10 sensor values (n), log10 outputs (n)] when RESPONSE == 2; then, with VIGNETTE, the
// vignette's table from word vignette_base (its heights and relative illumination).
layout(binding = 2, std430) readonly buffer Table { float table[]; };

// The run's path, specialised (src/passes/film/mod.rs, FilmPush::specialization) so the pipeline
// holds only it: lavapipe runs both sides of every branch, and the curve and the noise cost
// more than the rest of the pass.
layout(constant_id = 0) const int RESPONSE = 1;  // 0: linear (scene-referred), 1: characteristic curve, 2: table
layout(constant_id = 1) const bool NOISE = true; // noise_sigma > 0
layout(constant_id = 2) const bool VIGNETTE = false; // vignette != 0

layout(push_constant) uniform Push {
    ivec2 size;
    float exposure_gain;
    int use_curve;                  // the value RESPONSE is specialised to
    float log10_mid_in;
    float log10_mid_out;
    float contrast;
    float toe_softness_decades;
    float shoulder_softness_decades;
    float log10_black_out;
    float log10_white_out;
    float noise_sigma;              // at sensor value 1; 0: no noise
    uint seed;
    int table_entries;
    int vignette;                   // 1: the vignette's falloff first (VIGNETTE); its constants:
    float vignette_centre_x_px;
    float vignette_centre_y_px;
    float vignette_pixel_pitch_mm;
    float vignette_image_distance_mm;
    int vignette_entries;           // 0: cos^4
    int vignette_base;              // the vignette's first word in `table`
    int band_top_px;                // a band's first row in the whole frame (the grain's row)
} pc;

#include "height_table.glsl"
#include "vignette.glsl"

uint hash(uint x) {
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

// A standard normal value for (pixel, channel), Box-Muller on two hashed uniforms.
float gaussian(ivec2 p, int c) {
    uint h1 = hash(uint(p.x) * 73856093u ^ uint(p.y + pc.band_top_px) * 19349663u ^ uint(c) * 83492791u ^ pc.seed);
    uint h2 = hash(h1 ^ 0x9e3779b9u);
    float u1 = (float(h1 >> 8) + 0.5) / 16777216.0;
    float u2 = float(h2 >> 8) / 16777216.0;
    return sqrt(-2.0 * log(u1)) * cos(2.0 * PI * u2);
}

// Smooth maximum in decades: max(a, b) + k*log10(1 + 10^(-|a-b|/k)); k > 0.
float smooth_max(float a, float b, float k) {
    return max(a, b) + k * log(1.0 + exp(-abs(a - b) / k * log(10.0))) / log(10.0);
}

float characteristic_curve(float sensor_value) {
    float lb = pc.log10_black_out, lw = pc.log10_white_out;
    float x = log(clamp(sensor_value, 1.0e-30, 1.0e30)) / log(10.0);
    // Straight part, then the shoulder (soft minimum with white) and the toe (soft maximum with
    // black), then a rescale so the curve ends exactly at white (src/optics/film.rs).
    float y = pc.log10_mid_out + pc.contrast * (x - pc.log10_mid_in);
    y = -smooth_max(-y, -lw, pc.shoulder_softness_decades);
    y = smooth_max(y, lb, pc.toe_softness_decades);
    float ceiling = smooth_max(lw, lb, pc.toe_softness_decades);
    y = lb + (y - lb) * ((lw - lb) / (ceiling - lb));
    return pow(10.0, clamp(y, lb, lw));
}

float table_curve(float sensor_value) {
    int n = pc.table_entries;
    float x = log(clamp(sensor_value, 1.0e-30, 1.0e30)) / log(10.0);
    float y = table[2 * n - 1];
    if (x <= table[0]) {
        y = table[n];
    } else {
        for (int i = 1; i < n; ++i) {
            if (x <= table[i]) {
                y = mix(table[n + i - 1], table[n + i], (x - table[i - 1]) / (table[i] - table[i - 1]));
                break;
            }
        }
    }
    return pow(10.0, y);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec4 c = finite_or_zero(imageLoad(color_in, p));
    vec3 rgb = c.rgb;
    if (VIGNETTE) {
        rgb *= vignette_falloff(p, vec2(pc.vignette_centre_x_px, pc.vignette_centre_y_px), pc.vignette_pixel_pitch_mm,
                                pc.vignette_image_distance_mm, pc.vignette_base, pc.vignette_entries);
    }
    vec3 h = rgb * pc.exposure_gain;
    if (NOISE) {
        for (int k = 0; k < 3; ++k) h[k] += pc.noise_sigma * sqrt(max(h[k], 0.0)) * gaussian(p, k);
    }
    if (RESPONSE == 1) {
        h = vec3(characteristic_curve(h.r), characteristic_curve(h.g), characteristic_curve(h.b));
    } else if (RESPONSE == 2) {
        h = vec3(table_curve(h.r), table_curve(h.g), table_curve(h.b));
    }
    imageStore(color_out, p, vec4(h, c.a));
}
