#version 450
// Tiled depth of field, large-CoC tiles at full resolution: the upsampled half-resolution
// background, or for pixels that are themselves nearly sharp the exact gather (so a sharp
// subject stays sharp at full resolution), with the half-resolution foreground composited over.
#include "common.glsl"
#define APERTURE_MASK_BINDING 6
#include "aperture.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D coc_px;
layout(binding = 2, rgba32f) uniform readonly image2D bg_half;
layout(binding = 3, rgba32f) uniform readonly image2D fg_half;
layout(binding = 4, rgba32f) uniform writeonly image2D color_out;
layout(binding = 5, std430) readonly buffer TileLists { uint tile_list[]; };
layout(binding = 7, r32f) uniform readonly image2D coc_half;
layout(binding = 8, rgba32f) uniform readonly image2D fg_big_half;
layout(binding = 9, std430) readonly buffer TileRadius { float tile_radius_px[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 half_size;
    ivec2 tiles;
    float small_radius_px;
    Aperture ap;
    float layer_transition_px;
} pc;

#include "gather.glsl"

vec4 load_half_bg(ivec2 q) { return imageLoad(bg_half, clamp(q, ivec2(0), pc.half_size - 1)); }
vec4 load_half_fg(ivec2 q) { return imageLoad(fg_half, clamp(q, ivec2(0), pc.half_size - 1)); }
vec4 load_half_fg_big(ivec2 q) { return imageLoad(fg_big_half, clamp(q, ivec2(0), pc.half_size - 1)); }

void main() {
    uint t = tile_list[CLASS_LARGE * pc.tiles.x * pc.tiles.y + int(gl_WorkGroupID.x)];
    ivec2 p = ivec2(t % uint(pc.tiles.x), t / uint(pc.tiles.x)) * TILE_SIZE + ivec2(gl_LocalInvocationID.xy);
    if (outside(p, pc.size)) return;
    // Bilinear upsampling: full-res pixel centre (p + 0.5) is half-res position (p + 0.5)/2 - 0.5.
    vec2 h = (vec2(p) + 0.5) * 0.5 - 0.5;
    ivec2 h0 = ivec2(floor(h));
    vec2 f = h - vec2(h0);
    // Joint bilateral upsampling of the background: each half-resolution texel also weighted by
    // how close its CoC is to this pixel's, so a blurred pixel next to a sharp subject (or an
    // in-focus highlight) does not pull that content in from the coarser grid.
    float coc_here = imageLoad(coc_px, p).r;
    vec4 bg = vec4(0.0);
    float bg_weight = 0.0;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 q = clamp(h0 + ivec2(i, j), ivec2(0), pc.half_size - 1);
            float bilinear = (i == 0 ? 1.0 - f.x : f.x) * (j == 0 ? 1.0 - f.y : f.y);
            float similar = 1.0 / (1.0 + abs(imageLoad(coc_half, q).r - coc_here));
            bg += (bilinear * similar) * imageLoad(bg_half, q);
            bg_weight += bilinear * similar;
        }
    }
    bg = bg_weight > 0.0 ? bg / bg_weight : load_half_bg(h0);
    vec4 fg = mix(mix(load_half_fg(h0), load_half_fg(h0 + ivec2(1, 0)), f.x),
                  mix(load_half_fg(h0 + ivec2(0, 1)), load_half_fg(h0 + ivec2(1, 1)), f.x), f.y);
    float radius_p = 0.5 * abs(coc_here);
    // Pixels whose own CoC is small are gathered exactly, as in the small-CoC tiles (so nothing
    // changes across a tile border), with only the large-CoC foreground composited over them;
    // blurred pixels take the half-resolution layers. A blend over the last 1.5 px below the
    // small-CoC radius joins the two, so a pixel at or above it costs only the half path.
    float blurred = smoothstep(pc.small_radius_px - 2.0, pc.small_radius_px - 0.5, radius_p);
    vec4 base = bg;
    if (blurred < 1.0) {
        Aperture ap = pc.ap;
        // As in dof_tile_gather: only foreground samples reach farther than p's own CoC.
        float fg_radius = tile_radius_px[pc.tiles.x * pc.tiles.y + int(t)];
        int r = int(ceil(min(pc.small_radius_px + 1.0, max(radius_p, fg_radius)))) + 1;
        vec4 exact = gather_exact(p, pc.size, r, ap, pc.layer_transition_px);
        vec4 fg_big = mix(mix(load_half_fg_big(h0), load_half_fg_big(h0 + ivec2(1, 0)), f.x),
                          mix(load_half_fg_big(h0 + ivec2(0, 1)), load_half_fg_big(h0 + ivec2(1, 1)), f.x), f.y);
        exact = vec4(mix(exact.rgb, fg_big.rgb, fg_big.a), exact.a);
        base = mix(exact, bg, blurred);
        fg = vec4(fg.rgb, fg.a * blurred);
    }
    imageStore(color_out, p, vec4(mix(base.rgb, fg.rgb, fg.a), base.a));
}
