#version 450
// Circle of confusion: signed diameter in pixels from planar depth (Kyaw 2013 eq 5.3).
// Foreground (nearer than the focus distance) negative, background positive, 0 in focus.
//
// Every pixel gets the CoC of its own depth here. With RESOLVE_EDGES, a pixel whose 3x3
// neighbourhood spans two depths whose CoCs differ by more than a quarter pixel (an
// anti-aliased edge, see glsl/dof/coc_edges.comp) is also appended to the edge list, and
// coc_edges.comp, dispatched indirectly over that list, overwrites its CoC with the resolved
// one. lavapipe runs the body of every branch and leaves a loop only when no lane of the SIMD
// group is still in it: the resolve written here cost its colour reads and arithmetic for every
// lane of any group holding one edge pixel (11 ms of scene A's 15 ms); over the list, its groups
// are full of edge pixels.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
// The run's paths, specialised (src/passes/dof/coc.rs, CocPush::specialization): lavapipe runs both
// sides of every branch, so a pipeline without them skips the edge list's and the field
// curvature's work.
layout(constant_id = 0) const bool RESOLVE_EDGES = true;   // pc.resolve_edges != 0
layout(constant_id = 1) const bool FIELD_CURVATURE = true; // pc.entries > 0
layout(binding = 0, r32f) uniform readonly image2D depth_m;
layout(binding = 1, r32f) uniform writeonly image2D coc_px;
// Field curvature: [heights mm (entries), film-plane offset mm of the sharp image surface].
layout(binding = 2, std430) readonly buffer FieldCurvature { float table[]; };
// The edge resolve's dispatch and count (zeroed before this dispatch), and its pixels in any
// order (glsl/include/coc.glsl). Unused without RESOLVE_EDGES.
layout(binding = 3, std430) buffer Args { uint args[]; };
layout(binding = 4, std430) writeonly buffer EdgePixels { uint edge_pixels[]; };

#include "coc.glsl"

// Whether the edge resolve looks at pixel p: its 3x3 depths span two layers whose CoCs differ by
// more than a quarter pixel (EDGE_RESOLVE_MIN_PX in src/passes/dof/coc.rs: a highlight's fringe over
// a surface half a metre behind it differs by less than a pixel and still enlarged its disc).
// The nearest and farthest layers from the depths (a division is monotonic: the largest
// inverse is the inverse of the smallest depth), so a pixel divides once for them, not once per
// neighbour.
bool at_edge(ivec2 p, float d_p) {
    float d_min = d_p, d_max = d_p;
    for (int i = 0; i < 9; ++i) {
        float d = depth_mm(p + ivec2(i % 3 - 1, i / 3 - 1));
        d_min = min(d_min, d);
        d_max = max(d_max, d);
    }
    float w_near = 1.0 / d_min, w_far = 1.0 / d_max;
    return pc.coc_scale_px_mm * (w_near - w_far) > 0.25;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    float d_p = depth_mm(p);
    imageStore(coc_px, p, vec4(coc_of_inverse_depth(p, 1.0 / d_p), 0.0, 0.0, 0.0));
    if (RESOLVE_EDGES) {
        // The indirect dispatch's y and z (x counts up below from the zeroed buffer).
        if (p == ivec2(0)) {
            args[COC_ARGS_DISPATCH + 1] = 1u;
            args[COC_ARGS_DISPATCH + 2] = 1u;
        }
        if (at_edge(p, d_p)) {
            uint slot = atomicAdd(args[COC_ARGS_COUNT], 1u);
            edge_pixels[slot] = pack_pixel(p);
            if (slot % uint(EDGE_GROUP_SIZE) == 0u) atomicAdd(args[COC_ARGS_DISPATCH], 1u);
        }
    }
}
