#version 450
// Longitudinal (axial) colour: the depth of field ran once per channel, each with its own CoC
// (the channel's focus shifted from green's); this pass takes red from the red run, green and
// alpha from the green run, blue from the blue run.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D red_run;
layout(binding = 1, rgba32f) uniform readonly image2D green_run;
layout(binding = 2, rgba32f) uniform readonly image2D blue_run;
layout(binding = 3, rgba32f) uniform writeonly image2D color_out;

layout(push_constant) uniform Push { ivec2 size; } pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec4 g = imageLoad(green_run, p);
    imageStore(color_out, p, vec4(imageLoad(red_run, p).r, g.g, imageLoad(blue_run, p).b, g.a));
}
