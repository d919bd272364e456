#version 450
// Lens flare, step 2 (one workgroup): the tiles with light pixels become a short list of lights,
// and every light's flare elements become sprites for the ghost-sprite kernel.
//   1. The lit tiles, in order.
//   2. One invocation walks them in that order: a tile joins the first light whose tiles lie
//      within `merge_tiles` of it, or starts a new one; when the list is full, it joins the
//      nearest. The explicit lights follow.
//   3. Per light: its centre (energy-weighted), the radius from which the starburst and halo
//      are drawn (its visible area's), how far they stay visible, and the share of its light
//      they take (which the kernel takes from its pixels).
//   4. Per (light, element): a sprite with tight bounds, or none where the element would add
//      less than `visible` anywhere: every ghost of the table (src/optics/flare/ghosts.rs), every
//      fitted ghost (Walch's primitives, src/passes/flare/fitted.rs), every spike of the
//      starburst, one glow (the round diffraction and the halo).
#include "common.glsl"
#include "flare.glsl"
#include "bezier_ghost.glsl"

#define GROUP 256
#define MAX_LIGHTS 64
// A light being gathered: energy (3), weight * x, weight * y, weight, pixels, tiles, tile box (4).
#define ACC_WORDS 12

// Whether the lens has fitted ghosts: without, the fitted sprites' code is not in the pipeline at
// all (on lavapipe it is more than half of this shader's compile at its first dispatch: the demo's
// cold flare_lights 2.4 -> 1.1 s, for a kernel that then runs in 3 ms).
layout(constant_id = 0) const bool LIGHTS_FITTED = true;
// The same for the matrix ghosts (a lens without a prescription has none).
layout(constant_id = 1) const bool LIGHTS_GHOSTS = true;

layout(local_size_x = GROUP) in;
layout(binding = 0, std430) readonly buffer FlareParams { FlareConstants fc; };
layout(binding = 1, std430) buffer FlareTiles { float tile_data[]; };
layout(binding = 2, std430) readonly buffer ExplicitLights { float explicit_data[]; };
layout(binding = 3, std430) readonly buffer GhostTable { float ghost_data[]; };
layout(binding = 4, std430) writeonly buffer FlareLights { float light_data[]; };
layout(binding = 5, std430) writeonly buffer FlareSprites { float sprite_data[]; };
layout(binding = 6, std430) writeonly buffer FlareArgs { uint args[]; };
layout(binding = 7, std430) buffer LitTiles { uint lit[]; };

layout(push_constant) uniform Push { int max_lights; } pc;

shared uint s_lit_total;
shared float s_acc[MAX_LIGHTS][ACC_WORDS];
shared uint s_lights;
// The lights as written to FlareLights, for step 4.
shared float s_light[MAX_LIGHTS][LIGHT_WORDS];

void write_none(uint s) {
    sprite_data[s * SPRITE_WORDS + SPRITE_BOUNDS] = 1.0;
    sprite_data[s * SPRITE_WORDS + SPRITE_BOUNDS + 1] = 1.0;
    sprite_data[s * SPRITE_WORDS + SPRITE_BOUNDS + 2] = 0.0;
    sprite_data[s * SPRITE_WORDS + SPRITE_BOUNDS + 3] = 0.0;
    sprite_data[s * SPRITE_WORDS + SPRITE_KIND] = float(KIND_NONE);
}

// The sprite's box (pixel coordinates, continuous) clamped to the frame: none when empty.
bool write_bounds(uint s, vec2 lo, vec2 hi, uint kind, uint light) {
    lo = max(lo, vec2(0.0));
    hi = min(hi, vec2(fc.width, fc.height));
    if (!(lo.x < hi.x && lo.y < hi.y)) {
        write_none(s);
        return false;
    }
    uint b = s * SPRITE_WORDS;
    sprite_data[b + SPRITE_BOUNDS] = lo.x;
    sprite_data[b + SPRITE_BOUNDS + 1] = lo.y;
    sprite_data[b + SPRITE_BOUNDS + 2] = hi.x;
    sprite_data[b + SPRITE_BOUNDS + 3] = hi.y;
    sprite_data[b + SPRITE_KIND] = float(kind);
    sprite_data[b + SPRITE_LIGHT] = float(light);
    return true;
}

