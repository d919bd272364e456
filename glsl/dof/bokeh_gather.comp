#version 450
// Depth of field by gathering: each output pixel sums the samples whose aperture-shaped circle of
// confusion covers it, each weighted by 1/area of its circle (energy spread over the CoC), in two
// layers: the background (the pixel's own depth and behind) and the foreground in front of it.
//  - A sample behind the pixel spreads no farther than the pixel's own CoC, so a blurred
//    background does not bleed over a sharp subject.
//  - A sample in front spreads over its full CoC and is composited over the background with the
//    coverage it reaches (alpha), so a blurred foreground covers what is behind it softly.
//  - A sharp subject (tiny CoC) reaches only its own pixel, so it does not bleed into the background.
//  - Where the pixel's own layer is a surface ending within its CoC over a background that does
//    not reach it (a small bright sphere over a sharp texture), that layer keeps only the weight
//    it has; the rest is the background around the pixel, which the surface hides in the pinhole
//    image (gather.glsl), so the surface's light is spread once, not also kept at full strength.
#include "common.glsl"
#define APERTURE_MASK_BINDING 3
#define APERTURE_SHAPE_BINDING 4
#include "aperture.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform writeonly image2D color_out;

layout(push_constant) uniform Push {
    ivec2 size;
    int radius_px;              // largest CoC radius in the image (the gather extent)
    Aperture ap;
    float layer_transition_px;  // CoC difference over which a sample moves from background to foreground
} pc;

#include "gather.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    Aperture ap = pc.ap;
    // radius_px - 1: the largest CoC radius, rounded up.
    float disc_px = tap_disc_px(float(pc.radius_px - 1));
    imageStore(color_out, p, gather_exact(p, pc.size, disc_px, ap, pc.layer_transition_px));
}
