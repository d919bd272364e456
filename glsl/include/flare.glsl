// Layout of the lens-flare buffers (src/passes/flare/mod.rs and its steps). The integer defines are
// Rust constants too (realcam::gpu::shaders::flare, made by build.rs).
#ifndef REALCAM_FLARE_GLSL
#define REALCAM_FLARE_GLSL
#include "common.glsl"

// Per tile of the frame (flare_tiles): the light of its pixels over the threshold.
#define TILE_ENERGY 0      // 3 words: R, G, B
#define TILE_WX 3          // sum of weight * x (weight = R + G + B)
#define TILE_WY 4
#define TILE_W 5
#define TILE_COUNT 6       // pixels over the threshold
#define TILE_LIGHT 7       // the light it joined (flare_lights), -1 none
#define TILE_WORDS 8

// A light (flare_lights): what it holds and how its flare was drawn.
#define LIGHT_ENERGY 0     // 3 words: R, G, B (scene value x pixels)
#define LIGHT_AREA 3       // pixels
#define LIGHT_X 4          // centre, px
#define LIGHT_Y 5
#define LIGHT_R0 6         // radius from which the starburst and halo are drawn, px
#define LIGHT_TILES 7      // tiles it gathered (0: an explicit light)
#define LIGHT_BOX 8        // 4 words: first and last tile x, y
#define LIGHT_MOVED 12     // 3 words: share of each channel moved into the starburst and halo
#define LIGHT_SPIKE_REACH 15 // outer radius of the spikes, px (0: none drawn)
#define LIGHT_GLOW_REACH 16  // outer radius of the glow (round diffraction and halo), px
#define LIGHT_SPIKE_SHARE 17 // share of the spikes' light on their centre line: 1 for a light of one
                             // pixel, less as its image (its CoC disc) spreads them (spike_share)
#define LIGHT_WORDS 20

// An explicit light (--flare-light, --flare-lights).
#define EXPLICIT_X 0
#define EXPLICIT_Y 1
#define EXPLICIT_ENERGY 2  // 3 words
#define EXPLICIT_AREA 5
#define EXPLICIT_WORDS 8

// A ghost in one channel (the matrix model, src/optics/flare/ghosts.rs): its centre per unit
// slope (mm), the sensor matrix's A, the entrance radius of the aperture (mm), the flip, the
// energy ratio, then up to MAX_CLIPS clip circles (offset per unit slope, radius, mm).
#define GHOST_CENTRE 0
#define GHOST_A 1
#define GHOST_RADIUS 2
#define GHOST_FLIP 3
#define GHOST_ENERGY 4
#define GHOST_CLIPS 5      // how many clips follow
#define GHOST_POSITION 6   // its centre over the light's (centre_mm / G0), for the softness
#define GHOST_CLIP0 8
#define MAX_CLIPS 24
#define GHOST_WORDS 56     // GHOST_CLIP0 + 2 * MAX_CLIPS
#define GHOST_CHANNEL_WORDS 168 // 3 channels

// A fitted ghost (Walch 2017 ch. 6-8: a lens file's [[fitted_ghost]]; src/passes/flare/fitted.rs),
// after the matrix ghosts in the ghost table: its channel, the fitted range of the angle of
// eq 8.1 (deg), the frame's px per px of the fit's frame, the fit's pivot (its frame's centre, px
// of its frame), then per parameter of src/optics/bezier_ghost.rs PARAM_NAMES its polynomial's
// coefficients c0..c3 (zeros past its order) and the range it is kept in.
#define FITTED_CHANNEL 0
#define FITTED_ANGLES 1    // 2 words: low, high
#define FITTED_SCALE 3
#define FITTED_PIVOT 4     // 2 words
#define FITTED_PARAMS 8
#define FITTED_PARAM_COUNT 13
#define FITTED_TERMS 4
#define FITTED_PARAM_WORDS 6 // FITTED_TERMS coefficients, low, high
#define FITTED_WORDS 88    // FITTED_PARAMS + FITTED_PARAM_COUNT * FITTED_PARAM_WORDS

// A sprite of the ghost-sprite kernel: bounds, kind, and per kind:
#define SPRITE_BOUNDS 0    // 4 words: x0, y0, x1, y1 (pixel coordinates; x0 > x1: none)
#define SPRITE_KIND 4
#define SPRITE_LIGHT 5
#define SPRITE_SOFTNESS 6  // ghost: the edge's ramp, px
#define SPRITE_INNER 7     // fitted: its light deep inside (I_i x its channel's value)
#define SPRITE_DATA 8
#define SPRITE_WORDS 32
#define KIND_NONE 0
// Ghost, per channel c at SPRITE_DATA + 8c: centre x, y, radius x flip, value per px, clip
// centre x, y, clip radius.
#define KIND_GHOST 1
#define GHOST_SPRITE_CHANNEL_WORDS 8
// Spike: origin x, y, direction x, y, r0, r1, then per channel the coefficient C (value x px):
// the pixel's share is C (1/t_in - 1/t_out) along the part of the ray inside it.
#define KIND_SPIKE 2
// Glow: centre x, y, r0, r1, diffraction coefficient per channel (value x px: D / r^3 per px),
// halo peak per channel (value per px), halo radius px.
#define KIND_GLOW 3
// Fitted (Walch's primitive at the light's angle, in this frame's px): the BEZIER_WORDS of
// bezier_ghost.glsl (bounds, shape, transfer, colour: the value per unit of eq 6.4's light in
// its channel, 0 in the others; eq 8.2's roll about the frame's centre).
#define KIND_FITTED 4

