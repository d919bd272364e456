#version 450
// Vignetting (include/vignette.glsl) as a pass of its own: where the film pass runs, the falloff
// is applied in its dispatch instead (src/passes/lens/vignette.rs), one read and write of the frame
// fewer.
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
#include "vignette.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    float falloff = vignette_falloff(p, pc.centre_px, pc.pixel_pitch_mm, pc.image_distance_mm, 0, pc.entries);
    vec4 c = imageLoad(color_in, p);
    imageStore(color_out, p, vec4(c.rgb * falloff, c.a));
}
