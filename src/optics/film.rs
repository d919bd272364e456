//! The film characteristic curve (Kyaw 2013 sec 4.5): response against log exposure, with a
//! toe, a straight part and a shoulder. Here the response is log10 of a linear output value
//! (the negative of a density), so the curve runs from black up to white.
//!
//! Working in decades (log10) on both axes, the curve is
//!
//! ```text
//! x      = log10(clamp(H, 1e-30, 1e30))                      (NaN and H <= 0 count as 1e-30)
//! y_lin  = log10(grey_out) + contrast * (x - log10(grey_in))  straight part through middle grey
//! y_sh   = smin(y_lin, log10(white), shoulder_softness)       shoulder
//! y_toe  = smax(y_sh,  log10(black), toe_softness)            toe
//! y      = lb + (y_toe - lb) * (lw - lb) / (smax(lw, lb, toe_softness) - lb)
//! out    = 10^y
//! ```
//!
//! with lb = log10(black), lw = log10(white) and the soft maximum in decades
//! smax(a, b, k) = k log10(10^(a/k) + 10^(b/k)) = max(a, b) + k log10(1 + 10^(-|a - b| / k)),
//! smin(a, b, k) = -smax(-a, -b, k). The softness k is how many decades the blend spans: where
//! the two lines cross, the result is k log10 2 = 0.3 k decades past the larger one, and
//! beyond about 2k decades apart the blend is under 1% of a decade. The toe's soft maximum
//! lifts the white asymptote by a hair above lw; the last affine step maps [lb, that] back onto
//! [lb, lw] exactly, so the asymptotes are black and white and the curve stays smooth (C-inf)
//! and strictly increasing. The constants 1e-30 and 1e30 are representable in f32, so a shader
//! can use the same ones.

use super::lens::OpticsError;
use std::f64::consts::LN_10;

/// Sensor values are clamped into this range before the logarithm (NaN -> the minimum).
pub const MIN_SENSOR_VALUE: f64 = 1e-30;
pub const MAX_SENSOR_VALUE: f64 = 1e30;

/// A filmic tone curve in log-log space: a straight line of slope `contrast` through middle
/// grey, softly limited by a shoulder at `white_out` and a toe at `black_out`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmCurve {
    /// Sensor value (1.0 = saturation) that maps to middle grey, e.g. 0.18.
    pub middle_grey_in: f64,
    /// Output value of middle grey, e.g. 0.18.
    pub middle_grey_out: f64,
    /// Slope of log10(out) against log10(in) in the straight part, e.g. 1.0-1.6.
    pub contrast: f64,
    /// Width of the toe blend in decades of output.
    pub toe_softness_decades: f64,
    /// Width of the shoulder blend in decades of output.
    pub shoulder_softness_decades: f64,
    /// Output floor (the toe's asymptote), e.g. 1e-3.
    pub black_out: f64,
    /// Output ceiling (the shoulder's asymptote), e.g. 1.0.
    pub white_out: f64,
}

/// Soft maximum in decades: k log10(10^(a/k) + 10^(b/k)), written so it cannot overflow.
/// Always >= max(a, b) and at most k log10 2 above it; k <= 0 gives the hard maximum.
pub fn soft_max_decades(a: f64, b: f64, softness_decades: f64) -> f64 {
    let k = softness_decades;
    if k.is_nan() || k <= 0.0 {
        return a.max(b);
    }
    a.max(b) + k * (-(a - b).abs() / k * LN_10).exp().ln_1p() / LN_10
}

/// Soft minimum in decades: -soft_max(-a, -b).
pub fn soft_min_decades(a: f64, b: f64, softness_decades: f64) -> f64 {
    -soft_max_decades(-a, -b, softness_decades)
}

