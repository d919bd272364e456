//! Camera settings over a shot: a track of keyframes per setting (a rack focus, an iris pull,
//! a zoom), each interpolated between its keys and held before the first and after the last.
//! A camera file (`crate::io::camera_file`) or a USD camera fills them; [`ShotCamera`]
//! (super::shot::ShotCamera) evaluates them at each frame.

use super::{CameraField, CameraRequest};

/// The settings a shot may change from frame to frame: the numbers of [`CameraRequest`]. The
/// rest (film, bokeh method, lens file) is one per run.
pub const ANIMATED: [CameraField; 14] = [
    CameraField::FocalLengthMm,
    CameraField::FNumber,
    CameraField::FocusDistanceM,
    CameraField::ShutterS,
    CameraField::ShutterAngleDeg,
    CameraField::Iso,
    CameraField::NitsPerUnit,
    CameraField::Blades,
    CameraField::BladeRotationDeg,
    CameraField::BladeCurvature,
    CameraField::SphericalAberration,
    CameraField::CatsEye,
    CameraField::Grain,
    CameraField::MaxBlurPx,
];

/// `value` of `field` (one of [`ANIMATED`]) written into `request`; a whole-number setting
/// (the blades) takes the nearest whole number.
pub fn set(request: &mut CameraRequest, field: CameraField, value: f64) {
    match field {
        CameraField::FocalLengthMm => request.focal_length_mm = Some(value),
        CameraField::FNumber => request.f_number = Some(value),
        CameraField::FocusDistanceM => request.focus_distance_m = value,
        CameraField::ShutterS => {
            request.shutter_s = value;
            request.shutter_angle_deg = None;
        }
        CameraField::ShutterAngleDeg => request.shutter_angle_deg = Some(value),
        CameraField::Iso => request.iso = value,
        CameraField::NitsPerUnit => request.nits_per_unit = value,
        // A negative or huge count is refused by the camera's check, not wrapped here.
        CameraField::Blades => request.blades = Some(value.round().clamp(0.0, u32::MAX as f64) as u32),
        CameraField::BladeRotationDeg => request.blade_rotation_deg = Some(value),
        CameraField::BladeCurvature => request.blade_curvature = Some(value),
        CameraField::SphericalAberration => request.spherical_aberration = Some(value),
        CameraField::CatsEye => request.cats_eye = Some(value),
        CameraField::Grain => request.grain = value,
        CameraField::MaxBlurPx => request.max_blur_px = value,
        // Not animated (see ANIMATED): nothing to set.
        _ => {}
    }
}

/// How a track goes from one key to the next.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Interpolation {
    /// The key's value until the next key (a cut).
    Constant,
    /// A straight line between keys.
    Linear,
    /// A cubic through the keys that eases out of and into each key where the track turns or
    /// ends (flat there, as Blender's automatic clamped handles) and never overshoots between
    /// two keys: a monotone cubic Hermite curve, its slopes by Fritsch & Butland's (1984)
    /// weighted harmonic mean of the neighbouring secants.
    #[default]
    Smooth,
}

impl Interpolation {
    pub fn parse(name: &str) -> Option<Interpolation> {
        match name {
            "constant" => Some(Interpolation::Constant),
            "linear" => Some(Interpolation::Linear),
            "smooth" => Some(Interpolation::Smooth),
            _ => None,
        }
    }
}

/// One setting's keyframes: (frame, value) with the frames rising, and how to go between them.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    keys: Vec<(f64, f64)>,
    interpolation: Interpolation,
}

/// Why a track was refused.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum TrackError {
    #[error("has no keys")]
    Empty,
    #[error("key {index} is not finite (frame {frame}, value {value})")]
    NotFinite { index: usize, frame: f64, value: f64 },
    #[error("has two keys at frame {frame}")]
    SameFrame { frame: f64 },
}

impl Track {
    /// A track of `keys` (frame, value) in any order, every number finite, no two at one frame.
    pub fn new(mut keys: Vec<(f64, f64)>, interpolation: Interpolation) -> Result<Track, TrackError> {
        if keys.is_empty() {
            return Err(TrackError::Empty);
        }
        if let Some((index, &(frame, value))) =
            keys.iter().enumerate().find(|(_, (f, v))| !f.is_finite() || !v.is_finite())
        {
            return Err(TrackError::NotFinite { index, frame, value });
        }
        keys.sort_by(|a, b| a.0.total_cmp(&b.0));
        if let Some(w) = keys.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(TrackError::SameFrame { frame: w[0].0 });
        }
        Ok(Track { keys, interpolation })
    }

    /// A track that holds one value.
    pub fn constant(value: f64) -> Track {
        Track { keys: vec![(0.0, value)], interpolation: Interpolation::Constant }
    }

    pub fn keys(&self) -> &[(f64, f64)] {
        &self.keys
    }

    /// Whether the value changes over the track (more than one key with different values).
    pub fn is_animated(&self) -> bool {
        self.keys.windows(2).any(|w| w[0].1 != w[1].1)
    }

    /// The value at `frame`: the first key's before it, the last key's after it, between two
    /// keys by the track's interpolation.
    pub fn at(&self, frame: f64) -> f64 {
        let k = &self.keys;
        let next = k.partition_point(|&(f, _)| f <= frame);
        if next == 0 {
            return k[0].1;
        }
        if next == k.len() {
            return k[k.len() - 1].1;
        }
        let i = next - 1;
        let ((f0, v0), (f1, v1)) = (k[i], k[next]);
        let t = (frame - f0) / (f1 - f0);
        match self.interpolation {
            Interpolation::Constant => v0,
            Interpolation::Linear => v0 + (v1 - v0) * t,
            Interpolation::Smooth => {
                let h = f1 - f0;
                let (m0, m1) = (self.slope(i), self.slope(next));
                // Cubic Hermite basis on t in [0, 1], slopes per frame scaled by the interval.
                let t2 = t * t;
                let t3 = t2 * t;
                let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
                let h10 = t3 - 2.0 * t2 + t;
                let h01 = -2.0 * t3 + 3.0 * t2;
                let h11 = t3 - t2;
                h00 * v0 + h10 * h * m0 + h01 * v1 + h11 * h * m1
            }
        }
    }

    /// The smooth curve's slope (value per frame) at key `i`: 0 at the first and last key and
    /// where the track turns (the secants on either side differ in sign); else Fritsch &
    /// Butland's weighted harmonic mean of the two secants, which keeps each interval's cubic
    /// within its keys' values.
    fn slope(&self, i: usize) -> f64 {
        let k = &self.keys;
        if i == 0 || i + 1 >= k.len() {
            return 0.0;
        }
        let (h0, h1) = (k[i].0 - k[i - 1].0, k[i + 1].0 - k[i].0);
        let (d0, d1) = ((k[i].1 - k[i - 1].1) / h0, (k[i + 1].1 - k[i].1) / h1);
        if d0 * d1 <= 0.0 {
            return 0.0;
        }
        3.0 * (h0 + h1) / ((2.0 * h1 + h0) / d0 + (h1 + 2.0 * h0) / d1)
    }
}

