#version 450
// Circle of confusion: signed diameter in pixels from planar depth (Kyaw 2013 eq 5.3).
// Foreground (nearer than the focus distance) negative, background positive, 0 in focus.
//
// Anti-aliased edges: renderers filter the colour pass over about 1.5 px but take the depth of
// one sample per pixel, so a pixel at an edge may carry one surface's depth and mostly another
// surface's light (a bright in-focus point's fringe with the sky's depth). Where the 3x3
// neighbourhood spans two depths whose CoCs differ by more than a quarter pixel, the pixel's
// colour is read as a mix of the two layers' colours (the near neighbours' mean, the far
// neighbour of median brightness; least squares for the near layer's share alpha), and it takes
// the depth of the layer that brings more of its light: alpha L_near against (1 - alpha) L_far.
// A near pixel whose alpha lies within the range of the near layer's pixels (a textured surface
// at a hard edge) keeps its depth. The far layer gets no such test: at an anti-aliased fringe
// the far neighbours are fringe pixels too, and would explain each other.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
// The run's paths, specialised (src/passes/coc.rs, CocPush::specialization): lavapipe runs both
// sides of every branch, so a pipeline without them skips the edge resolve's and the field
// curvature's work.
layout(constant_id = 0) const bool RESOLVE_EDGES = true;   // pc.resolve_edges != 0
layout(constant_id = 1) const bool FIELD_CURVATURE = true; // pc.entries > 0
layout(binding = 0, r32f) uniform readonly image2D depth_m;
layout(binding = 1, r32f) uniform writeonly image2D coc_px;
// Field curvature: [heights mm (entries), film-plane offset mm of the sharp image surface].
layout(binding = 2, std430) readonly buffer FieldCurvature { float table[]; };
layout(binding = 3, rgba32f) uniform readonly image2D color_in;

layout(push_constant) uniform Push {
    ivec2 size;
    // v^2 / (N' P) / pixel pitch, in px*mm: eq 5.3 is C = scale * (1/S - 1/u).
    float coc_scale_px_mm;
    float inv_focus_distance_per_mm;
    float max_coc_px;          // user clamp on |C|
    float mm_per_depth_unit;   // 1000 for metres
    vec2 centre_px;
    float pixel_pitch_mm;
    float image_distance_mm;   // v
    float inv_focal_length_per_mm;
    float aperture_px;         // v / (N' P) / pixel pitch
    int entries;               // field-curvature table entries; 0: none (FIELD_CURVATURE)
    // Longitudinal colour: this run's channel focuses elsewhere than green, which shifts its
    // signed CoC by a constant (Camera::longitudinal_color_coc_px); 0 for green.
    float coc_offset_px;
    int resolve_edges;         // 1: the anti-aliased-edge depth resolve above; 0: depth as stored (RESOLVE_EDGES)
} pc;

#include "height_table.glsl"

// Depth in mm at q (clamped to the frame), at least 1e-30 so that its inverse is finite.
float depth_mm(ivec2 q) {
    q = clamp(q, ivec2(0), pc.size - 1);
    return max(imageLoad(depth_m, q).r * pc.mm_per_depth_unit, 1.0e-30);
}

float inverse_depth(ivec2 q) { return 1.0 / depth_mm(q); }

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

// The inverse depth (1/mm) whose light pixel p mostly holds (see the top of the file).
float resolved_inverse_depth(ivec2 p) {
    float d_p = depth_mm(p);
    float w_p = 1.0 / d_p;
    if (!RESOLVE_EDGES) return w_p;
    // The nearest and farthest layers from the depths (a division is monotonic: the largest
    // inverse is the inverse of the smallest depth), so a pixel away from an edge divides once
    // for them, not once per neighbour.
    float d_min = d_p, d_max = d_p;
    for (int i = 0; i < 9; ++i) {
        float d = depth_mm(p + ivec2(i % 3 - 1, i / 3 - 1));
        d_min = min(d_min, d);
        d_max = max(d_max, d);
    }
    float w_near = 1.0 / d_min, w_far = 1.0 / d_max;
    // Two layers only matter if their CoCs differ by more than a quarter pixel
    // (EDGE_RESOLVE_MIN_PX in src/passes/coc.rs: a highlight's fringe over a surface half a metre
    // behind it differs by less than a pixel and still enlarged its disc). lavapipe runs the code
    // after an early return or inside a false `if` anyway, but it leaves a loop that no lane of
    // the SIMD group is still in: the edge resolve is a loop of one trip at an edge and none
    // elsewhere, so groups without an edge skip its colour reads and arithmetic.
    int trips = pc.coc_scale_px_mm * (w_near - w_far) > 0.25 ? 1 : 0;
    float resolved = w_p;
    for (int once = 0; once < trips; ++once) {
        float w[9];
        for (int i = 0; i < 9; ++i) w[i] = inverse_depth(p + ivec2(i % 3 - 1, i / 3 - 1));
        resolved = edge_inverse_depth(p, w, w_p, w_near, w_far);
    }
    return resolved;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    // Kyaw 2013 eq 5.3 in reciprocal form: exactly 0 at u = S, the finite limit at u = inf
    // (1/inf = 0), and -inf (then clamped) at u = 0. Depth was validated (no NaN, >= 0) on load.
    float inv_u = resolved_inverse_depth(p);
    float coc = pc.coc_scale_px_mm * (pc.inv_focus_distance_per_mm - inv_u);
    if (FIELD_CURVATURE) {
        // Field curvature (Kyaw 2013 sec 6.3.4, 7.6): at image height h the sharp image surface
        // lies delta(h) behind the film, so the point focuses at v_u + delta instead of v_u.
        // Eq 5.3 in the same terms: C = D' (v w / (1 + delta w) - 1), w = 1/v_u = 1/f - 1/u.
        float h_mm = length(vec2(p) + 0.5 - pc.centre_px) * pc.pixel_pitch_mm;
        float w = pc.inv_focal_length_per_mm - inv_u;
        float delta = height_table_lookup(1, pc.entries, h_mm);
        coc = pc.aperture_px * (pc.image_distance_mm * w / (1.0 + delta * w) - 1.0);
    }
    coc = clamp(coc + pc.coc_offset_px, -pc.max_coc_px, pc.max_coc_px);
    imageStore(coc_px, p, vec4(coc, 0.0, 0.0, 0.0));
}
