#version 450
// Tiled depth of field, large-CoC tiles at full resolution: the upsampled half-resolution
// background, or for pixels that are themselves nearly sharp the exact gather (so a sharp
// subject stays sharp at full resolution), with the half-resolution foreground composited over.
#include "common.glsl"
#define APERTURE_MASK_BINDING 6
#include "dof_tiles.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform readonly image2D bg_half;
layout(binding = 3, rgba32f) uniform readonly image2D fg_half;
layout(binding = 4, rgba32f) uniform writeonly image2D color_out;
layout(binding = 5, std430) readonly buffer TileLists { uint tile_list[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 half_size;
    ivec2 tiles;
    float small_radius_px;
    int blades;
    float rotation_rad;
    float curvature;
    float sa_amount;
    float sa_max_coc_px;
    float centre_x_px;
    float centre_y_px;
    float cats_eye_per_px;
    float layer_transition_px;
} pc;

#include "gather.glsl"

vec4 load_half_bg(ivec2 q) { return imageLoad(bg_half, clamp(q, ivec2(0), pc.half_size - 1)); }
vec4 load_half_fg(ivec2 q) { return imageLoad(fg_half, clamp(q, ivec2(0), pc.half_size - 1)); }

void main() {
    uint t = tile_list[CLASS_LARGE * pc.tiles.x * pc.tiles.y + int(gl_WorkGroupID.x)];
    ivec2 p = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x)) * TILE_SIZE + ivec2(gl_LocalInvocationID.xy);
    if (outside(p, pc.size)) return;
    // Bilinear upsampling: full-res pixel centre (p + 0.5) is half-res position (p + 0.5)/2 - 0.5.
    vec2 h = (vec2(p) + 0.5) * 0.5 - 0.5;
    ivec2 h0 = ivec2(floor(h));
    vec2 f = h - vec2(h0);
    vec4 bg = mix(mix(load_half_bg(h0), load_half_bg(h0 + ivec2(1, 0)), f.x),
                  mix(load_half_bg(h0 + ivec2(0, 1)), load_half_bg(h0 + ivec2(1, 1)), f.x), f.y);
    vec4 fg = mix(mix(load_half_fg(h0), load_half_fg(h0 + ivec2(1, 0)), f.x),
                  mix(load_half_fg(h0 + ivec2(0, 1)), load_half_fg(h0 + ivec2(1, 1)), f.x), f.y);
    float radius_p = 0.5 * abs(imageLoad(coc_px, p).r);
    float blurred = smoothstep(0.5 * pc.small_radius_px, pc.small_radius_px, radius_p);
    vec4 base = bg;
    if (blurred < 1.0) {
        Aperture ap = Aperture(pc.blades, pc.rotation_rad, pc.curvature, pc.sa_amount, pc.sa_max_coc_px,
                           vec2(pc.centre_x_px, pc.centre_y_px), pc.cats_eye_per_px);
        vec4 exact = gather_exact(p, pc.size, int(ceil(pc.small_radius_px)) + 1, ap, pc.layer_transition_px);
        base = mix(exact, bg, blurred);
    }
    imageStore(color_out, p, vec4(mix(base.rgb, fg.rgb, fg.a), base.a));
}
