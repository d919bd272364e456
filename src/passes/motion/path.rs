//! The CPU twin of glsl/include/motion.glsl: the shutter in time, a point's path over it, the
//! depth classes and the jitter, in the shaders' f32 arithmetic. Used by the twins of every
//! motion-blur shader and by the planner (the push constants' [`ShutterPush`]).

use crate::optics::shutter::ShutterTiming;

/// `struct Shutter` of glsl/include/motion.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShutterPush {
    pub open_frames: f32,
    pub close_frames: f32,
    pub ramp_frames: f32,
    pub roll_x: f32,
    pub roll_y: f32,
    pub roll_c: f32,
    /// The images are the band of the frame from this row (banded rendering; 0 for the whole
    /// frame): a pixel's line, its jitter and its sample positions are its row's in the frame.
    pub band_top_px: i32,
}

impl ShutterPush {
    /// The shutter of `timing` on a `width x height` frame.
    pub fn new(timing: &ShutterTiming, width: u32, height: u32) -> ShutterPush {
        ShutterPush::for_band(timing, width, height, 0)
    }

    /// The shutter of a band whose first row is row `top_px` of a `width x height` frame: a
    /// pixel's open time is its row's in the whole frame.
    pub fn for_band(timing: &ShutterTiming, width: u32, height: u32, top_px: u32) -> ShutterPush {
        let (a, b, c) = timing.rolling_plane(width, height);
        ShutterPush {
            open_frames: timing.open_frames as f32,
            close_frames: timing.close_frames as f32,
            ramp_frames: timing.ramp_frames() as f32,
            roll_x: a as f32,
            roll_y: b as f32,
            roll_c: c as f32,
            band_top_px: top_px as i32,
        }
    }

    /// A global box shutter open from `open_frames` to `close_frames` on every line: the
    /// extent of a rolling one, as a test that must hold for every line's open time reads it.
    pub fn spanning(open_frames: f32, close_frames: f32) -> ShutterPush {
        ShutterPush {
            open_frames,
            close_frames,
            ramp_frames: 0.0,
            roll_x: 0.0,
            roll_y: 0.0,
            roll_c: 0.0,
            band_top_px: 0,
        }
    }

    /// The open time of the pixel whose centre is `q` (in the band's pixels; its row in the
    /// frame's).
    pub fn window(&self, q: [f32; 2]) -> [f32; 2] {
        let offset = self.roll_x * q[0] + self.roll_y * (q[1] + self.band_top_px as f32) + self.roll_c;
        [self.open_frames + offset, self.close_frames + offset]
    }

    /// The light of the whole open time.
    pub fn total(&self) -> f32 {
        (self.close_frames - self.open_frames) - self.ramp_frames
    }
}

/// `shutter_cdf` (the f64 curve of src/optics/shutter.rs, within f32 rounding of the shader's).
pub fn shutter_cdf(x: f32, len: f32, ramp: f32) -> f32 {
    crate::optics::shutter::cumulative(x as f64, len as f64, ramp as f64) as f32
}

fn length(v: [f32; 2]) -> f32 {
    (v[0] * v[0] + v[1] * v[1]).sqrt()
}

/// `clamp_speed`.
pub fn clamp_speed(v: [f32; 2], max_speed: f32) -> [f32; 2] {
    let l = length(v);
    if l > max_speed {
        let s = max_speed / l;
        [v[0] * s, v[1] * s]
    } else {
        v
    }
}

/// A texel's (next, previous) velocity, each clamped.
pub fn clamped_velocity(v: &[f32], max_speed: f32) -> [f32; 4] {
    let n = clamp_speed([v[0], v[1]], max_speed);
    let p = clamp_speed([v[2], v[3]], max_speed);
    [n[0], n[1], p[0], p[1]]
}

