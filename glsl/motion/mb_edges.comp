#version 450
// Motion blur, step 0b: the anti-aliased-edge resolve of the velocity and depth, one invocation
// per pixel of the list glsl/motion/mb_edge_list.comp wrote (an indirect dispatch,
// MB_EDGE_GROUP_SIZE pixels per workgroup); that pass already copied every pixel's velocity and
// depth as stored. Renderers filter the colour pass but take depth and vectors from one sample
// per pixel: a static highlight's fringe pixel holds 30% highlight and 70% moving sphere in
// colour but 100% sphere in velocity, and the blur then drags the highlight's light along the
// sphere's path (issue 30; the other way round, a moving object's fringe over a still background
// is held still). A listed pixel's 3x3 neighbourhood spans two depth layers whose motions differ
// by more than half a pixel over the open time; glsl/include/edge_layers.glsl decides which
// layer's light the pixel holds (the depth of field's coc_edges decides the same way), and a
// pixel that holds mostly the other layer's light (at least `min_share` of it) takes that layer's
// mean velocity and inverse depth. The changed pixels are counted (`--explain` gives the count).
// It reads only the inputs, which no one writes meanwhile, and writes only listed pixels, each
// listed once.
#include "common.glsl"
#include "motion.glsl"
#include "edge_layers.glsl"

layout(local_size_x = MB_EDGE_GROUP_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D depth_m;
layout(binding = 2, rgba32f) uniform readonly image2D velocity; // next.xy, prev.xy px per frame
layout(binding = 3, rgba32f) uniform writeonly image2D velocity_out;
layout(binding = 4, r32f) uniform writeonly image2D depth_out;
layout(binding = 5, std430) buffer Args { uint args[]; }; // [MB_EDGE_ARGS_CHANGED]: counted up here
layout(binding = 6, std430) readonly buffer EdgePixels { uint edge_pixels[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    float t_fwd;        // frames the shutter is open after the frame time (at most)
    float t_back;       // and before it
    float max_speed_px;
    float min_share;
} pc;

// The layer key: inverse depth (larger is nearer), of a depth kept finite and positive.
float layer_key(float z) { return 1.0 / clamp(z, 1.0e-6, 1.0e30); }

vec4 clamped_velocity(vec4 v) {
    return vec4(clamp_speed(v.xy, pc.max_speed_px), clamp_speed(v.zw, pc.max_speed_px));
}

void main() {
    uint slot = gl_GlobalInvocationID.x;
    if (slot >= args[MB_EDGE_ARGS_COUNT]) return;
    ivec2 p = mb_unpack_pixel(edge_pixels[slot]);
    float w[9];
    vec4 v9[9];
    vec3 c9[9];
    float w_near = layer_key(imageLoad(depth_m, p).r), w_far = w_near;
    for (int i = 0; i < 9; ++i) {
        ivec2 q = clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), pc.size - 1);
        w[i] = layer_key(imageLoad(depth_m, q).r);
        v9[i] = clamped_velocity(imageLoad(velocity, q));
        c9[i] = finite_or_zero(imageLoad(color_in, q)).rgb;
        w_near = max(w_near, w[i]);
        w_far = min(w_far, w[i]);
    }
    int layer = edge_layer(w, c9, c9[4], w_near, w_far, pc.min_share);
    if (layer == EDGE_OWN) return;
    float w_mid = 0.5 * (w_near + w_far);
    vec4 v_sum = vec4(0.0);
    float w_sum = 0.0, n = 0.0;
    for (int i = 0; i < 9; ++i) {
        if (i == 4 || (w[i] > w_mid) != (layer == EDGE_NEAR)) continue;
        v_sum += v9[i];
        w_sum += w[i];
        n += 1.0;
    }
    imageStore(velocity_out, p, v_sum / n);
    imageStore(depth_out, p, vec4(1.0 / (w_sum / n), 0.0, 0.0, 0.0));
    atomicAdd(args[MB_EDGE_ARGS_CHANGED], 1u);
}
