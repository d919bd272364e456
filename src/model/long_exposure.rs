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
}

/// Frames accumulated into one exposure; see the module docs.
#[derive(Clone, Debug, Default)]
pub struct LongExposure {
    /// Width, height and channels of the first frame; None before it.
    shape: Option<(u32, u32, u32)>,
    frames: u64,
    /// Per value, the sum over the frames so far.
    sum: Vec<f64>,
}

impl LongExposure {
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
        self.frames += 1;
        Ok(())
    }

    /// The frames accumulated so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// The exposure: the average of the frames (Kyaw 2013 sec. 7.4, blend factor 1/n).
    pub fn image(&self) -> Result<Image, LongExposureError> {
        let Some((width, height, channels)) = self.shape.filter(|_| self.frames > 0) else {
            return Err(LongExposureError::NoFrames);
        };
        let n = self.frames as f64;
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
