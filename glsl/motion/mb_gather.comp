#version 450
#extension GL_EXT_control_flow_attributes : require
// Motion blur, step 3: the reconstruction gather (after McGuire et al. 2012 and Guertin,
// McGuire & Nowrouzezahrai 2014), written as the scatter it stands for: a texel Y spreads its
// light along its own path over the shutter, and pixel X receives the share of the shutter's
// light during which Y's path lies over X (path_coverage). X gathers the texels whose paths can
// reach it on four lines: back along the neighbourhood's longest next and previous velocity (a
// fast neighbour blurring over X) and back along X's own (X's own surface, when it moves
// otherwise); each line has a fixed number of jittered, stratified samples, so the cost does not
// grow with the speed. Samples are layered by depth as the light is:
//   F: nearer surfaces whose paths cross X, over everything (coverage aF <= 1);
//   S: X's own surface (the centre texel and samples at its depth), visible where F is not;
//   B: where neither covers X, what lies behind X's moving surface: farther samples whose paths
//      cross X, else the farther texels near X, the nearest weighing most (the pinhole image
//      hides the rest: issue 30 item 2).
// Result = F + (1 - aF) (S + (1 - aS) B). A static background stays sharp behind a moving
// object (its own S is the texel, aS = 1), and a moving object's silhouette spreads over it
// (F). One workgroup per tile of mb_neighbor's list of tiles something near moves in (the
// others are copied by mb_still); a pixel whose own open time lets nothing reach it copies too.
#include "common.glsl"
#include "motion.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;
layout(binding = 0, rgba32f) uniform readonly image2D color_in;
layout(binding = 1, r32f) uniform readonly image2D depth_m;
layout(binding = 2, rgba32f) uniform readonly image2D velocity;
layout(binding = 3, rgba32f) uniform writeonly image2D color_out;
layout(binding = 4, std430) readonly buffer NeighborMotion { vec4 neighbor_motion[]; };
layout(binding = 5, std430) readonly buffer TileMotion { vec4 tile_motion[]; };
layout(binding = 6, std430) readonly buffer TileList { uint tile_list[]; };

layout(push_constant) uniform Push {
    ivec2 size;
    ivec2 tiles;
    Shutter shutter;
    float max_speed_px;
    int samples_per_line;
} pc;

struct Layers {
    vec4 fg; float fg_a;          // nearer surfaces crossing X
    vec4 own; float own_a;        // X's own surface
    vec4 behind; float behind_a;  // farther surfaces crossing X
    vec4 guess; float guess_n;    // farther texels near X: the hidden background
};

vec4 texel_velocity(ivec2 q) {
    vec4 v = imageLoad(velocity, q);
    return vec4(clamp_speed(v.xy, pc.max_speed_px), clamp_speed(v.zw, pc.max_speed_px));
}

// One line of samples at X + r dir, r in (0.5, reach]; `other_reach`: the reach of the other
// line on the same side when both lines run together (`same` in [0, 1]), where each counts half.
void sample_line(inout Layers l, ivec2 p, float z_x, vec2 win, vec2 dir, float reach, float same,
                 float other_reach, bool own_line, int k) {
    int n = pc.samples_per_line;
    if (reach <= 0.5 || n <= 0) return;
    float spacing = (reach - 0.5) / float(n);
    // In the whole frame's rows (a band's from its first row): the same jitter and the same
    // rounding of the sample positions as the whole frame's render.
    ivec2 band = ivec2(0, pc.shutter.band_top_px);
    float jitter = motion_jitter(p + band, k);
    float total = shutter_total(pc.shutter);
    for (int i = 0; i < n; ++i) {
        precise float r = 0.5 + (float(i) + jitter) * spacing;
        precise vec2 at = vec2(p + band) + 0.5 + r * dir;
        ivec2 y = clamp(ivec2(floor(at)) - band, ivec2(0), pc.size - 1);
        vec2 o = vec2(p - y);
        vec4 v = texel_velocity(y);
        float light = path_coverage(o, v.xy, v.zw, win, pc.shutter.ramp_frames) / total;
        // Lines that run together each estimate the same sources: half weight where they overlap.
        float share = own_line ? 1.0 - 0.5 * same : 1.0 - 0.5 * same * clamp(other_reach + 0.5 - r, 0.0, 1.0);
        float w = light * spacing * share;
        vec4 c = finite_or_zero(imageLoad(color_in, y));
        vec3 cls = depth_classes(z_x, imageLoad(depth_m, y).r);
        l.fg += cls.x * w * c;
        l.fg_a += cls.x * w;
        l.own += cls.y * w * c;
        l.own_a += cls.y * w;
        l.behind += cls.z * w * c;
        l.behind_a += cls.z * w;
        // The hidden background's estimate: farther texels weighted by their nearness to X, a
        // linear fall-off over the line's reach (McGuire et al. 2012 sec 3, the background case of
        // the per-sample weight, b cone(X, Y, v(X)): the farther texel that the pixel's own blur
        // reaches first is the likeliest to be what the pixel's own surface hid at the frame time).
        float near = 1.0 - r / (reach + 0.5);
        l.guess += cls.z * share * near * c;
        l.guess_n += cls.z * share * near;
    }
}