/// `half_coverage`.
#[allow(clippy::too_many_arguments)]
pub fn half_coverage(o: [f32; 2], v: [f32; 2], u0: f32, u1: f32, win: [f32; 2], ramp: f32, backward: bool) -> f32 {
    if u1 <= u0 {
        return 0.0;
    }
    let len = win[1] - win[0];
    let speed = length(v);
    let light = |a: f32, b: f32| {
        if backward {
            shutter_cdf(-a - win[0], len, ramp) - shutter_cdf(-b - win[0], len, ramp)
        } else {
            shutter_cdf(b - win[0], len, ramp) - shutter_cdf(a - win[0], len, ramp)
        }
    };
    if speed < 1.0e-6 {
        if o[0] * o[0] + o[1] * o[1] > 0.25 {
            return 0.0;
        }
        return light(u0, u1);
    }
    let n = [v[0] / speed, v[1] / speed];
    let s = o[0] * n[0] + o[1] * n[1];
    let across = [o[0] - s * n[0], o[1] - s * n[1]];
    let across_weight = ((1.0 - length(across)) * 4.0).clamp(0.0, 1.0);
    if across_weight <= 0.0 {
        return 0.0;
    }
    let a = ((s - 0.5) / speed).max(u0);
    let b = ((s + 0.5) / speed).min(u1);
    if b <= a {
        return 0.0;
    }
    across_weight * light(a, b)
}

/// `path_coverage`: the shutter light during which the point from texel Y (velocities `next`,
/// `prev`) lies over the pixel at offset o = X - Y, within X's open time `win`.
pub fn path_coverage(o: [f32; 2], next: [f32; 2], prev: [f32; 2], win: [f32; 2], ramp: f32) -> f32 {
    let forward = half_coverage(o, next, win[0].max(0.0), win[1], win, ramp, false);
    let backward = half_coverage(o, prev, (-win[1]).max(0.0), -win[0], win, ramp, true);
    forward + backward
}

/// `depth_classes`: (nearer, same surface, farther).
pub fn depth_classes(z_x: f32, z_y: f32) -> [f32; 3] {
    let q = (z_y.clamp(1.0e-6, 1.0e30) / z_x.clamp(1.0e-6, 1.0e30)).log2() * 10.0;
    let nearer = (-q).clamp(0.0, 1.0);
    let farther = q.clamp(0.0, 1.0);
    [nearer, 1.0 - nearer - farther, farther]
}

/// `motion_hash`.
pub fn motion_hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// `motion_jitter`.
pub fn motion_jitter(p: [i32; 2], k: i32) -> f32 {
    let h = motion_hash(
        (p[0] as u32)
            .wrapping_mul(1973)
            .wrapping_add((p[1] as u32).wrapping_mul(9277))
            .wrapping_add((k as u32).wrapping_mul(26699)),
    );
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_moving_point_spends_one_pixel_over_speed_of_the_shutter_on_each_pixel() {
        // 10 px per frame, shutter 0.5 frame centred: a 5 px streak from -2.5 to +2.5 px. The
        // pixel 1 px ahead (0.5..1.5 px) holds the point for 1/10 frame: a fifth of the shutter.
        let win = [-0.25, 0.25];
        let (next, prev) = ([10.0, 0.0], [-10.0, 0.0]);
        let share = |x: f32| path_coverage([x, 0.0], next, prev, win, 0.0) / 0.5;
        assert!((share(1.0) - 0.2).abs() < 1e-6 && (share(-1.0) - 0.2).abs() < 1e-6);
        assert!((share(0.0) - 0.2).abs() < 1e-6);
        // The pixel at 2 covers 1.5..2.5: fully lit; at 3, 2.5..3.5: not at all.
        assert!((share(2.0) - 0.2).abs() < 1e-6 && share(3.0) == 0.0);
        let sum: f32 = (-4..=4).map(|x| share(x as f32)).sum();
        assert!((sum - 1.0).abs() < 1e-6, "the streak holds all the light: {sum}");
        // Across the path: nothing one pixel to the side near the texel.
        assert_eq!(path_coverage([0.0, 1.0], next, prev, win, 0.0), 0.0);
        // A static point lights only its own pixel, for the whole shutter.
        assert_eq!(path_coverage([0.0, 0.0], [0.0; 2], [0.0; 2], win, 0.0), 0.5);
        assert_eq!(path_coverage([1.0, 0.0], [0.0; 2], [0.0; 2], win, 0.0), 0.0);
    }

    #[test]
    fn the_two_halves_follow_their_own_vectors() {
        // Next frame to the right, previous frame above: the path bends at the texel.
        let win = [-0.5, 0.5];
        let (next, prev) = ([8.0, 0.0], [0.0, -8.0]);
        assert!(path_coverage([2.0, 0.0], next, prev, win, 0.0) > 0.0);
        assert!(path_coverage([0.0, -2.0], next, prev, win, 0.0) > 0.0);
        assert_eq!(path_coverage([-2.0, 0.0], next, prev, win, 0.0), 0.0);
        assert_eq!(path_coverage([0.0, 2.0], next, prev, win, 0.0), 0.0);
    }
}