impl FilmCurve {
    /// A neutral filmic look: ISO middle grey (0.128) -> 0.18, contrast 1.2, 1000:1 output range, a shoulder that
    /// reaches about 0.95 at sensor saturation.
    pub fn default_filmic() -> Self {
        FilmCurve {
            // ISO 12232 places a standard exposure of middle grey (H = 10/ISO lux s) at 10/78 =
            // 0.128 of the saturation exposure (H_sat = 78/ISO): that sensor value prints as 0.18.
            middle_grey_in: 0.128,
            middle_grey_out: 0.18,
            contrast: 1.2,
            toe_softness_decades: 0.2,
            shoulder_softness_decades: 0.25,
            black_out: 1e-3,
            white_out: 1.0,
        }
    }

    /// Checks the parameters: everything finite, grey levels and contrast positive, softness
    /// not negative, 0 < black_out < middle_grey_out < white_out.
    /// The named presets: "neutral" (the default filmic curve), "contrast" (steeper, harder
    /// shoulder, like a slide film), "soft" (flatter, long toe and shoulder, like a negative
    /// printed soft). None for an unknown name.
    pub fn preset(name: &str) -> Option<Self> {
        let neutral = Self::default_filmic();
        match name {
            "neutral" | "filmic" => Some(neutral),
            "contrast" => Some(FilmCurve {
                contrast: 1.6,
                shoulder_softness_decades: 0.15,
                toe_softness_decades: 0.12,
                ..neutral
            }),
            "soft" => Some(FilmCurve {
                contrast: 0.95,
                shoulder_softness_decades: 0.4,
                toe_softness_decades: 0.35,
                ..neutral
            }),
            _ => None,
        }
    }

    pub fn validate(self) -> Result<Self, OpticsError> {
        let c = self;
        let in_range = c.black_out < c.middle_grey_out && c.middle_grey_out < c.white_out;
        let rules = [
            ("middle_grey_in", c.middle_grey_in, c.middle_grey_in > 0.0, "must be positive"),
            ("contrast", c.contrast, c.contrast > 0.0, "must be positive"),
            ("toe_softness_decades", c.toe_softness_decades, c.toe_softness_decades >= 0.0, "must not be negative"),
            (
                "shoulder_softness_decades",
                c.shoulder_softness_decades,
                c.shoulder_softness_decades >= 0.0,
                "must not be negative",
            ),
            ("black_out", c.black_out, c.black_out > 0.0, "must be positive"),
            ("white_out", c.white_out, c.white_out > c.black_out, "must be above black_out"),
            ("middle_grey_out", c.middle_grey_out, in_range, "must lie between black_out and white_out"),
        ];
        for (name, value, ok, requirement) in rules {
            let requirement = if value.is_finite() { requirement } else { "must be finite" };
            if !(value.is_finite() && ok) {
                return Err(OpticsError::InvalidFilmCurve { name, value, requirement });
            }
        }
        Ok(self)
    }

    /// Maps a linear sensor value (1.0 = saturation) to a linear output value in
    /// [black_out, white_out]. Total: NaN and values <= 0 give black_out, +inf gives white_out.
    pub fn apply(&self, sensor_value: f64) -> f64 {
        let h = if sensor_value > MIN_SENSOR_VALUE {
            sensor_value.min(MAX_SENSOR_VALUE)
        } else {
            MIN_SENSOR_VALUE // also NaN
        };
        let out = 10f64.powf(self.apply_log10(h.log10()));
        out.max(self.black_out).min(self.white_out)
    }

    /// The characteristic curve itself: log10(output) as a function of log10(sensor value).
    pub fn apply_log10(&self, log10_in: f64) -> f64 {
        let (lb, lw) = (self.black_out.log10(), self.white_out.log10());
        let (k_toe, k_shoulder) = (self.toe_softness_decades, self.shoulder_softness_decades);
        // Kyaw 2013 sec 4.5: straight part, then shoulder (highlights) and toe (shadows).
        let linear = self.middle_grey_out.log10() + self.contrast * (log10_in - self.middle_grey_in.log10());
        let shoulder = soft_min_decades(linear, lw, k_shoulder);
        let toe = soft_max_decades(shoulder, lb, k_toe);
        let ceiling = soft_max_decades(lw, lb, k_toe);
        let y = lb + (toe - lb) * ((lw - lb) / (ceiling - lb));
        y.max(lb).min(lw)
    }
}

