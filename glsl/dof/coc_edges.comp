#version 450
// The CoC pass's edge resolve: one invocation per pixel of the edge list glsl/dof/coc.comp wrote
// (an indirect dispatch, EDGE_GROUP_SIZE pixels per workgroup), whose CoC it overwrites with
// that of the depth its light belongs to. It reads only the depth and the colour, which no one
// writes meanwhile, and writes only listed pixels, each listed once.
//
// Anti-aliased edges: renderers filter the colour pass over about 1.5 px but take the depth of
// one sample per pixel. Where the 3x3 neighbourhood spans two depths whose CoCs differ by more
// than a quarter pixel (coc.comp's test), the pixel takes the depth of the layer whose light it
// mostly holds: glsl/include/edge_layers.glsl decides (shared with the motion blur's edge
// resolve, glsl/motion/mb_edges.comp), and the pixel takes that layer's mean inverse depth.
#include "common.glsl"

// Specialised like coc.comp (src/passes/dof/coc.rs, CocPush::edge_specialization).
layout(constant_id = 0) const bool FIELD_CURVATURE = true; // pc.entries > 0
layout(binding = 0, r32f) uniform readonly image2D depth_m;
layout(binding = 1, r32f) uniform writeonly image2D coc_px;
layout(binding = 2, std430) readonly buffer FieldCurvature { float table[]; };
layout(binding = 3, rgba32f) uniform readonly image2D color_in;
layout(binding = 4, std430) readonly buffer Args { uint args[]; };
layout(binding = 5, std430) readonly buffer EdgePixels { uint edge_pixels[]; };

#include "coc.glsl"
#include "edge_layers.glsl"

layout(local_size_x = EDGE_GROUP_SIZE) in;

// The inverse depth (1/mm) whose light pixel p holds at an edge between two layers, the
// nearest w_near and farthest w_far of its neighbourhood w (glsl/include/edge_layers.glsl).
float edge_inverse_depth(ivec2 p, float w[9], float w_p, float w_near, float w_far) {
    float w_mid = 0.5 * (w_near + w_far);
    float near_n = 0.0, far_n = 0.0, near_w = 0.0, far_w = 0.0;
    vec3 c9[9];
    c9[4] = vec3(0.0);
    for (int i = 0; i < 9; ++i) {
        if (i == 4) continue;
        c9[i] = finite_or_zero(imageLoad(color_in, clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), pc.size - 1))).rgb;
        if (w[i] > w_mid) {
            near_n += 1.0;
            near_w += w[i];
        } else {
            far_n += 1.0;
            far_w += w[i];
        }
    }
    vec3 c_p = finite_or_zero(imageLoad(color_in, p)).rgb;
    int layer = edge_layer(w, c9, c_p, w_near, w_far, 0.0);
    if (layer == EDGE_OWN) return w_p;
    return layer == EDGE_NEAR ? near_w / near_n : far_w / far_n;
}

void main() {
    uint slot = gl_GlobalInvocationID.x;
    if (slot >= args[COC_ARGS_COUNT]) return;
    ivec2 p = unpack_pixel(edge_pixels[slot]);
    float d_p = depth_mm(p);
    float w_p = 1.0 / d_p;
    // The nearest and farthest layers as coc.comp found them (from the depths: the largest
    // inverse is the inverse of the smallest depth).
    float d_min = d_p, d_max = d_p;
    float w[9];
    for (int i = 0; i < 9; ++i) {
        float d = depth_mm(p + ivec2(i % 3 - 1, i / 3 - 1));
        d_min = min(d_min, d);
        d_max = max(d_max, d);
        w[i] = 1.0 / d;
    }
    float inv_u = edge_inverse_depth(p, w, w_p, 1.0 / d_min, 1.0 / d_max);
    imageStore(coc_px, p, vec4(coc_of_inverse_depth(p, inv_u), 0.0, 0.0, 0.0));
}