// The matrix ghost g of light l (src/optics/flare/ghosts.rs GhostChannel::shape).
void ghost_sprite(uint s, uint l, uint g) {
    if (!LIGHTS_GHOSTS) {
        write_none(s);
        return;
    }
        vec2 light = vec2(s_light[l][LIGHT_X], s_light[l][LIGHT_Y]);
    vec2 centre = vec2(fc.centre_x, fc.centre_y);
    vec2 u = (light - centre) * fc.pitch_mm / fc.g0_mm;
    float u_len = length(u);
    float source_radius = sqrt(s_light[l][LIGHT_AREA] / PI);
    vec2 lo = vec2(1e30), hi = vec2(-1e30);
    uint b = s * SPRITE_WORDS;
    float softness = 1.0;
    for (uint c = 0; c < 3; ++c) {
        uint t = (g * 3 + c) * GHOST_WORDS;
        float radius_mm = ghost_data[t + GHOST_RADIUS];
        // The clip that removes the most of the aperture's circle.
        float least = 1e38, clip_offset = 0.0, clip_radius = 1e30;
        int clips = int(ghost_data[t + GHOST_CLIPS]);
        for (int k = 0; k < clips; ++k) {
            float offset = ghost_data[t + GHOST_CLIP0 + 2 * k];
            float r = ghost_data[t + GHOST_CLIP0 + 2 * k + 1];
            float overlap = disk_overlap(radius_mm, r, abs(offset) * u_len);
            if (overlap < least) {
                least = overlap;
                clip_offset = offset;
                clip_radius = r;
            }
        }
        float a = ghost_data[t + GHOST_A];
        float radius_px = max(abs(a) * radius_mm / fc.pitch_mm, fc.min_ghost_radius_px);
        float scale = radius_px / radius_mm * (a < 0.0 ? -1.0 : 1.0);
        vec2 at = centre + ghost_data[t + GHOST_CENTRE] * u / fc.pitch_mm;
        vec2 clip_at = at + scale * clip_offset * u;
        float clip_px = min(abs(scale) * clip_radius, 1e30);
        float area_mm2 = fc.aperture_area * radius_mm * radius_mm;
        float value = s_light[l][LIGHT_ENERGY + c] * ghost_data[t + GHOST_ENERGY] / (area_mm2 * scale * scale);
        bool shown = least > 0.0 && value >= fc.visible;
        uint cb = b + SPRITE_DATA + c * GHOST_SPRITE_CHANNEL_WORDS;
        sprite_data[cb] = at.x;
        sprite_data[cb + 1] = at.y;
        sprite_data[cb + 2] = radius_px * ghost_data[t + GHOST_FLIP];
        sprite_data[cb + 3] = shown ? value : 0.0;
        sprite_data[cb + 4] = clip_at.x;
        sprite_data[cb + 5] = clip_at.y;
        sprite_data[cb + 6] = clip_px;
        sprite_data[cb + 7] = 0.0;
        softness = max(softness, 1.0 + 2.0 * abs(ghost_data[t + GHOST_POSITION]) * source_radius);
        if (shown) {
            vec2 reach = vec2(radius_px + 1.0);
            vec2 clip_reach = vec2(clip_px + 1.0);
            lo = min(lo, max(at - reach, clip_at - clip_reach));
            hi = max(hi, min(at + reach, clip_at + clip_reach));
        }
    }
    lo -= vec2(0.5 * softness);
    hi += vec2(0.5 * softness);
    if (write_bounds(s, lo, hi, KIND_GHOST, l)) sprite_data[b + SPRITE_SOFTNESS] = softness;
}

// Polynomial parameter k of the fitted ghost at table word t at angle a (deg), kept in its range
// (src/optics/bezier_ghost.rs GhostPolynomials::at).
float fitted_param(uint t, uint k, float a) {
    uint p = t + FITTED_PARAMS + k * FITTED_PARAM_WORDS;
    float v = ghost_data[p + FITTED_TERMS - 1];
    for (int i = FITTED_TERMS - 2; i >= 0; --i) v = v * a + ghost_data[p + uint(i)];
    return clamp(v, ghost_data[p + FITTED_TERMS], ghost_data[p + FITTED_TERMS + 1]);
}

