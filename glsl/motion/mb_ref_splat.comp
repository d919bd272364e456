#version 450
// Motion blur reference, step 1 of each sub-frame time t: every source texel moves along its own
// path (glsl/include/motion.glsl) to where it is at t, and the nearest one landing on each
// pixel wins. Stage 0 takes the smallest depth per landing pixel (atomicMin on the float's
// bits: positive floats order as their bits); stage 1 takes, among the texels at that depth,
// the lowest index. Only pixels whose own (rolling) shutter is open at t take anything.
#include "common.glsl"
#include "motion.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, r32f) uniform readonly image2D depth_m;
layout(binding = 1, rgba32f) uniform readonly image2D velocity;
layout(binding = 2, std430) buffer LandingDepth { uint landing_depth[]; };
layout(binding = 3, std430) buffer LandingIndex { uint landing_index[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    Shutter shutter;
    float max_speed_px;
    float t_frames;
    int stage;
} pc;

void main() {
    ivec2 y = ivec2(gl_GlobalInvocationID.xy);
    if (outside(y, pc.size)) return;
    vec4 v = imageLoad(velocity, y);
    vec2 move = pc.t_frames >= 0.0 ? pc.t_frames * clamp_speed(v.xy, pc.max_speed_px)
                                   : -pc.t_frames * clamp_speed(v.zw, pc.max_speed_px);
    // Where it lands, in the frame's rows (a band's from its first row), as the frame's render.
    ivec2 band = ivec2(0, pc.shutter.band_top_px);
    precise vec2 at = vec2(y + band) + 0.5 + move;
    ivec2 l = ivec2(floor(at)) - band;
    if (outside(l, pc.size)) return;
    vec2 win = shutter_window(pc.shutter, vec2(l) + 0.5);
    if (pc.t_frames < win.x || pc.t_frames > win.y) return;
    uint z = floatBitsToUint(clamp(imageLoad(depth_m, y).r, 0.0, 3.0e38));
    uint i = uint(l.y * pc.size.x + l.x);
    if (pc.stage == 0) {
        atomicMin(landing_depth[i], z);
    } else if (landing_depth[i] == z) {
        atomicMin(landing_index[i], uint(y.y * pc.size.x + y.x));
    }
}
