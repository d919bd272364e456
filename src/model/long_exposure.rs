//! A long exposure built from frames (Kyaw 2013 sec. 7.4): each frame is exposed as a frame of
//! its own and accumulated with the blend factor a = 1/n (n: frames so far) against 1 - a for
//! what was accumulated, so that the exposure's illumination is the average of the frames', not
//! their sum. The sum is kept in f64 and divided once at the end, which is that running blend
//! without its rounding drift: 10,000 frames of a constant image stay constant to 1e-6.

use crate::io::Image;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum LongExposureError {
    #[error("frame {frame} is {width}x{height} px with {channels} channel(s), but the exposure's first frame was {expected_width}x{expected_height} px with {expected_channels}")]
    SizeMismatch {
        frame: i64,
        width: u32,
        height: u32,
        channels: u32,
        expected_width: u32,
        expected_height: u32,
        expected_channels: u32,
    },
    #[error("the long exposure has no frame")]
    NoFrames,
    /// A state file that is not one [`LongExposure::to_bytes`] wrote.
    #[error("not a long-exposure state of realcam: {reason}")]
    State { reason: String },
}

/// The first line of a state file (version 2 adds the settings line; a version 1 state, which
/// has none, is read as made with any settings).
const STATE_MAGIC: &str = "realcam-long-exposure 2";
const STATE_MAGIC_V1: &str = "realcam-long-exposure 1";

/// Frames accumulated into one exposure; see the module docs.
#[derive(Clone, Debug, Default)]
pub struct LongExposure {
    /// Width, height and channels of the first frame; None before it.
    shape: Option<(u32, u32, u32)>,
    /// The frame numbers accumulated, in order.
    done: Vec<i64>,
    /// Per value, the sum over the frames so far.
    sum: Vec<f64>,
    /// The settings the frames were rendered with, on one line (the caller's description, such
    /// as the camera's): a resumed exposure must use the same.
    settings: String,
}

impl LongExposure {
    /// An empty exposure whose frames are rendered with `settings` (one line).
    pub fn new(settings: &str) -> LongExposure {
        LongExposure { settings: settings.replace('\n', " "), ..LongExposure::default() }
    }

    /// The settings given to [`LongExposure::new`] (empty for a version 1 state).
    pub fn settings(&self) -> &str {
        &self.settings
    }

    /// Adds `image`, frame number `frame` of the sequence (for the error of a frame whose size
    /// differs from the first's).
    pub fn add(&mut self, frame: i64, image: &Image) -> Result<(), LongExposureError> {
        let shape = (image.width, image.height, image.channels);
        match self.shape {
            None => {
                self.shape = Some(shape);
                self.sum = vec![0.0; image.data.len()];
            }
            Some(expected) if expected != shape => {
                return Err(LongExposureError::SizeMismatch {
                    frame,
                    width: shape.0,
                    height: shape.1,
                    channels: shape.2,
                    expected_width: expected.0,
                    expected_height: expected.1,
                    expected_channels: expected.2,
                });
            }
            Some(_) => {}
        }
        for (sum, &value) in self.sum.iter_mut().zip(&image.data) {
            *sum += f64::from(value);
        }
        self.done.push(frame);
        Ok(())
    }

    /// The frames accumulated so far.
    pub fn frames(&self) -> u64 {
        self.done.len() as u64
    }

    /// Whether frame `frame` was accumulated.
    pub fn has(&self, frame: i64) -> bool {
        self.done.contains(&frame)
    }

    /// The frame numbers accumulated, in order.
    pub fn done(&self) -> &[i64] {
        &self.done
    }

    /// The state, to stop and resume: a text header (the first line [`STATE_MAGIC`], then the
    /// settings, then `WIDTH HEIGHT CHANNELS`, then the frames done, comma-separated) and the
    /// sums as little-endian f64.
    pub fn to_bytes(&self) -> Vec<u8> {
        let (w, h, c) = self.shape.unwrap_or((0, 0, 0));
        let frames: Vec<String> = self.done.iter().map(i64::to_string).collect();
        let settings = &self.settings;
        let mut bytes = format!("{STATE_MAGIC}\n{settings}\n{w} {h} {c}\n{}\n", frames.join(",")).into_bytes();
        bytes.reserve(self.sum.len() * 8);
        for s in &self.sum {
            bytes.extend_from_slice(&s.to_le_bytes());
        }
        bytes
    }

