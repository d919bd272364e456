#version 450
// Motion blur, step 0b: the anti-aliased-edge resolve's candidates (glsl/motion/mb_edges.comp
// resolves them). A pixel whose 3x3 neighbourhood spans two depth layers (7% apart, where
// depth_classes parts them fully) whose motions differ by more than half a pixel over the open
// time is appended to the edge list with an atomic counter, and the resolve is then dispatched
// indirectly over the list (as the depth of field's glsl/dof/coc.comp lists its edge pixels for
// coc_edges.comp). Over every pixel the resolve's colour reads and layer decision idled every
// lane of a group holding one edge pixel; over the list its groups are full of them.
// Step 0a (mb_tiles and mb_neighbor on the velocity as stored) lists the tiles where a pixel's
// 3x3 neighbourhood can move that much: only those are dispatched here, one workgroup per tile
// (over every pixel this test was 50 ms of scene A's 250 on lavapipe, which runs the velocity
// loop below at least once whether a lane needs it or not). The resolve's outputs start as
// copies of the velocity and depth (transfer copies, src/passes/motion/edges.rs).
#include "common.glsl"
#include "motion.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, r32f) uniform readonly image2D depth_m;
layout(binding = 1, rgba32f) uniform readonly image2D velocity; // next.xy, prev.xy px per frame
// The resolve's dispatch and counts (zeroed before this dispatch), and its pixels in any order.
layout(binding = 2, std430) buffer Args { uint args[]; };
layout(binding = 3, std430) writeonly buffer EdgePixels { uint edge_pixels[]; };
// The tiles to look at (step 0a's list of moving tiles).
layout(binding = 4, std430) readonly buffer TileList { uint tile_list[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    float t_fwd;        // frames the shutter is open after the frame time (at most)
    float t_back;       // and before it
    float max_speed_px;
    float min_share;
} pc;

// The layer key: inverse depth (larger is nearer), of a depth kept finite and positive.
float layer_key(float z) { return 1.0 / clamp(z, 1.0e-6, 1.0e30); }

vec4 clamped_velocity(vec4 v) {
    return vec4(clamp_speed(v.xy, pc.max_speed_px), clamp_speed(v.zw, pc.max_speed_px));
}

void main() {
    ivec2 p = listed_tile_pixel(tile_list[gl_WorkGroupID.x], gl_LocalInvocationID.xy);
    // The indirect dispatch's y and z (x counts up below from the zeroed buffer).
    if (gl_WorkGroupID.x == 0u && gl_LocalInvocationIndex == 0u) {
        args[MB_EDGE_ARGS_DISPATCH + 1] = 1u;
        args[MB_EDGE_ARGS_DISPATCH + 2] = 1u;
    }
    if (outside(p, pc.size)) return;
    vec4 v_raw = imageLoad(velocity, p);
    float z_raw = imageLoad(depth_m, p).r;
    // The depths first: most pixels lie within one layer and read no neighbour's velocity.
    float w_near = layer_key(z_raw), w_far = w_near;
    for (int i = 0; i < 9; ++i) {
        float w = layer_key(imageLoad(depth_m, clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), pc.size - 1)).r);
        w_near = max(w_near, w);
        w_far = min(w_far, w);
    }
    if (!(w_near > w_far * 1.0717735)) return;
    vec4 v_p = clamped_velocity(v_raw);
    float motion = 0.0;
    for (int i = 0; i < 9; ++i) {
        vec4 v = clamped_velocity(imageLoad(velocity, clamp(p + ivec2(i % 3 - 1, i / 3 - 1), ivec2(0), pc.size - 1)));
        motion = max(motion, max(length(v.xy - v_p.xy) * pc.t_fwd, length(v.zw - v_p.zw) * pc.t_back));
    }
    if (motion > 0.5) {
        uint slot = atomicAdd(args[MB_EDGE_ARGS_COUNT], 1u);
        edge_pixels[slot] = mb_pack_pixel(p);
        if (slot % uint(MB_EDGE_GROUP_SIZE) == 0u) atomicAdd(args[MB_EDGE_ARGS_DISPATCH], 1u);
    }
}