impl Default for FilmCurve {
    fn default() -> Self {
        Self::default_filmic()
    }
}

/// A characteristic curve as a table in log-log space, interpolated linearly, constant beyond
/// its ends.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmTable {
    pub log10_sensor_value: Vec<f64>,
    pub log10_output: Vec<f64>,
}

impl FilmTable {
    /// The response to a linear sensor value (NaN and values <= 0 give the first entry).
    pub fn apply(&self, sensor_value: f64) -> f64 {
        let x = if sensor_value > 1e-30 { sensor_value.min(1e30).log10() } else { -30.0 };
        10f64.powf(self.apply_log10(x))
    }

    pub fn apply_log10(&self, x: f64) -> f64 {
        let (xs, ys) = (&self.log10_sensor_value, &self.log10_output);
        let n = xs.len();
        if x <= xs[0] {
            return ys[0];
        }
        match (1..n).find(|&i| x <= xs[i]) {
            Some(i) => ys[i - 1] + (ys[i] - ys[i - 1]) * (x - xs[i - 1]) / (xs[i] - xs[i - 1]),
            None => ys[n - 1],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// log10 sensor values from 1e-12 to 1e12 in steps of 1e-3 decades.
    const STEP_DECADES: f64 = 1e-3;
    fn grid() -> impl Iterator<Item = f64> {
        (0..=24_000).map(|i| -12.0 + i as f64 * STEP_DECADES)
    }

    fn curves() -> Vec<FilmCurve> {
        let d = FilmCurve::default_filmic();
        vec![
            d,
            FilmCurve { contrast: 1.6, toe_softness_decades: 0.05, shoulder_softness_decades: 0.35, ..d },
            FilmCurve { contrast: 1.0, black_out: 1e-4, white_out: 0.9, ..d },
            FilmCurve { middle_grey_in: 0.128, middle_grey_out: 0.2, ..d },
        ]
    }

    #[test]
    fn monotonic_bounded_and_finite_on_a_dense_grid() {
        for curve in curves() {
            let mut previous = 0.0;
            for x in grid() {
                let out = curve.apply(10f64.powf(x));
                assert!(out.is_finite() && out >= curve.black_out && out <= curve.white_out, "{x} {out}");
                assert!(out >= previous, "not monotonic at 10^{x}: {out} < {previous}");
                previous = out;
            }
            // The extremes reach the asymptotes.
            assert!((curve.apply(1e-12) - curve.black_out).abs() < 1e-6 * curve.black_out);
            assert!((curve.apply(1e12) - curve.white_out).abs() < 1e-9);
        }
    }

    #[test]
    fn special_inputs() {
        for curve in curves() {
            let black = curve.apply(0.0);
            assert_eq!(curve.apply(f64::NAN), black);
            assert_eq!(curve.apply(-5.0), black);
            assert_eq!(curve.apply(f64::NEG_INFINITY), black);
            assert!((curve.apply(f64::INFINITY) / curve.white_out - 1.0).abs() < 1e-12);
            for h in [0.0, 1e-300, 1e6, 1e300, f64::MAX, f64::INFINITY, f64::NAN] {
                let out = curve.apply(h);
                assert!(out >= curve.black_out && out <= curve.white_out, "{h} -> {out}");
            }
        }
    }

    /// The slope of log10(out) vs log10(in) is continuous: between neighbouring grid intervals
    /// it changes by at most step * max|y''|, and max|y''| <= contrast^2 ln10 (1/4k_s + 1/4k_t)
    /// (each soft max has second derivative at most ln10 / 4k per unit slope squared).
    #[test]
    fn c1_in_log_log() {
        let max_slope_jump = |curve: &FilmCurve| {
            let ys: Vec<f64> = grid().map(|x| curve.apply_log10(x)).collect();
            let slopes: Vec<f64> = ys.windows(2).map(|w| (w[1] - w[0]) / STEP_DECADES).collect();
            slopes.windows(2).map(|s| (s[1] - s[0]).abs()).fold(0.0, f64::max)
        };
        for curve in curves() {
            let bound = STEP_DECADES
                * curve.contrast.powi(2)
                * LN_10
                * (0.25 / curve.shoulder_softness_decades + 0.25 / curve.toe_softness_decades);
            let jump = max_slope_jump(&curve);
            assert!(jump <= 1.01 * bound + 1e-9, "slope jump {jump} > {bound} for {curve:?}");
        }
        // The check has teeth: hard corners (softness 0) jump by the full contrast.
        let hard = FilmCurve { toe_softness_decades: 0.0, shoulder_softness_decades: 0.0, ..FilmCurve::default() };
        assert!(max_slope_jump(&hard) > 0.5 * hard.contrast);
    }

    #[test]
    fn middle_grey_and_contrast_in_the_straight_part() {
        for curve in curves() {
            let out = curve.apply(curve.middle_grey_in);
            assert!((out / curve.middle_grey_out - 1.0).abs() < 0.01, "{out} for {curve:?}");
            let x = curve.middle_grey_in.log10();
            let slope = (curve.apply_log10(x + 1e-4) - curve.apply_log10(x - 1e-4)) / 2e-4;
            assert!((slope / curve.contrast - 1.0).abs() < 0.02, "slope {slope} for {curve:?}");
        }
        // The default shoulder keeps sensor saturation just under white.
        let at_saturation = FilmCurve::default_filmic().apply(1.0);
        assert!(at_saturation > 0.9 && at_saturation < 1.0, "{at_saturation}");
    }

    #[test]
    fn zero_softness_is_the_clamped_straight_line() {
        let curve = FilmCurve { toe_softness_decades: 0.0, shoulder_softness_decades: 0.0, ..FilmCurve::default() };
        for h in [1e-6, 1e-3, 0.01, 0.18, 0.5, 2.0, 100.0] {
            let straight = curve.middle_grey_out * (h / curve.middle_grey_in).powf(curve.contrast);
            let expected = straight.clamp(curve.black_out, curve.white_out);
            assert!((curve.apply(h) / expected - 1.0).abs() < 1e-12, "{h}");
        }
    }

    #[test]
    fn soft_max_in_decades() {
        let k = 0.3;
        assert!((soft_max_decades(1.0, 1.0, k) - (1.0 + k * 2f64.log10())).abs() < 1e-15);
        assert_eq!(soft_max_decades(-1.0, 700.0, k), 700.0);
        assert_eq!(soft_min_decades(3.0, -1.0, k), -soft_max_decades(-3.0, 1.0, k));
        assert!(soft_max_decades(2.0, 1.0, k) > 2.0 && soft_min_decades(2.0, 1.0, k) < 1.0);
        // Equal to the textbook log-sum-exp where that does not overflow.
        let direct = k * (10f64.powf(0.2 / k) + 10f64.powf(0.5 / k)).log10();
        assert!((soft_max_decades(0.2, 0.5, k) - direct).abs() < 1e-14);
    }

    #[test]
    fn validate_rejects_nonsense() {
        assert!(FilmCurve::default_filmic().validate().is_ok());
        let d = FilmCurve::default_filmic();
        let bad = [
            (FilmCurve { contrast: 0.0, ..d }, "contrast = 0"),
            (FilmCurve { middle_grey_in: f64::NAN, ..d }, "middle_grey_in = NaN"),
            (FilmCurve { toe_softness_decades: -0.1, ..d }, "toe_softness_decades = -0.1"),
            (FilmCurve { black_out: 0.0, ..d }, "black_out = 0"),
            (FilmCurve { white_out: 1e-4, ..d }, "white_out = 0.0001"),
            (FilmCurve { middle_grey_out: 1.5, ..d }, "middle_grey_out = 1.5"),
        ];
        for (curve, message) in bad {
            let err = curve.validate().unwrap_err().to_string();
            assert!(err.contains(message), "{err:?} lacks {message:?}");
        }
        // Invalid curves still do not panic.
        let upside_down = FilmCurve { black_out: 2.0, white_out: 0.5, ..d };
        let _ = upside_down.apply(0.3);
    }
}
