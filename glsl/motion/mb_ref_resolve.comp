#version 450
// Motion blur reference, step 2 of each sub-frame time t: every pixel adds what it shows at t,
// weighted by its shutter curve at t (midpoint rule over the sub-frame times), to its running
// sum; the last time writes the average. What landed (mb_ref_splat) is shown; a pixel nothing
// landed on shows what the pinhole image hides there: the nearest farther texel on the line of
// its own motion (the background its surface moved off), else the mean of what landed on its
// neighbours, else its own texel.
#include "common.glsl"
#include "motion.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D depth_m;
layout(binding = 2, rgba32f) uniform readonly image2D velocity;
layout(binding = 3, rgba32f) uniform image2D accum;     // rgb: weighted sum, a: weights
layout(binding = 4, rgba32f) uniform writeonly image2D color_out;
layout(binding = 5, std430) readonly buffer LandingIndex { uint landing_index[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    Shutter shutter;
    float max_speed_px;
    float t_frames;
    float dt_frames;
    int first;
    int last;
} pc;

const uint NONE = 0xffffffffu;

vec4 texel(uint index) {
    return finite_or_zero(imageLoad(color_in, ivec2(int(index) % pc.size.x, int(index) / pc.size.x)));
}

// What a pixel nothing landed on shows.
vec4 hidden(ivec2 p) {
    vec4 v = imageLoad(velocity, p);
    vec2 dir = pc.t_frames >= 0.0 ? clamp_speed(v.xy, pc.max_speed_px) : clamp_speed(v.zw, pc.max_speed_px);
    float reach = length(dir) * abs(pc.t_frames) + 2.0;
    float len = length(dir);
    float z = imageLoad(depth_m, p).r;
    if (len > 0.0) {
        dir /= len;
        int steps = int(ceil(reach));
        for (int k = 1; k <= steps; ++k) {
            for (int side = 0; side < 2; ++side) {
                // In the frame's rows (a band's from its first row), as the frame's render.
                ivec2 band = ivec2(0, pc.shutter.band_top_px);
                ivec2 q = ivec2(floor(vec2(p + band) + 0.5 + (side == 0 ? 1.0 : -1.0) * float(k) * dir)) - band;
                if (outside(q, pc.size)) continue;
                if (depth_classes(z, imageLoad(depth_m, q).r).z >= 1.0) {
                    return finite_or_zero(imageLoad(color_in, q));
                }
            }
        }
    }
    vec4 sum = vec4(0.0);
    float n = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = p + ivec2(dx, dy);
            if (outside(q, pc.size)) continue;
            uint i = landing_index[q.y * pc.size.x + q.x];
            if (i != NONE) {
                sum += texel(i);
                n += 1.0;
            }
        }
    }
    return n > 0.0 ? sum / n : finite_or_zero(imageLoad(color_in, p));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec4 acc = pc.first != 0 ? vec4(0.0) : imageLoad(accum, p);
    vec2 win = shutter_window(pc.shutter, vec2(p) + 0.5);
    float len = win.y - win.x;
    float ramp = pc.shutter.ramp_frames;
    // The shutter curve's height at t, times the step: the light of this sub-frame time.
    float half_step = 0.5 * pc.dt_frames;
    float w = shutter_cdf(pc.t_frames + half_step - win.x, len, ramp) - shutter_cdf(pc.t_frames - half_step - win.x, len, ramp);
    if (w > 0.0) {
        uint i = landing_index[p.y * pc.size.x + p.x];
        vec4 c = i != NONE ? texel(i) : hidden(p);
        acc += vec4(w * c.rgb, w);
    }
    if (pc.last != 0) {
        vec4 own = finite_or_zero(imageLoad(color_in, p));
        imageStore(color_out, p, acc.a > 0.0 ? vec4(acc.rgb / acc.a, own.a) : own);
    } else {
        imageStore(accum, p, acc);
    }
}
