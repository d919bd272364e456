#version 450
// Exposure and film response. The sensor value is H / H_sat (Kyaw 2013 eq 4.1 and 4.9, with the
// saturation-based ISO speed), computed on the CPU as one gain. Then either the film's
// characteristic curve on log exposure (toe, straight part, shoulder; Kyaw 2013 sec 4.5) or,
// for compositing, the scene-referred linear value.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;

layout(push_constant) uniform Push {
    ivec2 size;
    float exposure_gain;
    int use_curve;                  // 0: linear (scene-referred), 1: characteristic curve
    float log10_mid_in;
    float log10_mid_out;
    float contrast;
    float toe_softness_decades;
    float shoulder_softness_decades;
    float log10_black_out;
    float log10_white_out;
} pc;

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

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec4 c = finite_or_zero(imageLoad(color_in, p));
    vec3 h = c.rgb * pc.exposure_gain;
    if (pc.use_curve != 0) {
        h = vec3(characteristic_curve(h.r), characteristic_curve(h.g), characteristic_curve(h.b));
    }
    imageStore(color_out, p, vec4(h, c.a));
}
