// A ghost sprite's distance function and the sorting of a sprite against a tile, shared by
// flare_bins.comp (which sorts) and ghost_sprites.comp (which shades). The including shader
// declares `fc` (FlareConstants), `sprite_data[]` and includes aperture.glsl first.
// The shapes are convex with 1-Lipschitz distance functions (the polygon's edge distances, the
// clip circle's), so the tile's centre bounds every pixel of it.

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

// Sprite `s` against the tile at `origin`: its bin byte (bits 0-2 crossing channels, bits 3-5
// covering channels, 0: away from it, its bounds or a ghost channel whose edge lies more than
// the tile's half-diagonal plus half the ramp from the tile's centre, outward).
uint sprite_bin(uint s, ivec2 origin) {
    uint b = s * SPRITE_WORDS;
    vec4 box = vec4(sprite_data[b], sprite_data[b + 1], sprite_data[b + 2], sprite_data[b + 3]);
    bool meets = box.x <= box.z && box.x < float(origin.x + TILE_SIZE) && box.z >= float(origin.x)
        && box.y < float(origin.y + TILE_SIZE) && box.w >= float(origin.y);
    if (!meets) return 0u;
    int kind = int(sprite_data[b + SPRITE_KIND]);
    if (kind == KIND_GHOST) {
        vec2 tile_centre = vec2(origin) + 0.5 * float(TILE_SIZE);
        float half_ramp = 0.5 * sprite_data[b + SPRITE_SOFTNESS];
        uint mode = 0u;
        for (uint c = 0; c < 3; ++c) {
            float value = sprite_data[b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS + 3];
            if (value <= 0.0) continue;
            float d = ghost_sdf(b, c, tile_centre);
            if (d <= -(TILE_REACH + half_ramp)) {
                mode |= 1u << (c + BIN_COVERING_SHIFT);
            } else if (d < TILE_REACH + half_ramp) {
                mode |= 1u << c;
            }
        }
        return mode;
    } else if (kind == KIND_SPIKE) {
        uint d = b + SPRITE_DATA;
        vec2 t = ray_in_box(vec2(sprite_data[d], sprite_data[d + 1]), vec2(sprite_data[d + 2], sprite_data[d + 3]),
                            sprite_data[d + 4], sprite_data[d + 5], vec2(origin), vec2(origin + TILE_SIZE));
        return t.y > t.x ? 7u : 0u;
    } else if (kind == KIND_GLOW) {
        return 7u;
    }
    return 0u;
}
