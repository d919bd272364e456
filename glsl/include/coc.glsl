// The CoC pass's shared parts (glsl/dof/coc.comp, glsl/dof/coc_edges.comp): the push constants, the
// depth reads and eq 5.3. The integer defines are Rust constants too
// (realcam::gpu::shaders::coc, made by build.rs). The including shader declares depth_m, the
// `table` buffer and the FIELD_CURVATURE specialization constant first.
#ifndef REALCAM_COC_GLSL
#define REALCAM_COC_GLSL

// The edge list's args buffer: the edge resolve's indirect dispatch (x, y, z: EDGE_GROUP_SIZE
// listed pixels per workgroup), then the count of listed pixels.
#define COC_ARGS_DISPATCH 0
#define COC_ARGS_COUNT 3
#define COC_ARGS_WORDS 4
// Invocations per workgroup of the edge resolve (glsl/dof/coc_edges.comp).
#define EDGE_GROUP_SIZE 64

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
    int resolve_edges;         // 1: the anti-aliased-edge depth resolve (coc_edges.comp); 0: depth as stored (RESOLVE_EDGES)
} pc;

#include "height_table.glsl"

// Depth in mm at q (clamped to the frame), at least 1e-30 so that its inverse is finite.
float depth_mm(ivec2 q) {
    q = clamp(q, ivec2(0), pc.size - 1);
    return max(imageLoad(depth_m, q).r * pc.mm_per_depth_unit, 1.0e-30);
}

float inverse_depth(ivec2 q) { return 1.0 / depth_mm(q); }

// The signed, clamped CoC (px) of pixel p for the inverse depth inv_u (1/mm).
float coc_of_inverse_depth(ivec2 p, float inv_u) {
    // Kyaw 2013 eq 5.3 in reciprocal form: exactly 0 at u = S, the finite limit at u = inf
    // (1/inf = 0), and -inf (then clamped) at u = 0. Depth was validated (no NaN, >= 0) on load.
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
    return clamp(coc + pc.coc_offset_px, -pc.max_coc_px, pc.max_coc_px);
}

// A listed pixel: x | y << 16.
uint pack_pixel(ivec2 p) { return uint(p.x) | (uint(p.y) << 16); }
ivec2 unpack_pixel(uint v) { return ivec2(int(v & 0xffffu), int(v >> 16)); }

#endif
