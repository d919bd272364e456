//! The shutter in time: when it is open relative to the rendered frame, how its opening weighs
//! the light over that time (box or trapezoid curve), and the focal-plane (rolling) shutter that
//! exposes the rows, or columns, one after the other (Kyaw 2013 sec 4.2, 5.2).
//!
//! Times are in frames, relative to the instant the renderer's passes describe (the frame
//! time, 0). A velocity pass gives the motion per frame: a point at pixel p at the frame time is
//! at p + t next for t >= 0 and at p + |t| prev for t < 0 (`next`, `prev`: its displacement to
//! the next and to the previous frame); the shutter decides which t the film sees.

/// Where the open shutter sits relative to the frame time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ShutterPosition {
    /// Open from -s/2 to +s/2 (Blender's `CENTER`, the usual film camera).
    #[default]
    Centred,
    /// Open from the frame time on: 0 to s.
    Start,
    /// Closes at the frame time: -s to 0.
    End,
}

/// How much light the shutter lets through over its open time.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum ShutterCurve {
    /// Fully open at once, for the whole time (Blender's default).
    #[default]
    Box,
    /// Opens linearly over the first `ramp` fraction of the open time and closes linearly over the
    /// last (0 < ramp <= 0.5): a mechanical shutter's blades in motion.
    Trapezoid { ramp: f64 },
}

/// Which way a rolling shutter's exposure sweeps the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum RollingDirection {
    /// Rows top to bottom (the usual CMOS readout).
    #[default]
    Down,
    Up,
    /// Columns left to right.
    Right,
    Left,
}

impl RollingDirection {
    pub fn name(self) -> &'static str {
        match self {
            RollingDirection::Down => "rows top to bottom",
            RollingDirection::Up => "rows bottom to top",
            RollingDirection::Right => "columns left to right",
            RollingDirection::Left => "columns right to left",
        }
    }
}

/// The open shutter of one frame, in frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShutterTiming {
    /// Opening and closing time (frames, relative to the frame time) of the reference line: the
    /// whole frame for a global shutter, the middle row (or column) for a rolling one.
    pub open_frames: f64,
    pub close_frames: f64,
    pub curve: ShutterCurve,
    /// Rolling shutter: the readout time from the first line to the last, in frames; 0: global.
    pub readout_frames: f64,
    pub direction: RollingDirection,
}

impl ShutterTiming {
    /// A shutter open `shutter_s` seconds at `fps` frames per second, at `position`.
    pub fn new(shutter_s: f64, fps: f64, position: ShutterPosition, curve: ShutterCurve) -> ShutterTiming {
        let s = shutter_s * fps;
        let (open_frames, close_frames) = match position {
            ShutterPosition::Centred => (-0.5 * s, 0.5 * s),
            ShutterPosition::Start => (0.0, s),
            ShutterPosition::End => (-s, 0.0),
        };
        ShutterTiming { open_frames, close_frames, curve, readout_frames: 0.0, direction: RollingDirection::Down }
    }

    /// With a rolling shutter reading out in `readout_s` seconds.
    pub fn with_rolling(self, readout_s: f64, fps: f64, direction: RollingDirection) -> ShutterTiming {
        ShutterTiming { readout_frames: readout_s * fps, direction, ..self }
    }

    /// The open time in frames (the shutter angle / 360).
    pub fn open_length_frames(&self) -> f64 {
        self.close_frames - self.open_frames
    }

    /// The ramp of the curve in frames (0 for a box).
    pub fn ramp_frames(&self) -> f64 {
        match self.curve {
            ShutterCurve::Box => 0.0,
            ShutterCurve::Trapezoid { ramp } => ramp.clamp(0.0, 0.5) * self.open_length_frames(),
        }
    }

    /// The time offset (frames) of the line through pixel centre `(x, y)` of a `width x height`
    /// frame, as `(a, b, c)` with offset = a x + b y + c: the middle line at 0, the first line
    /// -readout/2, the last +readout/2.
    pub fn rolling_plane(&self, width: u32, height: u32) -> (f64, f64, f64) {
        let r = self.readout_frames;
        let (w, h) = (width.max(1) as f64, height.max(1) as f64);
        match self.direction {
            RollingDirection::Down => (0.0, r / h, -0.5 * r),
            RollingDirection::Up => (0.0, -r / h, 0.5 * r),
            RollingDirection::Right => (r / w, 0.0, -0.5 * r),
            RollingDirection::Left => (-r / w, 0.0, 0.5 * r),
        }
    }

