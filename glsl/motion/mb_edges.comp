#version 450
// Motion blur, step 0: the anti-aliased-edge resolve of the velocity and depth. Renderers filter
// the colour pass but take depth and vectors from one sample per pixel: a static highlight's
// fringe pixel holds 30% highlight and 70% moving sphere in colour but 100% sphere in velocity,
// and the blur then drags the highlight's light along the sphere's path (issue 30; the other way
// round, a moving object's fringe over a still background is held still). Where a pixel's 3x3
// neighbourhood spans two depth layers (7% apart, where depth_classes parts them fully) whose
// motions differ by more than half a pixel over the open time, glsl/include/edge_layers.glsl
// decides which layer's light the pixel holds (the depth of field's coc_edges decides the same
// way), and a pixel that holds mostly the other layer's light (at least `min_share` of it) takes
// that layer's mean velocity and inverse depth. Every other pixel's velocity and depth are copied
// as stored. The changed pixels are counted (`--explain` gives the count).
#include "common.glsl"
#include "motion.glsl"
#include "edge_layers.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D depth_m;
layout(binding = 2, rgba32f) uniform readonly image2D velocity; // next.xy, prev.xy px per frame
layout(binding = 3, rgba32f) uniform writeonly image2D velocity_out;
layout(binding = 4, r32f) uniform writeonly image2D depth_out;
layout(binding = 5, std430) buffer Changed { uint changed[]; }; // [0]: the pixels changed, zeroed before

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
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec4 v_raw = imageLoad(velocity, p);
    float z_raw = imageLoad(depth_m, p).r;
    vec4 v_p = clamped_velocity(v_raw);
    float w[9];
    vec4 v9[9];
    float w_near = layer_key(z_raw), w_far = w_near;
    float motion = 0.0;
    for (int i = 0; i < 9; ++i) {
        ivec2 q = clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), pc.size - 1);
        w[i] = layer_key(imageLoad(depth_m, q).r);
        v9[i] = clamped_velocity(imageLoad(velocity, q));
        w_near = max(w_near, w[i]);
        w_far = min(w_far, w[i]);
        motion = max(motion, max(length(v9[i].xy - v_p.xy) * pc.t_fwd, length(v9[i].zw - v_p.zw) * pc.t_back));
    }
    vec4 v_out = v_raw;
    float z_out = z_raw;
    if (w_near > w_far * 1.0717735 && motion > 0.5) {
        vec3 c9[9];
        for (int i = 0; i < 9; ++i) {
            ivec2 q = clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), pc.size - 1);
            c9[i] = finite_or_zero(imageLoad(color_in, q)).rgb;
        }
        int layer = edge_layer(w, c9, c9[4], w_near, w_far, pc.min_share);
        if (layer != EDGE_OWN) {
            float w_mid = 0.5 * (w_near + w_far);
            vec4 v_sum = vec4(0.0);
            float w_sum = 0.0, n = 0.0;
            for (int i = 0; i < 9; ++i) {
                if (i == 4 || (w[i] > w_mid) != (layer == EDGE_NEAR)) continue;
                v_sum += v9[i];
                w_sum += w[i];
                n += 1.0;
            }
            v_out = v_sum / n;
            z_out = 1.0 / (w_sum / n);
            atomicAdd(changed[0], 1u);
        }
    }
    imageStore(velocity_out, p, v_out);
    imageStore(depth_out, p, vec4(z_out, 0.0, 0.0, 0.0));
}
