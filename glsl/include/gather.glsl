// The exact depth-of-field gather shared by the reference pass and the tiled path's full-
// resolution tiles: every sample within `r` px whose aperture-shaped CoC covers pixel p
// contributes colour / CoC area, in two layers (see bokeh_gather.comp for the rules).
#ifndef REALCAM_GATHER_GLSL
#define REALCAM_GATHER_GLSL
#include "common.glsl"
#include "aperture.glsl"

// Needs, declared by the including shader: images color_in (rgba32f) and coc_px (r32f).
// Beyond the frame the edge pixels continue (clamp to edge). The taps: the disc of radius
// disc_px around p (tap_disc_px in aperture.glsl of the largest reach of a sample near p, which
// holds every tap that can weigh; the hidden fill below takes only positions within radius_p,
// which is at most that reach).
vec4 gather_exact(ivec2 p, ivec2 size, float disc_px, Aperture ap, float layer_transition_px) {
    float coc_p = imageLoad(coc_px, p).r;
    float radius_p = max(0.5 * abs(coc_p), 0.5);
    vec4 bg = vec4(0.0), fg = vec4(0.0), hidden = vec4(0.0);
    float bg_w = 0.0, fg_w = 0.0, hidden_n = 0.0, hidden_near_w = 0.0, own_n = 0.0;
    // A sample spread over p's own CoC would carry 1 / (this) at p.
    float area_p_px2 = ap.area_factor * radius_p * radius_p;
    // The disc's rows are the loop's bounds, as lavapipe pays for every tap a loop visits,
    // skipped or not.
    int r = int(floor(disc_px));
    for (int dy = -r; dy <= r; ++dy) {
        int half_width = int(floor(sqrt(disc_px * disc_px - float(dy * dy))));
        for (int dx = -half_width; dx <= half_width; ++dx) {
            // Beyond the frame the edge pixels continue (clamp to edge), so pixels near the
            // border see as much light from outside as a uniform scene would send them.
            ivec2 q = clamp(p + ivec2(dx, dy), ivec2(0), size - 1);
            float coc_q = imageLoad(coc_px, q).r;
            float radius_q = max(0.5 * abs(coc_q), 0.5);
            float d2_px2 = float(dx * dx + dy * dy);
            // A sample behind p spreads no farther than p's own CoC.
            float reach = coc_q > coc_p ? min(radius_q, radius_p) : radius_q;
            float w = 0.0;
            if (d2_px2 <= (reach + 1.0) * (reach + 1.0)) {
                // The aperture's image is upright behind the focus plane and inverted in front.
                int flip = coc_q < 0.0 ? -1 : 1;
                ivec2 o = ivec2(-dx, -dy) * flip;
                w = aperture_weight_at(o, reach, ap, vec2(p + ivec2(dx, dy)) + 0.5, float(flip), 1.0)
                    * sa_weight(vec2(o), radius_q, coc_q, ap);
            }
            vec4 c = finite_or_zero(imageLoad(color_in, q));
            float f = clamp((coc_p - coc_q) / layer_transition_px, 0.0, 1.0);
            // Within p's own CoC, the positions that are not in front of p (own depth or
            // behind), and of those the ones behind p whose light does not reach p (a sharp
            // background spreads less than p's CoC): how much of p's disc is background that
            // p's own surface hides (see the fill below), and its colour.
            float in_p = d2_px2 <= radius_p * radius_p ? 1.0 : 0.0;
            float behind = clamp((coc_q - coc_p) / layer_transition_px, 0.0, 1.0);
            float unreached = in_p * behind * (1.0 - min(w * area_p_px2, 1.0));
            // The light p gets from the background its surface hides is that background's
            // blurred image at p: at an in-focus background the one point behind p, which the
            // pinhole image does not show. So its colour is estimated from the visible
            // background nearest p, on the scale of that background's own CoC: each position
            // weighted by 1 / (1 + d^2 / radius_q^2)^3 (a ring at distance d >> radius_q counts
            // as d^-5), not by the mean over p's whole disc, which over a textured background
            // takes in texture far from p (scene A's HL15, a small sphere at the in-focus
            // Siemens star's edge: its own pixels 0.2 below its disc's ring, area 1.032 of
            // Cycles', 1.014 now).
            float closeness = 1.0 / (1.0 + d2_px2 / (radius_q * radius_q));
            float near = unreached * closeness * closeness * closeness;
            hidden += near * c;
            hidden_near_w += near;
            hidden_n += unreached;
            own_n += in_p * (1.0 - f);
            if (w <= 0.0) continue;
            fg += (f * w) * c;
            fg_w += f * w;
            bg += ((1.0 - f) * w) * c;
            bg_w += (1.0 - f) * w;
        }
    }
    // The light reaching p from its own depth and behind sums to weight 1 where the scene
    // continues around p (a flat wall at any CoC: the discs' areas are normalised). Less
    // (bg_w < 1) has two causes. Part of p's surface is hidden behind something nearer (the
    // front layer's positions): that part is estimated by the visible part, normalising by
    // bg_w. Or p's surface ends within its CoC over a background that spreads less than p's
    // CoC (a small bright sphere over a sharp texture, a blurred foreground's edge): then the
    // light p's pinhole ray misses comes from that background, which p's surface hides in the
    // pinhole image. Normalising would give p's surface the missing weight: a sphere smaller
    // than its CoC kept its full brightness at its own pixels (energy not conserved). The
    // second share (at most the unreached background's part of p's disc) is filled with the
    // colour of that background nearest p (on its own CoC's scale); the rest normalises as
    // before. On a flat wall or where nothing behind p fails to reach it, nothing is filled.
    float hidden_share = own_n > 0.0 ? hidden_n / own_n : 0.0;
    float missing = min(max(1.0 - bg_w, 0.0), hidden_share);
    vec4 hidden_colour = hidden_near_w > 0.0 ? hidden / hidden_near_w : vec4(0.0);
    float lit_w = bg_w + missing;
    vec4 background = lit_w > 0.0 ? (bg + missing * hidden_colour) / lit_w : vec4(0.0);
    vec4 foreground = fg_w > 0.0 ? fg / fg_w : vec4(0.0);
    return mix(background, foreground, clamp(fg_w, 0.0, 1.0));
}

#endif
