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
shared float s_sum[SUMS][TILE_SIZE * TILE_SIZE];

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint i = gl_LocalInvocationIndex;
    float v[SUMS] = float[SUMS](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    if (!outside(p, pc.size)) {
        vec3 c = imageLoad(color_in, p).rgb;
        bool finite = !any(isnan(c)) && !any(isinf(c));
        if (finite && max(c.r, max(c.g, c.b)) >= fc.threshold) {
            float w = max(c.r + c.g + c.b, 0.0);
            v = float[SUMS](c.r, c.g, c.b, w * (float(p.x) + 0.5), w * (float(p.y) + 0.5), w, 1.0);
        }
    }
    for (int k = 0; k < SUMS; ++k) s_sum[k][i] = v[k];
    barrier();
    // One invocation sums, in pixel order (the same sums every run; few barriers, which CPU
    // drivers pay for).
    if (i == 0) {
        float total[SUMS] = float[SUMS](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (uint j = 0; j < TILE_SIZE * TILE_SIZE; ++j) {
            if (s_sum[SUMS - 1][j] > 0.0) {
                for (int k = 0; k < SUMS; ++k) total[k] += s_sum[k][j];
            }
        }
        uint t = gl_WorkGroupID.y * uint(fc.tiles_x) + gl_WorkGroupID.x;
        for (int k = 0; k < SUMS; ++k) tile_data[t * TILE_WORDS + k] = total[k];
        tile_data[t * TILE_WORDS + TILE_LIGHT] = -1.0;
    }
}
