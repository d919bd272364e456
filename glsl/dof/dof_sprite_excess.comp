#version 450
// Tiled depth of field, step 3c: each sprite's excess taken out of its pixel of the input
// colour, in place, so the exact gathers of the composite read the colour less the sprites'
// energy without a full-resolution copy of the frame. dof_highlights.comp cannot do it itself:
// it reads rings of pixels 3 px around each candidate, which its other invocations would be
// rewriting. One invocation per sprite (a pixel has at most one: one per texel's pixel), so
// each written pixel has one writer. The pixel's value as it was is kept in `saved`; with
// `restore` set, a second dispatch puts it back (the per-channel runs of longitudinal colour
// each read the input colour as it was).
#include "common.glsl"
#include "dof_tiles.glsl"

layout(local_size_x = GROUP_SIZE) in;
layout(binding = 0, rgba32f) uniform image2D color;
layout(binding = 1, std430) readonly buffer Args { uint args[]; };
layout(binding = 2, std430) readonly buffer Sprites { Sprite sprites[]; };
// Per sprite slot: its pixel's colour before the excess was taken out (as loaded, unclamped).
layout(binding = 3, std430) buffer Saved { vec4 saved[]; };

layout(push_constant) uniform Push {
    int sprite_capacity;
    int restore;  // 0: take the excess out (and save the pixel); 1: put the saved pixel back
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= min(args[ARGS_SPRITE_COUNT], uint(pc.sprite_capacity))) return;
    Sprite s = sprites[i];
    // The centre is the pixel's centre (p + 0.5).
    ivec2 p = ivec2(floor(s.centre_px));
    if (pc.restore != 0) {
        imageStore(color, p, saved[i]);
        return;
    }
    vec4 loaded = imageLoad(color, p);
    saved[i] = loaded;
    // dof_highlights' own arithmetic: the excess was computed from this value.
    vec4 c = finite_or_zero(loaded);
    imageStore(color, p, vec4(c.rgb - s.color.rgb, c.a));
}
