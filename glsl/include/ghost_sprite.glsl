// A ghost sprite's distance function and the sorting of a sprite against a tile, shared by
// flare_bins.comp (which sorts) and ghost_sprites.comp (which shades). The including shader
// declares `fc` (FlareConstants), `sprite_data[]` and includes aperture.glsl first.
// The shapes are convex with 1-Lipschitz distance functions (the polygon's edge distances, the
// clip circle's), so the tile's centre bounds every pixel of it. A fitted sprite's distance
// (Walch's primitive, the distance to its Bezier border) is 1-Lipschitz too; the search finds it
// within FITTED_MARGIN px.
#include "bezier_ghost.glsl"

// How far (px) the 12-step search's distance may be from the exact one, for the sorting
// (src/passes/flare/fitted.rs FITTED_MARGIN_PX).
#define FITTED_MARGIN 1.0

// Half the diagonal of a tile's pixel centres.
#define TILE_REACH (0.5 * float(TILE_SIZE - 1) * 1.41421356)

// The ghost's distance (px, < 0 inside) at pixel centre q for channel c of sprite base b.
float ghost_sdf(uint b, uint c, vec2 q) {
    uint cb = b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS;
    vec2 centre = vec2(sprite_data[cb], sprite_data[cb + 1]);
    float signed_radius = sprite_data[cb + 2];
    float radius = abs(signed_radius);
    vec2 o = (q - centre) * (signed_radius < 0.0 ? -1.0 : 1.0);
    Aperture ap = Aperture(fc.blades, fc.rotation, fc.curvature, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0);
    // Past the corners the edge distance underestimates: the circumscribed circle bounds it.
    float d = max(aperture_sdf(o, radius, ap), length(o) - radius);
    return max(d, distance(q, vec2(sprite_data[cb + 4], sprite_data[cb + 5])) - sprite_data[cb + 6]);
}

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

// Eq 6.4's light of fitted sprite base b at pixel centre q (before its colour).
float fitted_light(uint b, vec2 q) {
    uint t = b + SPRITE_DATA + BEZIER_TRANSFER;
    return bezier_transfer(fitted_distance(b, q), sprite_data[t], sprite_data[t + 1], sprite_data[t + 2],
                           sprite_data[t + 3], sprite_data[t + 4], sprite_data[t + 5]);
}

// A fitted sprite is shaded from its distance at five nodes of the tile: its corner pixels'
// centres (FITTED_SPAN = 15 px apart) and its centre, interpolated bilinearly over the tile
// where the centre's distance is within FITTED_LINEAR px of the corners' mean (a distance
// bending by D between the nodes is interpolated to about D); else searched at each pixel
// (near the primitive's corners, its medial axis, a border of curvature radius under
// (15 px)^2 / 8 / 0.05 = 560 px). The Tessar's fitted primitives are mostly 1000-2000 px across.
// The twin is src/passes/flare/fitted.rs; tests/flare_fitted.rs measures the error against the
// search at every pixel.
#define FITTED_NODES 5
#define FITTED_SPAN float(TILE_SIZE - 1)
#define FITTED_LINEAR 0.05

// Node j from the tile's first pixel centre: the corners row by row, then the centre.
vec2 fitted_node(uint j) {
    return j == 4u ? vec2(0.5 * FITTED_SPAN) : FITTED_SPAN * vec2(j & 1u, j >> 1u);
}

// Whether the nodes `g` are near linear enough to interpolate.
bool fitted_linear(float g[FITTED_NODES]) {
    return abs(g[4] - 0.25 * (g[0] + g[1] + g[2] + g[3])) <= FITTED_LINEAR;
}

// The corners of `g` interpolated at `o` px from the first (0..FITTED_SPAN each way).
float fitted_interpolated(float g[FITTED_NODES], vec2 o) {
    vec2 f = o / FITTED_SPAN;
    return mix(mix(g[0], g[1], f.x), mix(g[2], g[3], f.x), f.y);
}

// Eq 6.4's light of fitted sprite base b at signed distance d (before its colour).
float fitted_transfer(uint b, float d) {
    uint t = b + SPRITE_DATA + BEZIER_TRANSFER;
    return bezier_transfer(d, sprite_data[t], sprite_data[t + 1], sprite_data[t + 2], sprite_data[t + 3],
                           sprite_data[t + 4], sprite_data[t + 5]);
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

