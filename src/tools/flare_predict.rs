//! `realcam flare-predict`: Walch 2017 ch. 9's occurrence estimators of a lens's fitted ghosts
//! (its `[[fitted_ghost]]` section) for one camera and light. The light's view-space position
//! gives the constellation angle (eq 8.1) and the roll (eq 8.2); each ghost's polynomials give
//! its primitive at that angle (ch. 8), drawn as the GPU draws it (the f32 twin of
//! glsl/tools/bezier_ghosts.comp) turned by the roll about the frame's centre and scaled by eq 8.3's
//! brightness. The flare image's intensity is the mean of its three channels at each pixel;
//! its min, max, sum, average and log-average (sec. 9.1) are reported, and the contrast the
//! flare leaves a scene of the given I_max and I_min (eq 9.3), with the flare's average as
//! I_flare (a veiling glare adds to every pixel alike). [`range`] does the same over a grid or
//! a path of lights, with sec. 9.2's statistics and bins; [`report`] writes those as text, CSV
//! and SVG.

pub mod range;
pub mod report;

use crate::gpu::shaders::bezier_ghost::{BEZIER_BOUNDS, BEZIER_WORDS};
use crate::io::lens_file::FittedGhostSpec;
use crate::optics::ghost_prediction::{
    brightness_scale, constellation_angle_deg, contrast_ratio, estimators, roll_rad, Estimators, ExposureSetting,
};
use crate::passes::flare::ghost_shape::primitive_light;
use crate::tools::bezier_ghosts::DrawnGhost;

/// ln's offset in the log-average (sec. 9.1; Reinhard et al. 2002 use a small delta so that
/// black pixels do not send the mean of logarithms to minus infinity).
pub const LOG_DELTA: f64 = 1.0e-6;

/// What the prediction is for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PredictRequest {
    /// The light in view space (camera at the origin looking down -z, x right, y up).
    pub light_view: [f64; 3],
    /// The scene's camera and light (eq 8.3's R) and those of the images the ghosts were
    /// fitted to (F).
    pub scene: ExposureSetting,
    pub measured: ExposureSetting,
    /// The scene's brightest and darkest intensities (eq 9.1), in the flare's units.
    pub scene_max: f64,
    pub scene_min: f64,
}

/// The prediction for one constellation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    pub angle_deg: f64,
    pub roll_deg: f64,
    /// Eq 8.3's B_scale.
    pub brightness_scale: f64,
    pub frame_px: [u32; 2],
    pub ghosts: usize,
    /// Sec. 9.1 over the frame's pixels.
    pub estimators: Estimators,
    /// Eq 9.3's K_real / K_ideal.
    pub contrast_ratio: f64,
}

/// Why there is no prediction (the fields name the command's inputs).
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PredictError {
    #[error("the lens has no [[fitted_ghost]] section (write one with the fit)")]
    NoGhosts,
    #[error(
        "fitted_ghost {ghost:?} is of a {w}x{h} frame, the first of a {w0}x{h0} one: the ghosts must share one frame"
    )]
    MixedFrames { ghost: String, w: u32, h: u32, w0: u32, h0: u32 },
    #[error("the light is at the camera: it has no direction")]
    LightAtCamera,
    #[error("eq 8.3's brightness scale is not positive and finite: the f-numbers, ISOs, exposure times, luminances and solid angles must all be positive")]
    BadExposure,
    #[error("the scene's intensities must be finite with max >= min >= 0 and max > 0, not max {max}, min {min}")]
    BadScene { max: f64, min: f64 },
}

/// The flare image (mean of the channels per pixel, row by row) of `ghosts` at `angle_deg`,
/// turned by `roll` (radians, counter-clockwise on screen) and scaled by `scale`.
pub fn flare_intensities(ghosts: &[FittedGhostSpec], angle_deg: f64, roll: f64, scale: f64) -> Vec<f64> {
    flare_samples(ghosts, angle_deg, roll, scale, 1)
}