// The counts flare_lights writes, and the group counts of the indirect dispatches after it
// (x, y, z each): flare_bins one group per sprite, ghost_sprites every tile where a light was
// found and none where not (it adds to the colour in place).
#define ARGS_LIGHTS 0
#define ARGS_LIT_TILES 1
#define ARGS_BIN_GROUPS 4
#define ARGS_SPRITE_GROUPS 8
#define ARGS_WORDS 12

// The share of a spike's light on its centre line for a light of `area` px, relative to one
// pixel's: the disc of the light's image convolved with the line, sampled by a 1 px strip
// (src/optics/flare/starburst.rs spike_share).
float strip_share(float d) {
    float h = min(1.0, 1.0 / d);
    float c = sqrt(max(1.0 - h * h, 0.0));
    // asin, refined by a Newton step on sin y = h (CPU drivers' asin is good to about 1e-4;
    // h <= 0.89 here, so cos y >= 0.46).
    float y = asin(h);
    if (c > 0.1) y -= (sin(y) - h) / cos(y);
    return (2.0 / PI) * (y + h * c);
}
float spike_share(float area) {
    float d = 2.0 * sqrt(max(area, 1.0) / PI);
    return min(1.0, strip_share(d) / strip_share(2.0 / sqrt(PI)));
}

// The frame's flare settings (src/passes/flare/types.rs FlareConstants, 4-byte fields).
struct FlareConstants {
    int width;
    int height;
    int tiles_x;
    int tiles_y;
    float threshold;       // a pixel with a channel at least this (scene value) belongs to a light
    float visible;         // an element is drawn where it adds at least this
    float pitch_mm;
    float centre_x;
    float centre_y;
    float g0_mm;           // the light's image height per unit slope
    int ghost_count;
    int merge_tiles;       // a lit tile joins a light whose tiles are at most this many tiles away
    int explicit_count;
    float min_ghost_radius_px;
    int spike_count;       // 0: no spikes
    float spike_coef_px[4];// per channel: one edge's spike carries coef E / r^2 per px at r px
    float glow_coef_px[4]; // per channel: the diffraction glow is coef E / r^3 per px^2
    float halo_fraction;
    float halo_radius_px;
    float max_radius_px;   // spikes and glows end here at the latest
    int slots_per_light;   // ghost_count + fitted_count + spike_count + 1
    int blades;
    float rotation;
    float curvature;
    float aperture_area;   // area of the aperture of circumradius 1
    int fitted_count;      // fitted ghosts in the table, after the ghost_count matrix ghosts
    int band_top_px;       // the image is the band of the frame from this row (0: the frame)
    int band_height_px;    // the band's rows (0: the frame's); a multiple of TILE_SIZE but the last
};

// The pixel's square [p, p + 1]^2 against the ray o + t d, t in [t0, t1]: the part inside.
vec2 ray_in_box(vec2 o, vec2 d, float t0, float t1, vec2 lo, vec2 hi) {
    for (int a = 0; a < 2; ++a) {
        if (abs(d[a]) < 1e-12) {
            if (o[a] < lo[a] || o[a] >= hi[a]) return vec2(1.0, 0.0);
        } else {
            float ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    return vec2(t0, t1);
}

// Area of the intersection of two disks of radii r1, r2 whose centres are d apart
// (src/optics/flare/mod.rs disk_overlap_area).
float disk_overlap(float r1, float r2, float d) {
    if (d >= r1 + r2) return 0.0;
    if (d <= abs(r1 - r2)) return PI * min(r1, r2) * min(r1, r2);
    float a1 = acos(clamp((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1), -1.0, 1.0));
    float a2 = acos(clamp((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2), -1.0, 1.0));
    float k = max((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2), 0.0);
    return r1 * r1 * a1 + r2 * r2 * a2 - 0.5 * sqrt(k);
}

#endif

// Sprite bins (flare_bins -> ghost_sprites): per tile, one byte per sprite, four sprites a
// word in sprite order: bits 0-2 channel c evaluated per pixel (the sprite crosses the tile),
// bits 3-5 channel c's light the same at every pixel of the tile (covers it), 0: away.
#define BIN_SPRITES_PER_WORD 4
#define BIN_COVERING_SHIFT 3
// ghost_sprites lists a tile's crossing sprites per kind, up to this many of each at once
// (batches when the sprite slots are more).
#define SPRITE_LIST 1024
