#version 450
// The CoC pass's edge resolve: one invocation per pixel of the edge list glsl/dof/coc.comp wrote
// (an indirect dispatch, EDGE_GROUP_SIZE pixels per workgroup), whose CoC it overwrites with
// that of the depth its light belongs to. It reads only the depth and the colour, which no one
// writes meanwhile, and writes only listed pixels, each listed once.
//
// Anti-aliased edges: renderers filter the colour pass over about 1.5 px but take the depth of
// one sample per pixel, so a pixel at an edge may carry one surface's depth and mostly another
// surface's light (a bright in-focus point's fringe with the sky's depth). Where the 3x3
// neighbourhood spans two depths whose CoCs differ by more than a quarter pixel (coc.comp's
// test), the pixel's colour is read as a mix of the two layers' colours (the near neighbours'
// mean, the far neighbour of median brightness; least squares for the near layer's share
// alpha), and it takes the depth of the layer that brings more of its light: alpha L_near
// against (1 - alpha) L_far. A near pixel whose alpha lies within the range of the near layer's
// pixels (a textured surface at a hard edge) keeps its depth. The far layer gets no such test:
// at an anti-aliased fringe the far neighbours are fringe pixels too, and would explain each
// other.
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

layout(local_size_x = EDGE_GROUP_SIZE) in;

float brightness(vec3 c) { return max(c.r, 0.0) + max(c.g, 0.0) + max(c.b, 0.0); }

// The inverse depth (1/mm) whose light pixel p holds at an edge between two layers, the
// nearest w_near and farthest w_far of its neighbourhood w (see the top of the file).
float edge_inverse_depth(ivec2 p, float w[9], float w_p, float w_near, float w_far) {
    float w_mid = 0.5 * (w_near + w_far);
    vec3 near_sum = vec3(0.0);
    float near_n = 0.0, far_n = 0.0, near_w = 0.0, far_w = 0.0;
    vec3 c9[9];
    float b9[9];
    for (int i = 0; i < 9; ++i) {
        if (i == 4) continue;
        vec3 c = finite_or_zero(imageLoad(color_in, clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), pc.size - 1))).rgb;
        c9[i] = c;
        b9[i] = brightness(c);
        if (w[i] > w_mid) {
            near_sum += c;
            near_n += 1.0;
            near_w += w[i];
        } else {
            far_n += 1.0;
            far_w += w[i];
        }
    }
    if (near_n == 0.0 || far_n == 0.0) return w_p;
    // The far layer's colour: its neighbour of median brightness (the darker middle one of an
    // even count; ties by position), not its mean. Next to a small bright highlight the far
    // neighbours are partly the highlight's other fringe pixels, a few of them a fifth of the
    // highlight or more: their mean came out as bright as the pixel itself, which then read as
    // no highlight light at all (scene A's HL15: fringe pixels of 2-11 over the star's 0.7 kept
    // its depth). The median is the background's as long as fewer than half are fringe.
    int rank = int(far_n - 1.0) / 2;
    vec3 c_far = vec3(0.0);
    for (int i = 0; i < 9; ++i) {
        if (i == 4 || w[i] > w_mid) continue;
        int below = 0;
        for (int j = 0; j < 9; ++j) {
            if (j == 4 || w[j] > w_mid) continue;
            below += (b9[j] < b9[i] || (b9[j] == b9[i] && j < i)) ? 1 : 0;
        }
        if (below == rank) c_far = c9[i];
    }
    vec3 c_near = near_sum / near_n;
    vec3 d = c_near - c_far;
    float dd = dot(d, d);
    if (dd <= 1.0e-12) return w_p;
    vec3 c_p = finite_or_zero(imageLoad(color_in, p)).rgb;
    // Read along the line from the far layer's colour to the near one's mean (alpha), the own
    // layer's pixels span a range: a near pixel inside it is explained by its own surface.
    bool own_near = w_p > w_mid;
    float lo = 1.0e30, hi = -1.0e30;
    for (int i = 0; i < 9; ++i) {
        if (i == 4 || (w[i] > w_mid) != own_near) continue;
        float a = dot(c9[i] - c_far, d) / dd;
        lo = min(lo, a);
        hi = max(hi, a);
    }
    float alpha_p = dot(c_p - c_far, d) / dd;
    if (own_near && alpha_p >= lo && alpha_p <= hi) return w_p;
    float alpha = clamp(alpha_p, 0.0, 1.0);
    bool near = alpha * brightness(c_near) > (1.0 - alpha) * brightness(c_far);
    // The pixel keeps its own depth if it lies in the chosen layer.
    if (near == own_near) return w_p;
    return near ? near_w / near_n : far_w / far_n;
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
