#version 450
// Vignetting: the lens's relative-illumination table against image height when it has one
// (natural and optical vignetting as measured), else the cos^4 law of illumination (Kyaw 2013
// eq 4.14, from eq 4.9) with the real field angle theta = atan(r / v), r the image height on the
// film and v the image distance.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
// [heights (entries), relative illumination (entries)]; entries = 0: cos^4.
layout(binding = 2, std430) readonly buffer Table { float table[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    vec2 centre_px;            // optical centre in this image's pixel coordinates
    float pixel_pitch_mm;
    float image_distance_mm;
    int entries;
} pc;

#include "height_table.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec2 r_mm = (vec2(p) + 0.5 - pc.centre_px) * pc.pixel_pitch_mm;
    float t2 = dot(r_mm, r_mm) / (pc.image_distance_mm * pc.image_distance_mm);
    // cos^4(atan(t)) = 1 / (1 + t^2)^2, without trigonometry.
    float falloff = 1.0 / ((1.0 + t2) * (1.0 + t2));
    // The lens's table where it has one, in a loop of one trip or none: lavapipe evaluates both
    // sides of a conditional whatever the condition (and the lookup, given no table, read the
    // word before it), but leaves a loop that no lane is in.
    for (int once = 0; once < min(pc.entries, 1); ++once) falloff = height_table_lookup(1, pc.entries, length(r_mm));
    vec4 c = imageLoad(color_in, p);
    imageStore(color_out, p, vec4(c.rgb * falloff, c.a));
}
