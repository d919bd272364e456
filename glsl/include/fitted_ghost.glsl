// Walch 2017's fitted ghost as a flare sprite (KIND_FITTED; src/passes/flare/fitted.rs is the
// twin): its signed distance by the 12-step search (bezier_ghost.glsl), eq 6.4's light of it,
// and the blocks a tile's light is shaded by. Shared by flare_bins.comp (which sorts a sprite
// against the tiles by the distance at their centres) and fitted_ghosts.comp (which shades).
// The including shader declares `sprite_data[]` and includes flare.glsl first.
#ifndef REALCAM_FITTED_GHOST_GLSL
#define REALCAM_FITTED_GHOST_GLSL
#include "bezier_ghost.glsl"

// How far (px) the 12-step search's distance may be from the exact one, for the sorting
// (src/passes/flare/fitted.rs FITTED_MARGIN_PX).
#define FITTED_MARGIN 1.0

// Half the diagonal of a tile's pixel centres.
#define TILE_REACH (0.5 * float(TILE_SIZE - 1) * 1.41421356)

// The signed distance (px, > 0 inside) of fitted sprite base b's primitive at pixel centre q:
// q turned back by eq 8.2's roll about the frame's centre, then the 12-step search of each
// side (bezier_ghost.glsl; src/optics/bezier_ghost.rs sides() for the control points).
float fitted_distance(uint b, vec2 q) {
    uint w = b + SPRITE_DATA;
    vec2 pivot = vec2(sprite_data[w + BEZIER_ROLL + 2], sprite_data[w + BEZIER_ROLL + 3]);
    float c = sprite_data[w + BEZIER_ROLL], s = sprite_data[w + BEZIER_ROLL + 1];
    vec2 o = q - pivot;
    vec2 local = pivot + vec2(c * o.x + s * o.y, -s * o.x + c * o.y);
    uint k = w + BEZIER_SHAPE;
    vec2 m = vec2(sprite_data[k], sprite_data[k + 1]) - local;
    float h = sprite_data[k + 2], l = sprite_data[k + 3], r = sprite_data[k + 4];
    float cl = sprite_data[k + 5], cr = sprite_data[k + 6];
    vec2 top = m + vec2(0.0, -h), bottom = m + vec2(0.0, h), left = m + vec2(-l, 0.0), right = m + vec2(r, 0.0);
    vec2 best = bezier_side_distance(top, m + vec2(-cl * l, -h), m + vec2(-l, -cl * h), left);
    vec2 d = bezier_side_distance(left, m + vec2(-l, cl * h), m + vec2(-cl * l, h), bottom);
    if (d.x < best.x) best = d;
    d = bezier_side_distance(bottom, m + vec2(cr * r, h), m + vec2(r, cr * h), right);
    if (d.x < best.x) best = d;
    d = bezier_side_distance(right, m + vec2(r, -cr * h), m + vec2(cr * r, -h), top);
    if (d.x < best.x) best = d;
    return best.x * best.y;
}

// Eq 6.4's light of fitted sprite base b at signed distance d (before its colour).
float fitted_transfer(uint b, float d) {
    uint t = b + SPRITE_DATA + BEZIER_TRANSFER;
    return bezier_transfer(d, sprite_data[t], sprite_data[t + 1], sprite_data[t + 2], sprite_data[t + 3],
                           sprite_data[t + 4], sprite_data[t + 5]);
}

// A fitted sprite's light over a square block of n x n pixels (a tile, n = TILE_SIZE, or a
// quarter of one) is shaded from its distance at five nodes: the block's corner pixels'
// centres (n - 1 px apart) and its centre. Where the centre's distance lies within
// FITTED_LINEAR px of the corners' mean, the distance is interpolated bilinearly over the
// block (a distance bending by D between the nodes is interpolated to about D); where not,
// the block's quarters are shaded the same way, and the pixels of a 4 px block that is still
// not near linear are searched one by one (near the primitive's corners and its medial axis).
#define FITTED_NODES 5
#define FITTED_LINEAR 0.05
#define FITTED_SMALLEST_BLOCK 4

// Node j of the n-px block whose first pixel centre is `first`: the corners row by row, then
// the centre.
vec2 fitted_node(vec2 first, int n, int j) {
    float span = float(n - 1);
    return first + (j == 4 ? vec2(0.5 * span) : span * vec2(j & 1, j >> 1));
}

// Whether the nodes `g` are near linear enough to interpolate.
bool fitted_linear(float g[FITTED_NODES]) {
    return abs(g[4] - 0.25 * (g[0] + g[1] + g[2] + g[3])) <= FITTED_LINEAR;
}

// The corners of `g` interpolated at `o` px from the block's first pixel centre (0..n-1 each way).
float fitted_interpolated(float g[FITTED_NODES], vec2 o, int n) {
    vec2 f = o / float(n - 1);
    return mix(mix(g[0], g[1], f.x), mix(g[2], g[3], f.x), f.y);
}

// Whether fitted sprite base b's light is smooth over the tile of nodes `g`: no kink of eq 6.4
// in it (its border d = 0, the fades' ends d = -F_o and F_i lie over the tile's reach from its
// centre) and the centre's light within FITTED_SMOOTH of its brightest of the corners' mean.
// Its light is then interpolated bilinearly from the corners.
#define FITTED_SMOOTH 1e-3
bool fitted_smooth(uint b, float g[FITTED_NODES]) {
    uint t = b + SPRITE_DATA + BEZIER_TRANSFER;
    float reach = TILE_REACH + FITTED_MARGIN;
    float d = g[4];
    bool clear = abs(d) > reach && abs(d + sprite_data[t + 3]) > reach && abs(d - sprite_data[t + 2]) > reach;
    float mean = 0.25 * (fitted_transfer(b, g[0]) + fitted_transfer(b, g[1]) + fitted_transfer(b, g[2])
                         + fitted_transfer(b, g[3]));
    float peak = max(sprite_data[t], sprite_data[t + 1]);
    return clear && abs(fitted_transfer(b, d) - mean) <= FITTED_SMOOTH * peak;
}

#endif
