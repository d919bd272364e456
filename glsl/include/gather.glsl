// The exact depth-of-field gather shared by the reference pass and the tiled path's full-
// resolution tiles: every sample within `r` px whose aperture-shaped CoC covers pixel p
// contributes colour / CoC area, in two layers (see bokeh_gather.comp for the rules).
#ifndef REALCAM_GATHER_GLSL
#define REALCAM_GATHER_GLSL
#include "common.glsl"
#include "aperture.glsl"

// Needs, declared by the including shader: images color_in (rgba32f) and coc_px (r32f).
// Beyond the frame the edge pixels continue (clamp to edge).
vec4 gather_exact(ivec2 p, ivec2 size, int r, Aperture ap, float layer_transition_px) {
    float coc_p = imageLoad(coc_px, p).r;
    float radius_p = max(0.5 * abs(coc_p), 0.5);
    vec4 bg = vec4(0.0), fg = vec4(0.0);
    float bg_w = 0.0, fg_w = 0.0;
    for (int dy = -r; dy <= r; ++dy) {
        // The taps lie in the disc dx^2 + dy^2 <= r^2: its rows are the loop's bounds, as
        // lavapipe pays for every tap a loop visits, skipped or not.
        int half_width = int(floor(sqrt(float(r * r - dy * dy))));
        for (int dx = -half_width; dx <= half_width; ++dx) {
            // Beyond the frame the edge pixels continue (clamp to edge), so pixels near the
            // border see as much light from outside as a uniform scene would send them.
            ivec2 q = clamp(p + ivec2(dx, dy), ivec2(0), size - 1);
            float coc_q = imageLoad(coc_px, q).r;
            float radius_q = max(0.5 * abs(coc_q), 0.5);
            // A sample behind p spreads no farther than p's own CoC.
            float reach = coc_q > coc_p ? min(radius_q, radius_p) : radius_q;
            if (float(dx * dx + dy * dy) > (reach + 1.0) * (reach + 1.0)) continue;
            // The aperture's image is upright behind the focus plane and inverted in front.
            int flip = coc_q < 0.0 ? -1 : 1;
            ivec2 o = ivec2(-dx, -dy) * flip;
            float w = aperture_weight_at(o, reach, ap, vec2(p + ivec2(dx, dy)) + 0.5, float(flip), 1.0)
                * sa_weight(vec2(o), radius_q, coc_q, ap);
            if (w <= 0.0) continue;
            vec4 c = finite_or_zero(imageLoad(color_in, q));
            float f = clamp((coc_p - coc_q) / layer_transition_px, 0.0, 1.0);
            fg += (f * w) * c;
            fg_w += f * w;
            bg += ((1.0 - f) * w) * c;
            bg_w += (1.0 - f) * w;
        }
    }
    vec4 background = bg_w > 0.0 ? bg / bg_w : vec4(0.0);
    vec4 foreground = fg_w > 0.0 ? fg / fg_w : vec4(0.0);
    return mix(background, foreground, clamp(fg_w, 0.0, 1.0));
}

#endif