/// [`flare_intensities`] at every `step_px`-th pixel across and down: the pixel nearest the
/// centre of each `step_px` x `step_px` block that starts within the frame (row by row of
/// blocks). Step 1 is every pixel.
pub fn flare_samples(ghosts: &[FittedGhostSpec], angle_deg: f64, roll: f64, scale: f64, step_px: u32) -> Vec<f64> {
    let Some(first) = ghosts.first() else { return Vec::new() };
    let [w, h] = first.frame_px;
    let step = step_px.max(1);
    let (bw, bh) = (w.div_ceil(step), h.div_ceil(step));
    let mut out = vec![0.0f64; bw as usize * bh as usize];
    let pivot_px = [w as f64 / 2.0, h as f64 / 2.0];
    // The sampled pixel of block (bx, by): its centre pixel, kept within the frame.
    let sample = |b: u32, size: u32| (b * step + step / 2).min(size - 1);
    for spec in ghosts {
        let ghost = spec.polynomials().at(angle_deg);
        let drawn = DrawnGhost { ghost, colour: [1.0; 3], roll_rad: roll, pivot_px };
        let Some(words) = drawn.words() else { continue };
        let b = &words[BEZIER_BOUNDS as usize..][..4];
        debug_assert_eq!(words.len(), BEZIER_WORDS as usize);
        let x0 = (b[0] as f64 - 0.5).floor().clamp(0.0, w as f64) as u32;
        let y0 = (b[1] as f64 - 0.5).floor().clamp(0.0, h as f64) as u32;
        let x1 = (b[2] as f64 + 0.5).ceil().clamp(0.0, w as f64) as u32;
        let y1 = (b[3] as f64 + 0.5).ceil().clamp(0.0, h as f64) as u32;
        for by in 0..bh {
            let y = sample(by, h);
            if y < y0 || y >= y1 {
                continue;
            }
            for bx in 0..bw {
                let x = sample(bx, w);
                if x < x0 || x >= x1 {
                    continue;
                }
                let light = primitive_light(&words, [x as f32 + 0.5, y as f32 + 0.5]) as f64;
                // One channel of three: its share of the pixel's mean.
                out[(by * bw + bx) as usize] += scale * light / 3.0;
            }
        }
    }
    out
}

/// Ch. 9's prediction for `request` from a lens's fitted ghosts.
pub fn predict(ghosts: &[FittedGhostSpec], request: &PredictRequest) -> Result<Prediction, PredictError> {
    predict_sampled(ghosts, request, 1)
}

/// [`predict`] from the flare image at every `step_px`-th pixel ([`flare_samples`]): the
/// min, max, average and log-average over those pixels, the sum their average times the
/// frame's pixels. Step 1 is [`predict`]; a larger one is step^2 times quicker, for ranges
/// over large frames.
pub fn predict_sampled(
    ghosts: &[FittedGhostSpec],
    request: &PredictRequest,
    step_px: u32,
) -> Result<Prediction, PredictError> {
    let first = ghosts.first().ok_or(PredictError::NoGhosts)?;
    if let Some(g) = ghosts.iter().find(|g| g.frame_px != first.frame_px) {
        let ([w, h], [w0, h0]) = (g.frame_px, first.frame_px);
        return Err(PredictError::MixedFrames { ghost: g.ghost.clone(), w, h, w0, h0 });
    }
    let l = request.light_view;
    if !l.iter().all(|v| v.is_finite()) || l == [0.0; 3] {
        return Err(PredictError::LightAtCamera);
    }
    let (max, min) = (request.scene_max, request.scene_min);
    if !(max.is_finite() && min.is_finite() && min >= 0.0 && max >= min && max > 0.0) {
        return Err(PredictError::BadScene { max, min });
    }
    let scale = brightness_scale(&request.measured, &request.scene).ok_or(PredictError::BadExposure)?;
    // Eq 8.1 with the camera at the origin looking down -z; eq 8.2 in view space.
    let angle_deg = constellation_angle_deg([0.0, 0.0, -1.0], [0.0; 3], l);
    let roll = roll_rad(l);
    let image = flare_samples(ghosts, angle_deg, roll, scale, step_px);
    let mut e = estimators(&image, LOG_DELTA).ok_or(PredictError::NoGhosts)?;
    if step_px > 1 {
        e.sum = e.average * first.frame_px[0] as f64 * first.frame_px[1] as f64;
    }
    Ok(Prediction {
        angle_deg,
        roll_deg: roll.to_degrees(),
        brightness_scale: scale,
        frame_px: first.frame_px,
        ghosts: ghosts.len(),
        estimators: e,
        contrast_ratio: contrast_ratio(max, min, e.average),
    })
}

/// The prediction as the command prints it.
pub fn text(p: &Prediction) -> String {
    let e = &p.estimators;
    format!(
        "constellation angle (eq 8.1): {:.4} deg\nroll (eq 8.2): {:.4} deg\nbrightness scale (eq 8.3): {:.6}\n\
         flare of {} fitted ghosts on {}x{} px (sec. 9.1):\n  min {:.6e}\n  max {:.6e}\n  sum {:.6e}\n  average {:.6e}\n  \
         log-average {:.6e}\ncontrast ratio K_real/K_ideal (eq 9.3): {:.6}\n",
        p.angle_deg,
        p.roll_deg,
        p.brightness_scale,
        p.ghosts,
        p.frame_px[0],
        p.frame_px[1],
        e.min,
        e.max,
        e.sum,
        e.average,
        e.log_average,
        p.contrast_ratio
    )
}

