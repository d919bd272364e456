#version 450
// Motion blur, step 1: the longest velocity toward the next frame and the longest toward the
// previous frame in every 16x16 tile (McGuire et al. 2012, TileMax), after the speed clamp. One
// invocation scans a tile row by row; of equal lengths the first wins.
#include "common.glsl"
#include "motion.glsl"

layout(local_size_x = 64) in;
layout(binding = 0, rgba32f) uniform readonly image2D velocity; // next.xy, prev.xy px per frame
layout(binding = 1, std430) writeonly buffer TileMotion { vec4 tile_motion[]; }; // next.xy, prev.xy

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
    float max_speed_px;
} pc;

void main() {
    int t = int(gl_GlobalInvocationID.x);
    if (t >= pc.tiles.x * pc.tiles.y) return;
    ivec2 origin = ivec2(t % pc.tiles.x, t / pc.tiles.x) * TILE_SIZE;
    vec4 best = vec4(0.0);
    vec2 best_len = vec2(-1.0);
    for (int y = origin.y; y < min(origin.y + TILE_SIZE, pc.size.y); ++y) {
        for (int x = origin.x; x < min(origin.x + TILE_SIZE, pc.size.x); ++x) {
            vec4 v = imageLoad(velocity, ivec2(x, y));
            v = vec4(clamp_speed(v.xy, pc.max_speed_px), clamp_speed(v.zw, pc.max_speed_px));
            precise float ln = v.x * v.x + v.y * v.y;
            precise float lp = v.z * v.z + v.w * v.w;
            if (ln > best_len.x) { best.xy = v.xy; best_len.x = ln; }
            if (lp > best_len.y) { best.zw = v.zw; best_len.y = lp; }
        }
    }
    tile_motion[t] = best;
}
