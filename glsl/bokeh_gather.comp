#version 450
// Depth of field by gathering: each output pixel sums the samples whose aperture-shaped circle of
// confusion covers it, each weighted by 1/area of its circle (energy spread over the CoC), in two
// layers: the background (the pixel's own depth and behind) and the foreground in front of it.
//  - A sample behind the pixel spreads no farther than the pixel's own CoC, so a blurred
//    background does not bleed over a sharp subject.
//  - A sample in front spreads over its full CoC and is composited over the background with the
//    coverage it reaches (alpha), so a blurred foreground covers what is behind it softly.
//  - A sharp subject (tiny CoC) reaches only its own pixel, so it does not bleed into the background.
#include "common.glsl"
#include "aperture.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform writeonly image2D color_out;

layout(push_constant) uniform Push {
    ivec2 size;
    int radius_px;              // largest CoC radius in the image (the gather extent)
    int blades;
    float rotation_rad;
    float curvature;
    float layer_transition_px;  // CoC difference over which a sample moves from background to foreground
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    Aperture ap = Aperture(pc.blades, pc.rotation_rad, pc.curvature);
    float coc_p = imageLoad(coc_px, p).r;
    float radius_p = max(0.5 * abs(coc_p), 0.5);

    vec4 bg = vec4(0.0), fg = vec4(0.0);
    float bg_w = 0.0, fg_w = 0.0;
    int r = pc.radius_px;
    for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) {
            ivec2 q = p + ivec2(dx, dy);
            if (outside(q, pc.size)) continue;
            float coc_q = imageLoad(coc_px, q).r;
            float radius_q = max(0.5 * abs(coc_q), 0.5);
            float reach = coc_q > coc_p ? min(radius_q, radius_p) : radius_q;
            if (float(dx * dx + dy * dy) > (reach + 1.0) * (reach + 1.0)) continue;
            // The image of the aperture is upright behind the focus plane and inverted in front.
            vec2 o = vec2(-dx, -dy) * (coc_q < 0.0 ? -1.0 : 1.0);
            float w = aperture_coverage(o, reach, ap) / aperture_area(reach, ap);
            if (w <= 0.0) continue;
            vec4 c = finite_or_zero(imageLoad(color_in, q));
            float f = clamp((coc_p - coc_q) / pc.layer_transition_px, 0.0, 1.0);
            fg += (f * w) * c;
            fg_w += f * w;
            bg += ((1.0 - f) * w) * c;
            bg_w += (1.0 - f) * w;
        }
    }
    vec4 background = bg_w > 0.0 ? bg / bg_w : vec4(0.0);
    vec4 foreground = fg_w > 0.0 ? fg / fg_w : vec4(0.0);
    float alpha = clamp(fg_w, 0.0, 1.0);
    imageStore(color_out, p, mix(background, foreground, alpha));
}