    /// The state [`LongExposure::to_bytes`] wrote.
    pub fn from_bytes(bytes: &[u8]) -> Result<LongExposure, LongExposureError> {
        let refuse = |reason: String| LongExposureError::State { reason };
        let version = if bytes.starts_with(STATE_MAGIC_V1.as_bytes()) { 1 } else { 2 };
        let mut lines = bytes.splitn(3 + version, |&b| b == b'\n');
        let mut line = |what: &str| {
            lines
                .next()
                .and_then(|l| std::str::from_utf8(l).ok())
                .map(str::to_string)
                .ok_or_else(|| refuse(format!("the {what} line is missing")))
        };
        if ![STATE_MAGIC, STATE_MAGIC_V1].contains(&line("first")?.as_str()) {
            return Err(refuse(format!("the first line is not \"{STATE_MAGIC}\"")));
        }
        let settings = if version == 1 { String::new() } else { line("settings")? };
        let size_line = line("size")?;
        let size: Vec<u32> = size_line.split(' ').filter_map(|v| v.parse().ok()).collect();
        let [w, h, c] = size[..] else {
            return Err(refuse(format!("the size line \"{size_line}\" is not WIDTH HEIGHT CHANNELS")));
        };
        let frames_line = line("frames")?;
        let done = if frames_line.is_empty() {
            Vec::new()
        } else {
            frames_line
                .split(',')
                .map(|f| f.parse::<i64>().map_err(|_| refuse(format!("the frame \"{f}\" is not a frame number"))))
                .collect::<Result<Vec<i64>, _>>()?
        };
        // In a sorted copy: a state of a million frames is read in a moment, not in hours.
        let mut sorted = done.clone();
        sorted.sort_unstable();
        if let Some(twice) = sorted.windows(2).find(|pair| pair[0] == pair[1]).map(|pair| pair[0]) {
            return Err(refuse(format!("the frames line lists frame {twice} more than once")));
        }
        let values = [w, h, c].iter().try_fold(1usize, |n, &v| n.checked_mul(v as usize));
        let Some(values) = values.filter(|v| v.checked_mul(8).is_some()) else {
            return Err(refuse(format!("the size line \"{size_line}\" holds more values than memory can")));
        };
        if !done.is_empty() && values == 0 {
            return Err(refuse(format!(
                "the size line \"{size_line}\" is an empty image, but the frames line lists {} frame(s)",
                done.len()
            )));
        }
        let data = lines.next().unwrap_or_default();
        if data.len() != values * 8 {
            return Err(refuse(format!(
                "{} bytes of sums, expected {} ({w}x{h} px, {c} channel(s), 8 bytes each)",
                data.len(),
                values * 8
            )));
        }
        let sum: Vec<f64> = data.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().unwrap_or([0; 8]))).collect();
        // The exposure is the sums over the frames as f32: each must stay finite there.
        let limit = f64::from(f32::MAX) * done.len().max(1) as f64;
        if let Some((i, v)) = sum.iter().enumerate().find(|(_, v)| v.is_nan() || v.abs() > limit) {
            let (pixel, channel) = (i / c as usize, i % c as usize);
            return Err(refuse(format!(
                "the sum of pixel ({}, {}) channel {channel} is {}, not a finite value the average of {} frame(s) can hold",
                pixel % w as usize,
                pixel / w as usize,
                crate::optics::Num(*v),
                done.len()
            )));
        }
        let shape = (values > 0).then_some((w, h, c));
        Ok(LongExposure { shape, done, sum, settings })
    }

    /// The exposure: the average of the frames (Kyaw 2013 sec. 7.4, blend factor 1/n).
    pub fn image(&self) -> Result<Image, LongExposureError> {
        let Some((width, height, channels)) = self.shape.filter(|_| !self.done.is_empty()) else {
            return Err(LongExposureError::NoFrames);
        };
        let n = self.done.len() as f64;
        Ok(Image { width, height, channels, data: self.sum.iter().map(|&s| (s / n) as f32).collect() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant(value: f32) -> Image {
        Image { width: 3, height: 2, channels: 4, data: vec![value; 24] }
    }

    #[test]
    fn ten_thousand_frames_of_a_constant_image_stay_constant() {
        // 0.1 and 1e6 are not exact in binary; an HDR value and a dim one.
        for value in [0.1f32, 1e6, 3.0e-4] {
            let mut exposure = LongExposure::default();
            // A sum in f32, for comparison: it drifts.
            let mut sum_f32 = 0.0f32;
            for n in 1..=10_000u32 {
                exposure.add(i64::from(n), &constant(value)).unwrap();
                sum_f32 += value;
            }
            assert_eq!(exposure.frames(), 10_000);
            let image = exposure.image().unwrap();
            for &v in &image.data {
                let relative = ((v as f64 - value as f64) / value as f64).abs();
                assert!(relative <= 1e-6, "{value}: {v} is {relative:e} off");
            }
            // The test tells: an f32 sum is off by more than 1e-6 here.
            let drift = ((sum_f32 as f64 / 1e4 - value as f64) / value as f64).abs();
            assert!(drift > 1e-6, "{value}: the f32 sum drifted only {drift:e}");
        }
    }

    #[test]
    fn the_exposure_is_the_average_of_the_frames() {
        // A highlight moving one pixel per frame along a 4x1 row: each pixel lit in one of 4
        // frames holds 1/4 of it; the total light equals one frame's.
        let mut exposure = LongExposure::default();
        for frame in 0..4u32 {
            let mut image = Image::new(4, 1, 1);
            image.set(frame, 0, 0, 8.0);
            exposure.add(i64::from(frame), &image).unwrap();
        }
        let image = exposure.image().unwrap();
        assert_eq!(image.data, [2.0, 2.0, 2.0, 2.0]);
        assert_eq!(image.data.iter().sum::<f32>(), 8.0);
    }

    #[test]
    fn a_stopped_exposure_resumes_to_the_same_sums() {
        let frame = |n: u32| {
            let mut image = Image::new(3, 2, 4);
            image
                .data
                .iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v = 0.1 * (i as f32 + 1.0) * n as f32 + 1e5 * (n % 3) as f32);
            image
        };
        let mut whole = LongExposure::new("f/2, focus 2 m");
        let mut first = LongExposure::new("f/2, focus 2 m");
        for n in 1..=7 {
            whole.add(i64::from(n), &frame(n)).unwrap();
            if n <= 3 {
                first.add(i64::from(n), &frame(n)).unwrap();
            }
        }
        let mut resumed = LongExposure::from_bytes(&first.to_bytes()).unwrap();
        assert_eq!(resumed.done(), [1, 2, 3]);
        assert_eq!(resumed.settings(), "f/2, focus 2 m");
        for n in 4..=7 {
            resumed.add(i64::from(n), &frame(n)).unwrap();
        }
        assert_eq!(resumed.to_bytes(), whole.to_bytes());
        assert_eq!(resumed.image().unwrap(), whole.image().unwrap());
        assert_eq!(LongExposure::from_bytes(&LongExposure::default().to_bytes()).unwrap().frames(), 0);
        // A version 1 state (no settings line) still resumes.
        let v1 = LongExposure::from_bytes(b"realcam-long-exposure 1\n1 1 1\n5\n\0\0\0\0\0\0\xf0\x3f").unwrap();
        assert_eq!((v1.done(), v1.settings(), v1.image().unwrap().data), (&[5][..], "", vec![1.0]));
    }

    #[test]
    fn a_bad_state_is_named() {
        let state = |bytes: &[u8]| LongExposure::from_bytes(bytes).unwrap_err().to_string();
        assert_eq!(
            state(b"hello"),
            "not a long-exposure state of realcam: the first line is not \"realcam-long-exposure 2\""
        );
        assert_eq!(
            state(b"realcam-long-exposure 2"),
            "not a long-exposure state of realcam: the settings line is missing"
        );
        assert_eq!(
            state(b"realcam-long-exposure 2\nf/2\n3 2\n1\n"),
            "not a long-exposure state of realcam: the size line \"3 2\" is not WIDTH HEIGHT CHANNELS"
        );
        assert_eq!(
            state(b"realcam-long-exposure 1\n1 1 1\n1,x\n"),
            "not a long-exposure state of realcam: the frame \"x\" is not a frame number"
        );
        assert_eq!(
            state(b"realcam-long-exposure 1\n1 1 2\n1\n12345678"),
            "not a long-exposure state of realcam: 8 bytes of sums, expected 16 (1x1 px, 2 channel(s), 8 bytes each)"
        );
    }

    /// Issue 34 (fuzzing the state files): a frame listed twice was looked for among the frames
    /// before it, quadratic in the frames (a state of a million frames took hours).
    #[test]
    fn a_state_of_a_million_frames_is_checked_for_a_frame_listed_twice() {
        let frames: Vec<String> = (1..=1_000_000).chain([999_999]).map(|f: i64| f.to_string()).collect();
        let state = format!("{STATE_MAGIC}\nf/2\n1 1 1\n{}\n", frames.join(","));
        let mut bytes = state.into_bytes();
        bytes.extend_from_slice(&1.0f64.to_le_bytes());
        assert_eq!(
            LongExposure::from_bytes(&bytes).unwrap_err().to_string(),
            "not a long-exposure state of realcam: the frames line lists frame 999999 more than once"
        );
    }

    #[test]
    fn a_frame_of_another_size_and_an_empty_exposure_are_errors() {
        let mut exposure = LongExposure::default();
        assert_eq!(exposure.image().unwrap_err(), LongExposureError::NoFrames);
        exposure.add(1001, &Image::new(4, 2, 4)).unwrap();
        assert_eq!(
            exposure.add(1002, &Image::new(4, 3, 4)).unwrap_err().to_string(),
            "frame 1002 is 4x3 px with 4 channel(s), but the exposure's first frame was 4x2 px with 4"
        );
        assert_eq!(exposure.frames(), 1);
    }
}
