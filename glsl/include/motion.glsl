// Motion blur: the shutter in time and the path of a point over it (src/optics/shutter.rs,
// src/passes/motion/path.rs is the CPU twin of every function here).
//
// Times are in frames relative to the frame time the passes describe. A point seen at texel Y
// at the frame time moves with `next` (px per frame toward the next frame) for t >= 0 and
// `prev` (px per frame toward the previous frame) for t < 0: it is at Y + t next, or at
// Y + |t| prev. Where both vectors are known the path is two segments, which bends for curved
// motion (a spinning wheel); with one vector prev = -next (constant velocity).
#ifndef REALCAM_MOTION_GLSL
#define REALCAM_MOTION_GLSL

// The edge resolve's args buffer (glsl/motion/mb_edge_list.comp lists the candidate pixels,
// glsl/motion/mb_edges.comp resolves them): its indirect dispatch (x, y, z: MB_EDGE_GROUP_SIZE
// listed pixels per workgroup), the count of listed pixels, the count of pixels it changed. The
// integer defines are Rust constants too (realcam::gpu::shaders::motion, made by build.rs).
#define MB_EDGE_ARGS_DISPATCH 0
#define MB_EDGE_ARGS_COUNT 3
#define MB_EDGE_ARGS_CHANGED 4
#define MB_EDGE_ARGS_WORDS 5
// Invocations per workgroup of the resolve (glsl/motion/mb_edges.comp).
#define MB_EDGE_GROUP_SIZE 64

// The gather's tile lists (glsl/motion/mb_neighbor.comp makes them): the indirect dispatches
// (x, y, z: one workgroup per listed tile) of the tiles something near moves in (mb_gather) and
// of the still tiles (mb_still, a copy), then the tiles themselves (column | row << 16): the
// moving ones from word 0 of the list buffer, the still ones from word `tiles` (the frame's tile
// count).
#define MB_TILE_ARGS_MOVING 0
#define MB_TILE_ARGS_STILL 3
#define MB_TILE_ARGS_WORDS 6

// A pixel of the edge list: x | y << 16 (as the depth of field's, glsl/include/coc.glsl).
uint mb_pack_pixel(ivec2 p) { return uint(p.x) | (uint(p.y) << 16); }
ivec2 mb_unpack_pixel(uint v) { return ivec2(int(v & 0xffffu), int(v >> 16)); }

// The open shutter of the reference line (the whole frame for a global shutter), its trapezoid
// ramp, and the rolling shutter's time offset of the line through a pixel centre q:
// roll_x q.x + roll_y q.y + roll_c (frames).
struct Shutter {
    float open_frames;
    float close_frames;
    float ramp_frames;
    float roll_x;
    float roll_y;
    float roll_c;
    int band_top_px;   // the images are the band of the frame from this row (0: the frame)
};

// The open time of the pixel whose centre is q (in the band's pixels; its row in the frame's).
vec2 shutter_window(Shutter s, vec2 q) {
    float offset = s.roll_x * q.x + s.roll_y * (q.y + float(s.band_top_px)) + s.roll_c;
    return vec2(s.open_frames + offset, s.close_frames + offset);
}

// The light let through from the opening until x frames after it, over an open time `len`
// with linear ramps of `ramp` at both ends (0: a box): the integral of the shutter curve.
float shutter_cdf(float x, float len, float ramp) {
    x = clamp(x, 0.0, max(len, 0.0));
    if (ramp <= 0.0) return x;
    float rise = min(x, ramp);
    float c = rise * rise / (2.0 * ramp);
    if (x > ramp) c += min(x, len - ramp) - ramp;
    if (x > len - ramp) {
        float d = x - (len - ramp);
        c += d - d * d / (2.0 * ramp);
    }
    return c;
}

// The light of the whole open time.
float shutter_total(Shutter s) {
    return (s.close_frames - s.open_frames) - s.ramp_frames;
}

// A velocity no faster than max_speed px per frame.
vec2 clamp_speed(vec2 v, float max_speed) {
    float l = length(v);
    return l > max_speed ? v * (max_speed / l) : v;
}

// The pixel of a tile list's tile (its column and row packed as a pixel of the edge list: an
// integer division per invocation cost lavapipe more than the copy of a still tile) at this
// invocation of a workgroup of TILE_SIZE x TILE_SIZE.
ivec2 listed_tile_pixel(uint packed_tile, uvec2 local) {
    return mb_unpack_pixel(packed_tile) * TILE_SIZE + ivec2(local);
}

// The shutter light (cdf units) during which a point moving along `v` from t = 0 (at `v` px
// per frame of `dir_time` = t, or of |t| going back) lies over the pixel at offset o from its
// texel: 1 px along the path, and within 0.75 px (fading out at 1 px) across it. `u0`, `u1`:
// the |t| range of this half of the path within the pixel's open time; `win`: that open time;
// `backward`: the half before the frame time (t = -u).
float half_coverage(vec2 o, vec2 v, float u0, float u1, vec2 win, float ramp, bool backward) {
    if (u1 <= u0) return 0.0;
    float len = win.y - win.x;
    precise float speed = length(v);
    float a, b;
    if (speed < 1.0e-6) {
        if (dot(o, o) > 0.25) return 0.0;
        a = u0;
        b = u1;
    } else {
        vec2 n = v / speed;
        precise float s = dot(o, n);
        vec2 across = o - s * n;
        float across_weight = clamp((1.0 - length(across)) * 4.0, 0.0, 1.0);
        if (across_weight <= 0.0) return 0.0;
        a = max((s - 0.5) / speed, u0);
        b = min((s + 0.5) / speed, u1);
        if (b <= a) return 0.0;
        float light = backward ? shutter_cdf(-a - win.x, len, ramp) - shutter_cdf(-b - win.x, len, ramp)
                               : shutter_cdf(b - win.x, len, ramp) - shutter_cdf(a - win.x, len, ramp);
        return across_weight * light;
    }
    return backward ? shutter_cdf(-a - win.x, len, ramp) - shutter_cdf(-b - win.x, len, ramp)
                    : shutter_cdf(b - win.x, len, ramp) - shutter_cdf(a - win.x, len, ramp);
}

// Both halves: the shutter light during which the point from texel Y lies over the pixel at
// offset o = X - Y, within X's open time win.
float path_coverage(vec2 o, vec2 next, vec2 prev, vec2 win, float ramp) {
    float forward = half_coverage(o, next, max(win.x, 0.0), win.y, win, ramp, false);
    float backward = half_coverage(o, prev, max(-win.y, 0.0), -win.x, win, ramp, true);
    return forward + backward;
}

// Soft depth classes of a sample at depth z_y against the centre's z_x: (nearer, same surface,
// farther), summing to 1; a sample 7% nearer (farther) is fully in front (behind).
vec3 depth_classes(float z_x, float z_y) {
    float q = log2(clamp(z_y, 1.0e-6, 1.0e30) / clamp(z_x, 1.0e-6, 1.0e30)) * 10.0;
    float nearer = clamp(-q, 0.0, 1.0);
    float farther = clamp(q, 0.0, 1.0);
    return vec3(nearer, 1.0 - nearer - farther, farther);
}

// A fixed per-pixel jitter in [0, 1) (an integer hash, the same on the CPU).
uint motion_hash(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

float motion_jitter(ivec2 p, int k) {
    uint h = motion_hash(uint(p.x) * 1973u + uint(p.y) * 9277u + uint(k) * 26699u);
    return float(h >> 8) * (1.0 / 16777216.0);
}

#endif
