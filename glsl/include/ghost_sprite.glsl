// A ghost sprite's distance function and the sorting of a sprite against a tile, shared by
// flare_bins.comp (which sorts) and ghost_sprites.comp (which shades). The including shader
// declares `fc` (FlareConstants), `sprite_data[]` and includes aperture.glsl first.
// The shapes are convex with 1-Lipschitz distance functions (the polygon's edge distances, the
// clip circle's), so the tile's centre bounds every pixel of it. A fitted sprite's distance
// (Walch's primitive, the distance to its Bezier border) is 1-Lipschitz too; the search finds it
// within FITTED_MARGIN px.
#include "fitted_ghost.glsl"

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