// Fitted ghost g of light l (Walch 2017 ch. 8; src/passes/flare/fitted.rs fitted_sprite): eq
// 8.1's angle between the axis and the light, from its place in the frame (the slope u of
// the matrix ghosts); outside the fitted range none (the polynomials do not extrapolate). The
// primitive of the polynomials at that angle, drawn towards the light: eq 8.2's roll about the
// frame's centre; the fit's pixels scaled to this frame's. Eq 8.3's brightness: the fits are per
// unit of the light's own image's energy, so the light's energy in the channel (over the
// scale^2 of the pixels' areas) scales them.
void fitted_sprite(uint s, uint l, uint g) {
    if (!LIGHTS_FITTED) {
        write_none(s);
        return;
    }
    uint t = uint(fc.ghost_count) * GHOST_CHANNEL_WORDS + g * FITTED_WORDS;
    vec2 centre = vec2(fc.centre_x, fc.centre_y);
    vec2 u = (vec2(s_light[l][LIGHT_X], s_light[l][LIGHT_Y]) - centre) * fc.pitch_mm / fc.g0_mm;
    float slope = length(u);
    float angle = degrees(atan(slope));
    float lo = ghost_data[t + FITTED_ANGLES], hi = ghost_data[t + FITTED_ANGLES + 1];
    if (!(angle >= lo - 1e-3 && angle <= hi + 1e-3)) {
        write_none(s);
        return;
    }
    angle = clamp(angle, lo, hi);
    // On screen (y down) the light's direction is +x turned counter-clockwise by atan2(-u_y, u_x).
    float roll = slope > 0.0 ? atan(-u.y, u.x) : 0.0;
    float p[FITTED_PARAM_COUNT];
    for (uint k = 0; k < FITTED_PARAM_COUNT; ++k) p[k] = fitted_param(t, k, angle);
    float scale = ghost_data[t + FITTED_SCALE];
    vec2 pivot = vec2(ghost_data[t + FITTED_PIVOT], ghost_data[t + FITTED_PIVOT + 1]);
    vec2 m = centre + scale * (vec2(p[0], p[1]) - pivot);
    float h = scale * p[2], left = scale * p[3], right = scale * p[4];
    float fi = scale * p[9], fo = scale * p[10];
    uint channel = uint(ghost_data[t + FITTED_CHANNEL]);
    float value = s_light[l][LIGHT_ENERGY + channel] / (scale * scale);
    if (!(max(p[7], p[8]) * value >= fc.visible)) {
        write_none(s);
        return;
    }
    // The primitive's box (the shape and its outer fade) turned about the centre.
    float reach = fo + 1.0;
    float cs = cos(roll), sn = sin(roll);
    vec2 lo_px = vec2(1e30), hi_px = vec2(-1e30);
    for (uint k = 0; k < 4; ++k) {
        vec2 corner = vec2((k & 1u) == 0u ? m.x - left - reach : m.x + right + reach,
                           (k & 2u) == 0u ? m.y - h - reach : m.y + h + reach);
        vec2 o = corner - centre;
        vec2 turned = centre + vec2(cs * o.x + sn * o.y, -sn * o.x + cs * o.y);
        lo_px = min(lo_px, turned);
        hi_px = max(hi_px, turned);
    }
    if (!write_bounds(s, lo_px, hi_px, KIND_FITTED, l)) return;
    uint b = s * SPRITE_WORDS;
    uint w = b + SPRITE_DATA;
    sprite_data[b + SPRITE_SOFTNESS] = 0.0;
    sprite_data[b + SPRITE_INNER] = p[8] * value;
    // The bounds as write_bounds clamped them.
    vec4 box = vec4(max(lo_px, vec2(0.0)), min(hi_px, vec2(fc.width, fc.height)));
    for (uint k = 0; k < 4; ++k) sprite_data[w + BEZIER_BOUNDS + k] = box[k];
    float shape[7] = float[7](m.x, m.y, h, left, right, p[5], p[6]);
    for (uint k = 0; k < 7; ++k) sprite_data[w + BEZIER_SHAPE + k] = shape[k];
    float transfer[6] = float[6](p[7], p[8], fi, fo, p[11], p[12]);
    for (uint k = 0; k < 6; ++k) sprite_data[w + BEZIER_TRANSFER + k] = transfer[k];
    for (uint c = 0; c < 3; ++c) sprite_data[w + BEZIER_COLOUR + c] = c == channel ? value : 0.0;
    sprite_data[w + BEZIER_ROLL] = cs;
    sprite_data[w + BEZIER_ROLL + 1] = -sn;
    sprite_data[w + BEZIER_ROLL + 2] = centre.x;
    sprite_data[w + BEZIER_ROLL + 3] = centre.y;
}