// 1 when a and b point the same way (within ~10 degrees), 0 below ~25 degrees.
float same_direction(vec2 a, vec2 b) {
    return clamp((dot(a, b) - 0.9) / 0.08, 0.0, 1.0);
}

vec2 unit(vec2 v) {
    float l = length(v);
    return l > 0.0 ? v / l : vec2(0.0);
}

void main() {
    ivec2 p = listed_tile_pixel(tile_list[gl_WorkGroupID.x], gl_LocalInvocationID.xy);
    if (outside(p, pc.size)) return;
    vec4 c = finite_or_zero(imageLoad(color_in, p));
    ivec2 tile = p / TILE_SIZE;
    vec4 nm = neighbor_motion[tile.y * pc.tiles.x + tile.x];
    vec2 win = shutter_window(pc.shutter, vec2(p) + 0.5);
    float t_fwd = max(win.y, 0.0);
    float t_back = max(-win.x, 0.0);
    float reach_next_n = t_fwd * length(nm.xy);
    float reach_prev_n = t_back * length(nm.zw);
    if (max(reach_next_n, reach_prev_n) < 0.5) {
        // Nothing in reach moves half a pixel while the shutter is open: a copy.
        imageStore(color_out, p, c);
        return;
    }
    float z_x = imageLoad(depth_m, p).r;
    vec4 v = texel_velocity(p);
    float reach_next_x = t_fwd * length(v.xy);
    float reach_prev_x = t_back * length(v.zw);
    float total = shutter_total(pc.shutter);
    // A still pixel has no line of its own: it samples along its own tile's longest velocities
    // instead where they point another way than the neighbourhood's (by more than ~25 degrees).
    // The neighbourhood's longest can belong to a faster object a tile or two away moving
    // another way, and a slower mover over this still pixel (a fence sliding across the sky
    // beside a fast ball) then spread none of its light over it: its paths cross X along
    // neither line. Where the two point the same way the tile's line adds nothing but a second
    // estimate of the same sources, whose overlap weights (`same`) are made for a line inside
    // the other: it gathered 1.3% too much light around a moving highlight.
    vec4 tm = tile_motion[tile.y * pc.tiles.x + tile.x];
    vec2 line_next = v.xy, line_prev = v.zw;
    if (reach_next_x <= 0.5 && same_direction(unit(nm.xy), unit(tm.xy)) <= 0.0) {
        line_next = tm.xy;
        reach_next_x = t_fwd * length(tm.xy);
    }
    if (reach_prev_x <= 0.5 && same_direction(unit(nm.zw), unit(tm.zw)) <= 0.0) {
        line_prev = tm.zw;
        reach_prev_x = t_back * length(tm.zw);
    }

    Layers l;
    l.fg = vec4(0.0); l.fg_a = 0.0;
    l.behind = vec4(0.0); l.behind_a = 0.0;
    l.guess = vec4(0.0); l.guess_n = 0.0;
    // The centre texel: the light of X's own surface while it is over X.
    l.own_a = path_coverage(vec2(0.0), v.xy, v.zw, win, pc.shutter.ramp_frames) / total;
    l.own = l.own_a * c;

    vec2 next_n = unit(nm.xy), prev_n = unit(nm.zw);
    vec2 next_x = reach_next_x > 0.5 ? unit(line_next) : vec2(0.0);
    vec2 prev_x = reach_prev_x > 0.5 ? unit(line_prev) : vec2(0.0);
    float same_next = same_direction(next_n, next_x);
    float same_prev = same_direction(prev_n, prev_x);
    // Sources whose forward half ends on X lie back along their next velocity; those whose
    // backward half ends on X, back along their previous velocity.
    // The four lines in a loop rather than four inlined calls: the same samples, and a quarter
    // of the code for the driver to compile (lavapipe took 60-75 ms to create the pipeline).
    vec2 dirs[4] = vec2[4](-next_n, -next_x, -prev_n, -prev_x);
    float reaches[4] = float[4](reach_next_n, reach_next_x, reach_prev_n, reach_prev_x);
    [[dont_unroll]] for (int k = 0; k < 4; ++k) {
        int other = k ^ 1;
        float same = k < 2 ? same_next : same_prev;
        sample_line(l, p, z_x, win, dirs[k], reaches[k] + 0.5, same, reaches[other] + 0.5, (k & 1) == 1, k);
    }

    float fg_a = min(l.fg_a, 1.0);
    vec4 fg = l.fg_a > 0.0 ? l.fg * (fg_a / l.fg_a) : vec4(0.0);
    float own_a = min(l.own_a, 1.0);
    vec4 own = l.own_a > 0.0 ? l.own * (own_a / l.own_a) : vec4(0.0);
    vec4 behind;
    if (l.behind_a > 0.05) {
        behind = l.behind / l.behind_a;
    } else if (l.guess_n > 0.0) {
        behind = l.guess / l.guess_n;
    } else if (l.own_a > 0.0) {
        behind = l.own / l.own_a;
    } else {
        behind = c;
    }
    vec4 result = fg + (1.0 - fg_a) * (own + (1.0 - own_a) * behind);
    imageStore(color_out, p, finite_or_zero(result));
}
