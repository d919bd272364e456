// Layout of the tiled depth-of-field buffers. The integer defines are Rust constants too
// (realcam::gpu::shaders::dof_tiles, made by build.rs).
#ifndef REALCAM_DOF_TILES_GLSL
#define REALCAM_DOF_TILES_GLSL

// Tile classes: a copy (nothing defocused reaches the tile), the exact full-resolution gather
// (small CoC), or a gather at level L of the pyramid (L = 1 .. 4: 1/2 .. 1/16 resolution),
// the level at which the tile's largest CoC radius is at most LEVEL_RADIUS texels (any at L4):
// 1.5 to 3 texels (level 1: 1 to 3). At 2, a radius just above a level's bound (scene A's
// wall at f/2, 8.6 px; its near pole, 17.9 px) was gathered on 1.1 texels, where the pyramid's
// box and the bilinear upsampling blur about as much as the disc itself: 22% of its 16-px
// tiles off the reference by more than 5% in mean luminance.
#define CLASS_COPY 0
#define CLASS_SMALL 1
#define CLASS_LEVEL1 2
#define LEVELS 4
#define CLASS_COUNT 6
#define LEVEL_RADIUS 3
// A level tile's pixels blend from the exact gather to the level's layers as their CoC radius
// goes from the small-CoC radius - 0.5 px to this many px above it (dof_composite.comp): over
// 1.5 px of radius, so that a rack focus moves a pixel across it over several frames rather
// than one (a tile's mean jumped 4% in one frame where the two disagree).
#define EXACT_BLEND_ABOVE_SMALL_PX 1
// A pixel of a level tile whose own CoC radius is below the level's range (the level a
// foreground's radius chose: a sharper subject or a nearer wall beside a strongly defocused
// foreground or background) would be blurred by the level's texels more than its own CoC asks.
// Up to EXACT_MAX_RADIUS_PX it takes the exact gather at full resolution instead, as a nearly
// sharp pixel does (dof_composite.comp): the exact-gather radius of level L (exact_radius_px)
// is the small-CoC radius at level 1, the largest radius of level L - 1 above, at most this.
#define EXACT_MAX_RADIUS_PX 5
float exact_radius_px(int level, float small_radius_px) {
    if (level <= 1) return small_radius_px;
    return max(small_radius_px, min(float(LEVEL_RADIUS << (level - 1)), float(EXACT_MAX_RADIUS_PX)));
}
// The tile lists: one per class, then per level the level's tiles with no nearly sharp pixel
// (every pixel's CoC radius at least the small-CoC radius), which the composite takes without
// its exact gather; the level classes' own lists keep the others. Last, the level tiles whose
// bin holds a sprite (dof_bin_order.comp lists them, dof_sprites.comp takes them).
#define LIST_BLURRED_LEVEL1 6  // CLASS_COUNT
#define LIST_SPRITE_TILES 10
#define LIST_COUNT 11

// An entry of a level's gather list (dof_level_lists.comp): the tile's index in the low
// LEVEL_LIST_TILE_BITS bits, above them the tiles of its 3x3 neighbourhood of the level's class
// (bit (dy + 1) * 3 + dx + 1; bit 4 the tile itself), which decide the texels its composites
// read (dof_level_gather.comp). Worked out once per tile there rather than by every texel of the
// gather: lavapipe reads a buffer lane by lane at an index it cannot prove uniform, and the nine
// class reads were a fifth of the level-2 gather's time.
#define LEVEL_LIST_TILE_BITS 23
uint level_list_tile(uint entry) { return entry & ((1u << LEVEL_LIST_TILE_BITS) - 1u); }
uint level_list_near(uint entry) { return entry >> LEVEL_LIST_TILE_BITS; }

// The args buffer of indirect dispatches (x, y, z): per class one workgroup per tile (its x is
// the class's tile count), per level the level gather's workgroups, the sprite binning's (one
// invocation per sprite); the sprite counters; the level gathers' tile counts; the highlight
// test's workgroups and candidates; the composite's dispatches over the blurred lists.
#define ARGS_DISPATCH_WORDS 3
#define ARGS_TILES(c) ((c) * ARGS_DISPATCH_WORDS)
#define ARGS_LEVEL_GATHER_BASE 18
#define ARGS_LEVEL_GATHER(level) (ARGS_LEVEL_GATHER_BASE + ((level) - 1) * ARGS_DISPATCH_WORDS)
#define ARGS_BIN_DISPATCH 30
#define ARGS_SPRITE_COUNT 33
#define ARGS_SPRITES_DROPPED 34
#define ARGS_BIN_OVERFLOWS 35
// The number of tiles in each level's gather list (dof_level_lists.comp).
#define ARGS_LEVEL_TILES_BASE 36
#define ARGS_LEVEL_TILES(level) (ARGS_LEVEL_TILES_BASE + (level) - 1)
// The highlight test's dispatch (GROUP_SIZE candidate texels per workgroup) and its count of
// candidate half-resolution texels (dof_downsample.comp lists them, dof_highlights.comp tests).
#define ARGS_HIGHLIGHT_DISPATCH 40
#define ARGS_HIGHLIGHT_COUNT 43
// The composite's dispatches over the blurred lists, one workgroup per tile (x, y, z per level).
#define ARGS_BLURRED_TILES_BASE 44
#define ARGS_BLURRED_TILES(level) (ARGS_BLURRED_TILES_BASE + ((level) - 1) * ARGS_DISPATCH_WORDS)
// The sprites' dispatch over the tiles with sprites, one workgroup per tile (x, y, z).
#define ARGS_SPRITE_TILES 56
#define ARGS_WORDS 59

// Invocations per workgroup of the level gathers and of the sprite binning.
#define GROUP_SIZE 64

// A sprite: vec2 + float + float + vec4 (std430: 32 bytes, 8 words).
#define SPRITE_WORDS 8
struct Sprite {
    vec2 centre_px;
    float coc_px;
    float pad;
    vec4 color;
};

// Sprites binned per tile: for each tile a count, then BIN_CAPACITY sprite indices. A tile
// with more sprites than that reads every sprite (and the overflow is counted).
#define BIN_CAPACITY 128

#endif