/// A shot's keyframed settings: at most one track per setting of [`ANIMATED`], with where
/// they came from (a camera file's path) for messages.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct CameraKeys {
    pub tracks: Vec<(CameraField, Track)>,
    /// What the keys are, as messages name them: `the camera file "rack.toml"`.
    pub origin: String,
}

impl CameraKeys {
    pub fn track(&self, field: CameraField) -> Option<&Track> {
        self.tracks.iter().find(|(f, _)| *f == field).map(|(_, t)| t)
    }

    /// Whether a setting changes over the shot.
    pub fn is_animated(&self) -> bool {
        self.tracks.iter().any(|(_, t)| t.is_animated())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(keys: &[(f64, f64)], interpolation: Interpolation) -> Track {
        Track::new(keys.to_vec(), interpolation).unwrap()
    }

    #[test]
    fn held_before_the_first_key_and_after_the_last() {
        for interpolation in [Interpolation::Constant, Interpolation::Linear, Interpolation::Smooth] {
            let t = track(&[(10.0, 1.0), (20.0, 3.0)], interpolation);
            assert_eq!(t.at(-5.0), 1.0);
            assert_eq!(t.at(10.0), 1.0);
            assert_eq!(t.at(20.0), 3.0);
            assert_eq!(t.at(1e9), 3.0);
        }
    }

    #[test]
    fn two_keys_by_each_interpolation() {
        let keys = [(0.0, 1.0), (8.0, 3.0)];
        assert_eq!(track(&keys, Interpolation::Constant).at(7.9), 1.0);
        assert!((track(&keys, Interpolation::Linear).at(2.0) - 1.5).abs() < 1e-12);
        let smooth = track(&keys, Interpolation::Smooth);
        // Flat at both ends (ease in and out): the Hermite curve 3t^2 - 2t^3 of the way.
        assert!((smooth.at(4.0) - 2.0).abs() < 1e-12, "halfway is the mean");
        assert!((smooth.at(2.0) - (1.0 + 2.0 * 0.15625)).abs() < 1e-12, "a quarter: 3/16 - 2/64 of the way");
        // Slower than linear near the keys.
        assert!(smooth.at(0.5) - 1.0 < 0.2 * (track(&keys, Interpolation::Linear).at(0.5) - 1.0));
    }

    #[test]
    fn smooth_never_overshoots_and_passes_through_every_key() {
        // A rack focus that pulls, holds and pulls back with uneven spacing: a Catmull-Rom
        // curve overshoots the hold here; the monotone cubic stays within each pair of keys.
        let keys = [(1.0, 1.0), (5.0, 1.2), (6.0, 4.0), (20.0, 4.0), (22.0, 0.5), (40.0, 0.45)];
        let t = track(&keys, Interpolation::Smooth);
        for &(f, v) in &keys {
            assert!((t.at(f) - v).abs() < 1e-12);
        }
        for w in keys.windows(2) {
            let (lo, hi) = (w[0].1.min(w[1].1), w[0].1.max(w[1].1));
            for s in 0..=100 {
                let f = w[0].0 + (w[1].0 - w[0].0) * s as f64 / 100.0;
                let v = t.at(f);
                assert!(v >= lo - 1e-12 && v <= hi + 1e-12, "frame {f}: {v} outside [{lo}, {hi}]");
            }
        }
        // Continuous slope through an interior key that does not turn (frame 5 rises on both sides).
        let d = 1e-6;
        let (left, right) = ((t.at(5.0) - t.at(5.0 - d)) / d, (t.at(5.0 + d) - t.at(5.0)) / d);
        assert!((left - right).abs() < 1e-3 * left.abs().max(1.0), "{left} vs {right}");
    }

    #[test]
    fn refused_tracks() {
        assert_eq!(Track::new(vec![], Interpolation::Linear), Err(TrackError::Empty));
        assert_eq!(
            Track::new(vec![(1.0, 2.0), (1.0, 3.0)], Interpolation::Linear),
            Err(TrackError::SameFrame { frame: 1.0 })
        );
        assert!(matches!(
            Track::new(vec![(1.0, f64::NAN)], Interpolation::Linear),
            Err(TrackError::NotFinite { index: 0, .. })
        ));
    }
}