    /// The earliest opening and latest closing over the whole frame (frames).
    pub fn extent_frames(&self) -> (f64, f64) {
        let half = 0.5 * self.readout_frames.abs();
        (self.open_frames - half, self.close_frames + half)
    }

    /// The light let through from the opening until `t` frames (opening at `open`), relative to
    /// the fully open shutter: the integral of the curve; [`Self::total_weight`] at closing.
    pub fn cumulative(&self, t: f64, open: f64) -> f64 {
        cumulative(t - open, self.open_length_frames(), self.ramp_frames())
    }

    /// The integral of the curve over the whole open time (frames at full opening).
    pub fn total_weight(&self) -> f64 {
        self.open_length_frames() - self.ramp_frames()
    }
}

/// The trapezoid's integral from 0 to `x` over an open time `length` with ramps of `ramp`
/// (both ends; 0 for a box). The GPU's twin is glsl/include/motion.glsl `shutter_cdf`.
pub fn cumulative(x: f64, length: f64, ramp: f64) -> f64 {
    let x = x.clamp(0.0, length.max(0.0));
    if ramp <= 0.0 {
        return x;
    }
    let rise = x.min(ramp);
    let mut c = rise * rise / (2.0 * ramp);
    if x > ramp {
        c += x.min(length - ramp) - ramp;
    }
    if x > length - ramp {
        let d = x - (length - ramp);
        c += d - d * d / (2.0 * ramp);
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_180_degree_shutter_at_24_fps_is_half_a_frame_centred() {
        let t = ShutterTiming::new(1.0 / 48.0, 24.0, ShutterPosition::Centred, ShutterCurve::Box);
        assert!((t.open_frames + 0.25).abs() < 1e-12 && (t.close_frames - 0.25).abs() < 1e-12);
        let start = ShutterTiming::new(1.0 / 48.0, 24.0, ShutterPosition::Start, ShutterCurve::Box);
        assert_eq!((start.open_frames, start.close_frames), (0.0, 0.5));
        let end = ShutterTiming::new(1.0 / 48.0, 24.0, ShutterPosition::End, ShutterCurve::Box);
        assert_eq!((end.open_frames, end.close_frames), (-0.5, 0.0));
    }

    #[test]
    fn the_trapezoid_lets_through_its_area_and_is_symmetric() {
        // Ramps of a quarter each: area = length - ramp = 1 - 0.25; half of it by the middle.
        let (length, ramp) = (1.0, 0.25);
        assert!((cumulative(1.0, length, ramp) - 0.75).abs() < 1e-12);
        assert!((cumulative(0.5, length, ramp) - 0.375).abs() < 1e-12);
        // Over the first ramp the curve rises linearly: integral x^2 / (2 ramp).
        assert!((cumulative(0.1, length, ramp) - 0.01 / 0.5).abs() < 1e-12);
        // Box: the time itself.
        assert_eq!(cumulative(0.3, 1.0, 0.0), 0.3);
        assert_eq!(cumulative(2.0, 1.0, 0.0), 1.0);
    }

    #[test]
    fn a_rolling_shutter_offsets_the_lines_by_the_readout() {
        // 10 ms readout at 25 fps = 0.25 frames; rows top to bottom: the first row centre
        // (y = 0.5 of 100) at -0.125 + 0.25 * 0.005, the last at +0.125 - 0.00125.
        let t = ShutterTiming::new(0.01, 25.0, ShutterPosition::Centred, ShutterCurve::Box).with_rolling(
            0.01,
            25.0,
            RollingDirection::Down,
        );
        let (a, b, c) = t.rolling_plane(200, 100);
        assert_eq!(a, 0.0);
        let first = b * 0.5 + c;
        let last = b * 99.5 + c;
        assert!((first + 0.125 - 0.00125).abs() < 1e-12 && (last - 0.125 + 0.00125).abs() < 1e-12);
        assert!((last - first - 0.25 * 99.0 / 100.0).abs() < 1e-12);
        assert_eq!(t.extent_frames(), (-0.125 - 0.125, 0.125 + 0.125));
    }
}
