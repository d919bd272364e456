// Layout of the tiled depth-of-field buffers. The integer defines are Rust constants too
// (realcam::gpu::shaders::dof_tiles, made by build.rs).
#ifndef REALCAM_DOF_TILES_GLSL
#define REALCAM_DOF_TILES_GLSL

// Tile classes: a copy (nothing defocused reaches the tile), the exact full-resolution gather
// (small CoC), or the half-resolution gather with sprites (large CoC).
#define CLASS_COPY 0
#define CLASS_SMALL 1
#define CLASS_LARGE 2
#define CLASS_COUNT 3

// The args buffer: three indirect dispatches (x, y, z) then the sprite counters.
#define ARGS_DISPATCH_WORDS 3
#define ARGS_DISPATCH(c) ((c) * ARGS_DISPATCH_WORDS)
#define ARGS_SPRITE_COUNT 9
#define ARGS_SPRITES_DROPPED 10
#define ARGS_WORDS 12

// A sprite: vec2 + float + float + vec4 (std430: 32 bytes, 8 words).
#define SPRITE_WORDS 8
struct Sprite {
    vec2 centre_px;
    float coc_px;
    float pad;
    vec4 color;
};

#endif
