#version 450
// Circle of confusion: signed diameter in pixels from planar depth (Kyaw 2013 eq 5.3).
// Foreground (nearer than the focus distance) negative, background positive, 0 in focus.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, r32f) uniform readonly image2D depth_m;
layout(binding = 1, r32f) uniform writeonly image2D coc_px;

layout(push_constant) uniform Push {
    ivec2 size;
    // v^2 / (N' P) / pixel pitch, in px*mm: eq 5.3 is C = scale * (1/S - 1/u).
    float coc_scale_px_mm;
    float inv_focus_distance_per_mm;
    float max_coc_px;          // user clamp on |C|
    float mm_per_depth_unit;   // 1000 for metres
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    float u_mm = imageLoad(depth_m, p).r * pc.mm_per_depth_unit;
    // Kyaw 2013 eq 5.3 in reciprocal form: exactly 0 at u = S, the finite limit at u = inf
    // (1/inf = 0), and -inf (then clamped) at u = 0. Depth was validated (no NaN, >= 0) on load.
    float inv_u = 1.0 / max(u_mm, 1.0e-30);
    float coc = pc.coc_scale_px_mm * (pc.inv_focus_distance_per_mm - inv_u);
    coc = clamp(coc, -pc.max_coc_px, pc.max_coc_px);
    imageStore(coc_px, p, vec4(coc, 0.0, 0.0, 0.0));
}
