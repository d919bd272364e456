#version 450
// Lens flare, step 1: the lights of the frame, per 16x16 tile. A pixel with a channel at or
// over the threshold (the scene value that saturates the sensor by the chosen factor) belongs
// to a light; each tile sums its light pixels' energy (per channel), their count (the visible
// area: a light partly hidden holds less) and their energy-weighted position. flare_lights
// gathers the tiles into lights.
#include "common.glsl"
#include "flare.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, std430) readonly buffer FlareParams { FlareConstants fc; };
layout(binding = 2, std430) writeonly buffer FlareTiles { float tile_data[]; };

layout(push_constant) uniform Push { ivec2 size; } pc;

#define SUMS 7
#define GROUP (TILE_SIZE * TILE_SIZE)
// A light pixel's channels count at most this much in the sums (tiles.rs FLARE_MAX_VALUE): the
// sums over a tile, and over the tiles of a light, of a frame of finite values stay finite.
#define FLARE_MAX_VALUE 1e20
// The tile's light pixels lie in s_first .. s_end - 1 (none: s_end 0).
shared uint s_first;
shared uint s_end;

// Pixel p's sums if it belongs to a light (energy per channel, energy-weighted position,
// energy, count); `lit` false and zeros if not.
float[SUMS] light_sums(ivec2 p, out bool lit) {
    lit = false;
    float v[SUMS] = float[SUMS](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    if (!outside(p, pc.size)) {
        vec3 c = imageLoad(color_in, p).rgb;
        bool finite = !any(isnan(c)) && !any(isinf(c));
        if (finite && max(c.r, max(c.g, c.b)) >= fc.threshold) {
            c = clamp(c, vec3(-FLARE_MAX_VALUE), vec3(FLARE_MAX_VALUE));
            float w = max(c.r + c.g + c.b, 0.0);
            v = float[SUMS](c.r, c.g, c.b, w * (float(p.x) + 0.5), w * (float(p.y) + 0.5), w, 1.0);
            lit = true;
        }
    }
    return v;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint i = gl_LocalInvocationIndex;
    if (i == 0u) {
        s_first = GROUP;
        s_end = 0u;
    }
    // s_first and s_end set before any invocation narrows them.
    barrier();
    bool lit;
    light_sums(p, lit);
    if (lit) {
        atomicMin(s_first, i);
        atomicMax(s_end, i + 1u);
    }
    // The range narrowed by every invocation before invocation 0 reads it.
    barrier();
    // One invocation sums, in pixel order (the same sums every run; few barriers and no
    // per-pixel shared stores, which CPU drivers pay for): it reads the range's pixels again.
    // Lavapipe runs the body of an `if` whatever the condition, but leaves a loop that no lane
    // is still in: over the range of light pixels only, a tile without any (nearly all) costs
    // one pass through the loop, not one per pixel.
    if (i == 0u) {
        float total[SUMS] = float[SUMS](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        ivec2 origin = ivec2(gl_WorkGroupID.xy) * TILE_SIZE;
        for (uint j = s_first; j < s_end; ++j) {
            bool lit_j;
            float v[SUMS] = light_sums(origin + ivec2(int(j) % TILE_SIZE, int(j) / TILE_SIZE), lit_j);
            if (lit_j) {
                for (int k = 0; k < SUMS; ++k) total[k] += v[k];
            }
        }
        uint t = gl_WorkGroupID.y * uint(fc.tiles_x) + gl_WorkGroupID.x;
        for (int k = 0; k < SUMS; ++k) tile_data[t * TILE_WORDS + k] = total[k];
        tile_data[t * TILE_WORDS + TILE_LIGHT] = -1.0;
    }
}
