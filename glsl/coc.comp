#version 450
// Circle of confusion: signed diameter in pixels from planar depth (Kyaw 2013 eq 5.3).
// Foreground (nearer than the focus distance) negative, background positive, 0 in focus.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, r32f) uniform readonly image2D depth_m;
layout(binding = 1, r32f) uniform writeonly image2D coc_px;
// Field curvature: [heights mm (entries), film-plane offset mm of the sharp image surface].
layout(binding = 2, std430) readonly buffer FieldCurvature { float table[]; };

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
    int entries;               // field-curvature table entries; 0: none
    // Longitudinal colour: this run's channel focuses elsewhere than green, which shifts its
    // signed CoC by a constant (Camera::longitudinal_color_coc_px); 0 for green.
    float coc_offset_px;
} pc;

#include "height_table.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    float u_mm = imageLoad(depth_m, p).r * pc.mm_per_depth_unit;
    // Kyaw 2013 eq 5.3 in reciprocal form: exactly 0 at u = S, the finite limit at u = inf
    // (1/inf = 0), and -inf (then clamped) at u = 0. Depth was validated (no NaN, >= 0) on load.
    float inv_u = 1.0 / max(u_mm, 1.0e-30);
    float coc = pc.coc_scale_px_mm * (pc.inv_focus_distance_per_mm - inv_u);
    if (pc.entries > 0) {
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