/// A hand-checkable fitted ghost for the estimators' tests: a 10 x 6 px box of light 2 (sharp
/// edges on pixel borders) in channel `channel`, whose centre moves 1 px right per degree from
/// x = 10 at 0 degrees, fitted on a 40 x 20 frame.
#[doc(hidden)]
pub fn box_ghost(channel: u32) -> FittedGhostSpec {
    use crate::optics::bezier_ghost::{BezierGhost, GhostPolynomials, Transfer};
    let g = BezierGhost {
        centre_px: [10.0, 10.0],
        height_px: 3.0,
        left_px: 5.0,
        right_px: 5.0,
        left_control: 1.0,
        right_control: 1.0,
        transfer: Transfer {
            border: 2.0,
            inner: 2.0,
            inner_falloff_px: 0.0,
            outer_falloff_px: 0.0,
            inner_exponent: 1.0,
            outer_exponent: 1.0,
        },
    };
    let mut coefficients: Vec<Vec<f64>> = g.to_params().iter().map(|&v| vec![v]).collect();
    coefficients[0] = vec![10.0, 1.0];
    FittedGhostSpec::new("2/1", channel, [40, 20], &GhostPolynomials { angles_deg: [0.0, 30.0], coefficients })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setting() -> ExposureSetting {
        ExposureSetting {
            f_number: 4.0,
            iso: 100.0,
            exposure_time_s: 0.01,
            luminance_cd_m2: 1.0e4,
            solid_angle_sr: 1.0e-5,
        }
    }

    #[test]
    fn the_estimators_and_the_contrast_ratio_against_hand_values() {
        // A light 45 degrees off the axis, straight right: angle 45 -> clamped to 30, box centre
        // x = 40, half outside the 40 px frame (x 35..40 of 35..45): 5 x 6 = 30 px of light 2 in
        // one channel, 2/3 each on the mean of three. One stop more ISO: scale 2 -> 4/3 each.
        let request = PredictRequest {
            light_view: [1.0, 0.0, -1.0],
            scene: ExposureSetting { iso: 200.0, ..setting() },
            measured: setting(),
            scene_max: 100.0,
            scene_min: 1.0,
        };
        let p = predict(&[box_ghost(1)], &request).unwrap();
        assert!((p.angle_deg - 45.0).abs() < 1e-12 && p.roll_deg.abs() < 1e-12);
        assert_eq!(p.brightness_scale, 2.0);
        let e = p.estimators;
        let px = 4.0 / 3.0;
        assert_eq!(e.min, 0.0);
        assert!((e.max - px).abs() < 1e-12);
        assert!((e.sum - 30.0 * px).abs() < 1e-9, "{}", e.sum);
        assert!((e.average - 30.0 * px / 800.0).abs() < 1e-12);
        let log_mean = (30.0 * (LOG_DELTA + px).ln() + 770.0 * LOG_DELTA.ln()) / 800.0;
        assert!((e.log_average - log_mean.exp()).abs() < 1e-15);
        // Eq 9.3: (100 + 1) / (101 + 2 * 0.05) = 0.999010.
        assert!((p.contrast_ratio - 101.0 / (101.0 + 2.0 * 0.05)).abs() < 1e-12);
        // Straight up (roll 90 degrees): the box turns about the centre (20, 10) to x 17..23,
        // y -15..-5: out of the frame, no flare, no contrast lost.
        let up = predict(&[box_ghost(1)], &PredictRequest { light_view: [0.0, 1.0, -1.0], ..request }).unwrap();
        assert!((up.roll_deg - 90.0).abs() < 1e-12);
        assert_eq!((up.estimators.max, up.estimators.sum, up.contrast_ratio), (0.0, 0.0, 1.0));
        // On the axis: centre x = 10, all 60 px in; the red and the blue ghost add to the mean.
        let ahead = PredictRequest { light_view: [0.0, 0.0, -3.0], scene: setting(), ..request };
        let p = predict(&[box_ghost(0), box_ghost(2)], &ahead).unwrap();
        assert!((p.estimators.max - 4.0 / 3.0).abs() < 1e-12);
        assert!((p.estimators.sum - 80.0).abs() < 1e-9);
    }

    #[test]
    fn bad_requests_are_named() {
        let request = PredictRequest {
            light_view: [0.0, 0.0, -1.0],
            scene: setting(),
            measured: setting(),
            scene_max: 1.0,
            scene_min: 0.0,
        };
        assert_eq!(predict(&[], &request), Err(PredictError::NoGhosts));
        let other = FittedGhostSpec { frame_px: [80, 40], ghost: "3/2".into(), ..box_ghost(1) };
        assert_eq!(
            predict(&[box_ghost(1), other], &request).unwrap_err().to_string(),
            "fitted_ghost \"3/2\" is of a 80x40 frame, the first of a 40x20 one: the ghosts must share one frame"
        );
        let at_camera = PredictRequest { light_view: [0.0; 3], ..request };
        assert_eq!(predict(&[box_ghost(1)], &at_camera), Err(PredictError::LightAtCamera));
        let nan = PredictRequest { scene: ExposureSetting { f_number: f64::NAN, ..setting() }, ..request };
        assert_eq!(predict(&[box_ghost(1)], &nan), Err(PredictError::BadExposure));
        let dark = PredictRequest { scene_max: 0.0, ..request };
        assert_eq!(predict(&[box_ghost(1)], &dark), Err(PredictError::BadScene { max: 0.0, min: 0.0 }));
    }
}
