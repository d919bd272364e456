#version 450
// Motion blur, step 2: for every tile, the longest next and previous velocity among the tiles
// within `search_tiles` (McGuire et al. 2012, NeighborMax, widened to the longest blur): the
// directions and reach of the gather. Each tile is then listed for the gather (mb_gather) when
// that velocity reaches half a pixel of any of its pixels while the shutter is open, else for
// the copy (mb_still). On lavapipe a pixel that copies in the gather's code still pays for most
// of it (both sides of a branch run): over scene A's still tiles, 100 of the gather's 165 ms.
#include "common.glsl"
#include "motion.glsl"

layout(local_size_x = 64) in;
layout(binding = 0, std430) readonly buffer TileMotion { vec4 tile_motion[]; };
layout(binding = 1, std430) writeonly buffer NeighborMotion { vec4 neighbor_motion[]; };
// The two dispatches (zeroed before this dispatch) and the two lists.
layout(binding = 2, std430) buffer Args { uint args[]; };
layout(binding = 3, std430) writeonly buffer TileList { uint tile_list[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
    Shutter shutter;
    int search_tiles;
    float gather_from_px;  // the reach from which a tile is listed for the gather
} pc;

void main() {
    int t = int(gl_GlobalInvocationID.x);
    if (t == 0) {
        args[MB_TILE_ARGS_MOVING + 1] = 1u;
        args[MB_TILE_ARGS_MOVING + 2] = 1u;
        args[MB_TILE_ARGS_STILL + 1] = 1u;
        args[MB_TILE_ARGS_STILL + 2] = 1u;
    }
    if (t >= pc.tiles.x * pc.tiles.y) return;
    ivec2 c = ivec2(t % pc.tiles.x, t / pc.tiles.x);
    vec4 best = vec4(0.0);
    vec2 best_len = vec2(-1.0);
    for (int dy = -pc.search_tiles; dy <= pc.search_tiles; ++dy) {
        for (int dx = -pc.search_tiles; dx <= pc.search_tiles; ++dx) {
            ivec2 n = c + ivec2(dx, dy);
            if (outside(n, pc.tiles)) continue;
            vec4 v = tile_motion[n.y * pc.tiles.x + n.x];
            precise float ln = v.x * v.x + v.y * v.y;
            precise float lp = v.z * v.z + v.w * v.w;
            if (ln > best_len.x) { best.xy = v.xy; best_len.x = ln; }
            if (lp > best_len.y) { best.zw = v.zw; best_len.y = lp; }
        }
    }
    neighbor_motion[t] = best;
    // The open time is linear over the frame (a rolling shutter's lines), so its ends reach
    // farthest from the frame time at one of the tile's corner pixels.
    ivec2 first = c * TILE_SIZE, last = min(first + TILE_SIZE - 1, pc.size - 1);
    float t_fwd = 0.0, t_back = 0.0;
    for (int i = 0; i < 4; ++i) {
        ivec2 corner = ivec2((i & 1) == 0 ? first.x : last.x, (i & 2) == 0 ? first.y : last.y);
        vec2 win = shutter_window(pc.shutter, vec2(corner) + 0.5);
        t_fwd = max(t_fwd, win.y);
        t_back = max(t_back, -win.x);
    }
    float reach = max(t_fwd * length(best.xy), t_back * length(best.zw));
    if (reach >= pc.gather_from_px) {
        uint slot = atomicAdd(args[MB_TILE_ARGS_MOVING], 1u);
        tile_list[slot] = mb_pack_pixel(c);
    } else {
        uint slot = atomicAdd(args[MB_TILE_ARGS_STILL], 1u);
        tile_list[pc.tiles.x * pc.tiles.y + int(slot)] = mb_pack_pixel(c);
    }
}
