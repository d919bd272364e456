#version 450
// Motion blur, step 1: the longest velocity toward the next frame and the longest toward the
// previous frame in every 16x16 tile (McGuire et al. 2012, TileMax), after the speed clamp.
#include "common.glsl"
#include "motion.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D velocity; // next.xy, prev.xy px per frame
layout(binding = 1, std430) writeonly buffer TileMotion { vec4 tile_motion[]; }; // next.xy, prev.xy

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
    float max_speed_px;
} pc;

shared vec4 s_v[TILE_SIZE * TILE_SIZE];
shared vec2 s_len[TILE_SIZE * TILE_SIZE];
shared uvec2 s_index[TILE_SIZE * TILE_SIZE];

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint i = gl_LocalInvocationIndex;
    bool valid = !outside(p, pc.size);
    vec4 v = valid ? imageLoad(velocity, p) : vec4(0.0);
    v = vec4(clamp_speed(v.xy, pc.max_speed_px), clamp_speed(v.zw, pc.max_speed_px));
    precise float ln = v.x * v.x + v.y * v.y;
    precise float lp = v.z * v.z + v.w * v.w;
    s_v[i] = v;
    s_len[i] = valid ? vec2(ln, lp) : vec2(-1.0);
    s_index[i] = uvec2(i);
    barrier();
    // The longest of each; of equal lengths the lower index (the same as a row-major scan).
    for (uint stride = TILE_SIZE * TILE_SIZE / 2; stride > 0; stride >>= 1) {
        if (i < stride) {
            uint j = i + stride;
            vec4 a = s_v[i];
            vec2 la = s_len[i];
            uvec2 ia = s_index[i];
            vec4 b = s_v[j];
            vec2 lb = s_len[j];
            uvec2 ib = s_index[j];
            if (lb.x > la.x || (lb.x == la.x && ib.x < ia.x)) { a.xy = b.xy; la.x = lb.x; ia.x = ib.x; }
            if (lb.y > la.y || (lb.y == la.y && ib.y < ia.y)) { a.zw = b.zw; la.y = lb.y; ia.y = ib.y; }
            s_v[i] = a;
            s_len[i] = la;
            s_index[i] = ia;
        }
        barrier();
    }
    if (i == 0) {
        ivec2 t = ivec2(gl_WorkGroupID.xy);
        tile_motion[t.y * pc.tiles.x + t.x] = s_v[0];
    }
}
