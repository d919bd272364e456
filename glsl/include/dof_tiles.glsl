// Layout of the tiled depth-of-field buffers (src/passes/dof_tiles.rs mirrors it).
#ifndef REALCAM_DOF_TILES_GLSL
#define REALCAM_DOF_TILES_GLSL

// Tile classes: a copy (nothing defocused reaches the tile), the exact full-resolution gather
// (small CoC), or the half-resolution gather with sprites (large CoC).
#define CLASS_COPY 0
#define CLASS_SMALL 1
#define CLASS_LARGE 2
#define CLASS_COUNT 3

// The args buffer: three indirect dispatches (x, y, z) then the sprite counters.
#define ARGS_DISPATCH(c) ((c) * 3)
#define ARGS_SPRITE_COUNT 9
#define ARGS_SPRITES_DROPPED 10
#define ARGS_WORDS 12

struct Sprite {
    vec2 centre_px;
    float coc_px;
    float pad;
    vec4 color;
};

#endif