// Spike k of light l: along an edge's normal (n for an even blade count, each two edges; 2n for
// an odd one).
void spike_sprite(uint s, uint l, uint k) {
        int n = fc.blades;
    bool even = n % 2 == 0;
    float sector = 2.0 * PI / float(n);
    uint edge = even ? k : k % uint(n);
    float angle = 0.5 * PI + fc.rotation + (float(edge) + 0.5) * sector;
    vec2 dir = vec2(cos(angle), -sin(angle)) * (!even && k >= uint(n) ? -1.0 : 1.0);
    float edges = even ? 2.0 : 1.0;
    float r0 = s_light[l][LIGHT_R0];
    float r1 = s_light[l][LIGHT_SPIKE_REACH];
    vec3 coef = vec3(0.0);
    float share = s_light[l][LIGHT_SPIKE_SHARE];
    for (uint c = 0; c < 3; ++c) coef[c] = share * edges * fc.spike_coef_px[c] * s_light[l][LIGHT_ENERGY + c];
    vec2 o = vec2(s_light[l][LIGHT_X], s_light[l][LIGHT_Y]);
    bool shown = max(coef.r, max(coef.g, coef.b)) / (r0 * r0) >= fc.visible && r1 > r0;
    if (!shown) {
        write_none(s);
        return;
    }
    vec2 a = o + r0 * dir, e = o + r1 * dir;
    if (!write_bounds(s, min(a, e) - 1.0, max(a, e) + 1.0, KIND_SPIKE, l)) return;
    uint b = s * SPRITE_WORDS + SPRITE_DATA;
    sprite_data[b] = o.x;
    sprite_data[b + 1] = o.y;
    sprite_data[b + 2] = dir.x;
    sprite_data[b + 3] = dir.y;
    sprite_data[b + 4] = r0;
    sprite_data[b + 5] = r1;
    for (uint c = 0; c < 3; ++c) sprite_data[b + 6 + c] = coef[c];
}

