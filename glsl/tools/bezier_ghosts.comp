#version 450
// Walch 2017's measured ghosts (ch. 6): every primitive of the list adds eq 6.4's light of its
// signed distance, found by the 12-step search (glsl/include/bezier_ghost.glsl), times its
// colour, to each pixel of its bounds. One invocation per pixel; src/tools/bezier_ghosts.rs.
#include "common.glsl"
#include "bezier_ghost.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, rgba32f) uniform writeonly image2D color_out;
layout(binding = 2, std430) readonly buffer BezierGhosts { float ghost_data[]; };

layout(push_constant) uniform Push { ivec2 size; uint count; } pc;

float word(uint b, uint k) { return ghost_data[b + k]; }

// The light of primitive b at pixel centre q.
float primitive_light(uint b, vec2 q) {
    // Eq 8.2's roll: the query point turned back by the roll about the pivot.
    vec2 pivot = vec2(word(b, BEZIER_ROLL + 2), word(b, BEZIER_ROLL + 3));
    float c = word(b, BEZIER_ROLL), s = word(b, BEZIER_ROLL + 1);
    vec2 o = q - pivot;
    vec2 local = pivot + vec2(c * o.x + s * o.y, -s * o.x + c * o.y);
    uint k = b + BEZIER_SHAPE;
    vec2 m = vec2(ghost_data[k], ghost_data[k + 1]) - local;
    float h = ghost_data[k + 2], l = ghost_data[k + 3], r = ghost_data[k + 4];
    float cl = ghost_data[k + 5], cr = ghost_data[k + 6];
    vec2 top = m + vec2(0.0, -h), bottom = m + vec2(0.0, h), left = m + vec2(-l, 0.0), right = m + vec2(r, 0.0);
    // The four sides of src/optics/bezier_ghost.rs (sides()), relative to q.
    vec2 best = bezier_side_distance(top, m + vec2(-cl * l, -h), m + vec2(-l, -cl * h), left);
    vec2 d = bezier_side_distance(left, m + vec2(-l, cl * h), m + vec2(-cl * l, h), bottom);
    if (d.x < best.x) best = d;
    d = bezier_side_distance(bottom, m + vec2(cr * r, h), m + vec2(r, cr * h), right);
    if (d.x < best.x) best = d;
    d = bezier_side_distance(right, m + vec2(r, -cr * h), m + vec2(cr * r, -h), top);
    if (d.x < best.x) best = d;
    uint t = b + BEZIER_TRANSFER;
    return bezier_transfer(best.x * best.y, ghost_data[t], ghost_data[t + 1], ghost_data[t + 2], ghost_data[t + 3],
                           ghost_data[t + 4], ghost_data[t + 5]);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec2 q = vec2(p) + 0.5;
    vec3 sum = vec3(0.0);
    for (uint i = 0; i < pc.count; ++i) {
        uint b = i * BEZIER_WORDS;
        vec4 box = vec4(word(b, 0), word(b, 1), word(b, 2), word(b, 3));
        if (!(q.x >= box.x && q.x <= box.z && q.y >= box.y && q.y <= box.w)) continue;
        float light = primitive_light(b, q);
        sum += light * vec3(word(b, BEZIER_COLOUR), word(b, BEZIER_COLOUR + 1), word(b, BEZIER_COLOUR + 2));
    }
    vec4 c = finite_or_zero(imageLoad(color_in, p));
    imageStore(color_out, p, vec4(c.rgb + sum, c.a));
}