// The glow of light l: the round part of the diffraction and the halo.
void glow_sprite(uint s, uint l) {
    float r0 = s_light[l][LIGHT_R0];
    float r1 = s_light[l][LIGHT_GLOW_REACH];
    vec2 o = vec2(s_light[l][LIGHT_X], s_light[l][LIGHT_Y]);
    if (!(r1 > r0) || !write_bounds(s, o - r1 - 1.0, o + r1 + 1.0, KIND_GLOW, l)) {
        if (!(r1 > r0)) write_none(s);
        return;
    }
    float rho = fc.halo_radius_px;
    uint b = s * SPRITE_WORDS + SPRITE_DATA;
    sprite_data[b] = o.x;
    sprite_data[b + 1] = o.y;
    sprite_data[b + 2] = r0;
    sprite_data[b + 3] = r1;
    for (uint c = 0; c < 3; ++c) {
        float e = s_light[l][LIGHT_ENERGY + c];
        sprite_data[b + 4 + c] = fc.glow_coef_px[c] * e;
        sprite_data[b + 7 + c] = rho > 0.0 ? fc.halo_fraction * e / (2.0 * PI * rho * rho) : 0.0;
    }
    sprite_data[b + 10] = rho;
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    uint tile_count = uint(fc.tiles_x * fc.tiles_y);
    uint max_lights = uint(min(pc.max_lights, MAX_LIGHTS));

    // 1. The lit tiles in order (one invocation: a pass over the tile records).
    if (lid == 0) {
        uint n = 0;
        for (uint t = 0; t < tile_count; ++t) {
            if (tile_data[t * TILE_WORDS + TILE_COUNT] > 0.0) lit[n++] = t;
        }
        s_lit_total = n;
    }

    // 2. Tiles into lights, in order, by one invocation; then the explicit lights.
    if (lid == 0) {
        uint n = 0;
        int merge = fc.merge_tiles;
        for (uint k = 0; k < s_lit_total; ++k) {
            uint t = lit[k];
            int tx = int(t % uint(fc.tiles_x)), ty = int(t / uint(fc.tiles_x));
            uint tb = t * TILE_WORDS;
            int join = -1;
            for (uint l = 0; l < n && join < 0; ++l) {
                if (tx >= int(s_acc[l][8]) - merge && tx <= int(s_acc[l][10]) + merge && ty >= int(s_acc[l][9]) - merge
                    && ty <= int(s_acc[l][11]) + merge) {
                    join = int(l);
                }
            }
            if (join < 0 && n < max_lights) {
                join = int(n++);
                for (int w = 0; w < 8; ++w) s_acc[join][w] = 0.0;
                s_acc[join][8] = float(tx);
                s_acc[join][9] = float(ty);
                s_acc[join][10] = float(tx);
                s_acc[join][11] = float(ty);
            }
            if (join < 0) {
                // The list is full: the nearest light (tile centres against the lights' boxes'
                // centres) takes it, so no light is lost.
                float best = 1e38;
                for (uint l = 0; l < n; ++l) {
                    vec2 c = 0.5 * vec2(s_acc[l][8] + s_acc[l][10], s_acc[l][9] + s_acc[l][11]);
                    float d = distance(c, vec2(tx, ty));
                    if (d < best) {
                        best = d;
                        join = int(l);
                    }
                }
            }
            for (int w = 0; w < 7; ++w) s_acc[join][w] += tile_data[tb + w];
            s_acc[join][7] += 1.0;
            s_acc[join][8] = min(s_acc[join][8], float(tx));
            s_acc[join][9] = min(s_acc[join][9], float(ty));
            s_acc[join][10] = max(s_acc[join][10], float(tx));
            s_acc[join][11] = max(s_acc[join][11], float(ty));
            tile_data[tb + TILE_LIGHT] = float(join);
        }
        for (int e = 0; e < fc.explicit_count && n < max_lights; ++e) {
            uint eb = uint(e) * EXPLICIT_WORDS;
            for (int c = 0; c < 3; ++c) s_acc[n][c] = explicit_data[eb + EXPLICIT_ENERGY + c];
            // Its position as a weight-1 centroid; its area; no tiles.
            s_acc[n][3] = explicit_data[eb + EXPLICIT_X];
            s_acc[n][4] = explicit_data[eb + EXPLICIT_Y];
            s_acc[n][5] = 1.0;
            s_acc[n][6] = explicit_data[eb + EXPLICIT_AREA];
            s_acc[n][7] = 0.0;
            for (int w = 8; w < 12; ++w) s_acc[n][w] = -1.0;
            n++;
        }
        s_lights = n;
        args[ARGS_LIGHTS] = n;
        args[ARGS_LIT_TILES] = s_lit_total;
        // Without a light no sprite is made and the frame keeps its colour (the sprites add to
        // it in place): the binning and the sprites dispatch no group.
        // The sprites are drawn on the band's tile rows (a band's: from fc.band_top_px).
        int rows = fc.band_height_px > 0 ? (fc.band_height_px + TILE_SIZE - 1) / TILE_SIZE : fc.tiles_y;
        uvec3 tiles = uvec3(fc.tiles_x, rows, 1);
        uvec3 sprites = n > 0u ? tiles : uvec3(0u, 1u, 1u);
        for (uint k = 0; k < 3; ++k) {
            args[ARGS_BIN_GROUPS + k] = k == 0u ? n * uint(fc.slots_per_light) : 1u;
            args[ARGS_SPRITE_GROUPS + k] = sprites[k];
        }
    }
    barrier();
    uint lights = s_lights;

    // 3. Each light's centre, the radii of its starburst and halo, the share they take.
    for (uint l = lid; l < lights; l += GROUP) {
                vec3 e = vec3(s_acc[l][0], s_acc[l][1], s_acc[l][2]);
        float w = s_acc[l][5];
        vec2 box_centre = (0.5 * vec2(s_acc[l][8] + s_acc[l][10], s_acc[l][9] + s_acc[l][11]) + 0.5) * float(TILE_SIZE);
        vec2 at = w > 0.0 ? vec2(s_acc[l][3], s_acc[l][4]) / w : box_centre;
        float area = max(s_acc[l][6], 1.0);
        float r0 = max(1.0, sqrt(area / PI));
        float e_max = max(e.r, max(e.g, e.b));
        // Spikes: visible while one edge's spike adds `visible` to a pixel: share coef E / r^2,
        // the share on the centre line falling as the light's image (its CoC disc) spreads them.
        float share = spike_share(area);
        float spike_reach = 0.0;
        float spike_peak = 0.0;
        for (uint c = 0; c < 3; ++c) spike_peak = max(spike_peak, share * fc.spike_coef_px[c] * e[c]);
        if (fc.spike_count > 0 && spike_peak / (r0 * r0) >= fc.visible) {
            spike_reach = min(sqrt(spike_peak / fc.visible), fc.max_radius_px);
        }
        // The glow: the diffraction D / r^3 and the halo, whichever reaches farther.
        float rho = fc.halo_radius_px;
        float glow_peak = 0.0;
        for (uint c = 0; c < 3; ++c) glow_peak = max(glow_peak, fc.glow_coef_px[c] * e[c]);
        float halo_peak = rho > 0.0 ? fc.halo_fraction * e_max / (2.0 * PI * rho * rho) : 0.0;
        float glow_reach = pow(glow_peak / fc.visible, 1.0 / 3.0);
        if (halo_peak > fc.visible) glow_reach = max(glow_reach, rho * sqrt(max(pow(halo_peak / fc.visible, 2.0 / 3.0) - 1.0, 0.0)));
        glow_reach = min(glow_reach, fc.max_radius_px);
        float at_r0 = glow_peak / (r0 * r0 * r0) + (rho > 0.0 ? halo_peak * pow(1.0 + r0 * r0 / (rho * rho), -1.5) : 0.0);
        if (!(at_r0 >= fc.visible)) glow_reach = 0.0;
        // The share of each channel the drawn elements take from the light's own pixels.
        vec3 moved = vec3(0.0);
        for (uint c = 0; c < 3; ++c) {
            if (spike_reach > r0) moved[c] += 2.0 * float(fc.blades) * share * fc.spike_coef_px[c] * (1.0 / r0 - 1.0 / spike_reach);
            if (glow_reach > r0) {
                moved[c] += 2.0 * PI * fc.glow_coef_px[c] * (1.0 / r0 - 1.0 / glow_reach);
                if (rho > 0.0) {
                    moved[c] += fc.halo_fraction * (1.0 / sqrt(1.0 + r0 * r0 / (rho * rho)) - 1.0 / sqrt(1.0 + glow_reach * glow_reach / (rho * rho)));
                }
            }
        }
        for (uint c = 0; c < 3; ++c) s_light[l][LIGHT_ENERGY + c] = e[c];
        s_light[l][LIGHT_AREA] = area;
        s_light[l][LIGHT_X] = at.x;
        s_light[l][LIGHT_Y] = at.y;
        s_light[l][LIGHT_R0] = r0;
        s_light[l][LIGHT_TILES] = s_acc[l][7];
        for (uint k = 0; k < 4; ++k) s_light[l][LIGHT_BOX + k] = s_acc[l][8 + k];
        for (uint c = 0; c < 3; ++c) s_light[l][LIGHT_MOVED + c] = min(moved[c], 0.5);
        s_light[l][LIGHT_SPIKE_REACH] = spike_reach;
        s_light[l][LIGHT_GLOW_REACH] = glow_reach;
        s_light[l][LIGHT_SPIKE_SHARE] = share;
        for (uint k = LIGHT_SPIKE_SHARE + 1; k < LIGHT_WORDS; ++k) s_light[l][k] = 0.0;
        for (uint k = 0; k < LIGHT_WORDS; ++k) light_data[l * LIGHT_WORDS + k] = s_light[l][k];
    }
    barrier();

    // 4. The sprites.
    uint slots = uint(fc.slots_per_light);
    for (uint s = lid; s < lights * slots; s += GROUP) {
        uint l = s / slots, e = s % slots;
        uint fitted_end = uint(fc.ghost_count + fc.fitted_count);
        if (e < uint(fc.ghost_count)) {
            ghost_sprite(s, l, e);
        } else if (e < fitted_end) {
            fitted_sprite(s, l, e - uint(fc.ghost_count));
        } else if (e < fitted_end + uint(fc.spike_count)) {
            spike_sprite(s, l, e - fitted_end);
        } else {
            glow_sprite(s, l);
        }
    }
}
