//! Issue 32 item 2, Walch 2017 ch. 5: the fit's targets from captured images instead of traced
//! ones. A capture is a grey image of a point light at a known angle (sec. 5.1: a light at
//! steps of the angle, in a dark room), optionally as exposure brackets (sec. 5.1: 0.25, 1 and
//! 4 s merged to HDR). Before a ghost is fitted (ch. 7), what is not the ghost is taken out:
//!
//! - the brackets are made linear through the camera's response and merged, each pixel from
//!   the frames in which it is not clipped ([`merge_brackets`]);
//! - the background (sec. 7.1.1: "the cost function is not able to distinguish between
//!   background and lens flare elements") is the median of the frame's border, subtracted
//!   ([`remove_background`]; zero-mean noise is left, not clipped at 0, so that it averages out
//!   of the ghost's energy);
//! - the light's own glare, round about the light, is the median over the azimuth at each
//!   distance from the light within a given radius, subtracted ([`remove_glare`]): a ghost
//!   covers few of the azimuths at a distance and leaves the median alone, the glare all.

pub mod folder;

use super::GreyImage;
use std::path::{Path, PathBuf};

/// What a capture's file says of itself.
#[derive(Clone, Debug, PartialEq)]
pub struct CaptureFile {
    pub path: PathBuf,
    /// The light's angle off the axis (degrees, towards +x).
    pub angle_deg: f64,
    /// The exposure time (s); None for a capture that is not one of a bracket.
    pub exposure_s: Option<f64>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CaptureError {
    #[error("{path}: no light angle: name the file like capture_12.5deg.exr (or capture_12.5deg_0.25s.exr in a bracket), or give a sidecar {sidecar} with \"angle_deg\"")]
    NoAngle { path: String, sidecar: String },
    #[error("{path}: field {field:?} is {value}, not a finite number{more}")]
    BadField { path: String, field: &'static str, value: String, more: &'static str },
    #[error("{path}: {message}")]
    Sidecar { path: String, message: String },
}

/// The angle and exposure of a capture: from its sidecar `<file>.json` (`{"angle_deg": 12.5,
/// "exposure_s": 0.25}`) where there is one, else from its name: `_`-separated parts of the
/// file's stem ending in `deg` (the angle) and in `s` (the exposure), e.g.
/// `capture_12.5deg_0.25s.exr`. `sidecar` is the sidecar's text, read by the caller (None: no
/// sidecar).
pub fn capture_file(path: &Path, sidecar: Option<&str>) -> Result<CaptureFile, CaptureError> {
    let shown = path.display().to_string();
    let sidecar_path = sidecar_of(path).display().to_string();
    let (mut angle_deg, mut exposure_s) = (None, None);
    let stem = path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    for part in stem.split('_') {
        if let Some(a) = part.strip_suffix("deg") {
            angle_deg = Some(number(&shown, "angle (deg in the name)", a, "")?);
        } else if let Some(t) = part.strip_suffix('s') {
            if let Ok(t) = t.parse::<f64>() {
                exposure_s = Some(positive(&shown, "exposure (s in the name)", t)?);
            }
        }
    }
    if let Some(text) = sidecar {
        let json: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| CaptureError::Sidecar { path: sidecar_path.clone(), message: e.to_string() })?;
        if let Some(v) = json.get("angle_deg") {
            let a = v.as_f64().ok_or_else(|| bad(&sidecar_path, "angle_deg", v.to_string(), ""))?;
            angle_deg = Some(number(&sidecar_path, "angle_deg", &a.to_string(), "")?);
        }
        if let Some(v) = json.get("exposure_s") {
            let t = v.as_f64().ok_or_else(|| bad(&sidecar_path, "exposure_s", v.to_string(), ""))?;
            exposure_s = Some(positive(&sidecar_path, "exposure_s", t)?);
        }
    }
    let angle_deg = angle_deg.ok_or(CaptureError::NoAngle { path: shown, sidecar: sidecar_path })?;
    Ok(CaptureFile { path: path.to_path_buf(), angle_deg, exposure_s })
}

/// A capture's sidecar: `capture_12.5deg.exr` -> `capture_12.5deg.exr.json`.
pub fn sidecar_of(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

fn bad(path: &str, field: &'static str, value: String, more: &'static str) -> CaptureError {
    CaptureError::BadField { path: path.to_string(), field, value, more }
}

fn number(path: &str, field: &'static str, text: &str, more: &'static str) -> Result<f64, CaptureError> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(bad(path, field, format!("{text:?}"), more)),
    }
}

fn positive(path: &str, field: &'static str, t: f64) -> Result<f64, CaptureError> {
    if t.is_finite() && t > 0.0 {
        Ok(t)
    } else {
        Err(bad(path, field, t.to_string(), " above 0"))
    }
}

/// The camera's response: a recorded value v (0..1, clipped at `clip`) of the exposure
/// H = radiance x time is v = H^(1 / gamma); gamma 1 is a raw (linear) capture, as Walch uses
/// (sec. 5.1: "raw-data as captured by the sensor").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    pub gamma: f64,
    /// Recorded values at or above this are clipped (their exposure unknown, only its bound).
    pub clip: f64,
}

impl Response {
    /// The exposure H of a recorded value (the inverse response; a value below 0, noise about
    /// a subtracted black level, keeps its sign).
    pub fn exposure(&self, recorded: f64) -> f64 {
        recorded.signum() * recorded.abs().powf(self.gamma)
    }
}

/// One frame of a bracket: its exposure time and its recorded grey values.
#[derive(Clone, Debug)]
pub struct Bracket {
    pub exposure_s: f64,
    pub recorded: Vec<f32>,
}

/// The merged radiance (exposure per second) of a bracket, and how many pixels were clipped
/// in every frame (their radiance is then a lower bound: the shortest frame's clip level).
#[derive(Clone, Debug)]
pub struct Merged {
    pub radiance: Vec<f64>,
    pub clipped_everywhere: usize,
}

/// The brackets merged to HDR (sec. 5.1): each frame made linear by the inverse response and
/// divided by its time, and each pixel the weighted mean of those frames that did not clip it,
/// weighted by the time squared (the inverse variance of H / t for a sensor noise of one
/// variance in H: the longest unclipped frame counts most). Frames must be of one size.
pub fn merge_brackets(frames: &[Bracket], response: Response) -> Merged {
    let n = frames.iter().map(|f| f.recorded.len()).min().unwrap_or(0);
    let mut radiance = vec![0.0; n];
    let mut clipped_everywhere = 0;
    let shortest = frames.iter().map(|f| f.exposure_s).fold(f64::INFINITY, f64::min);
    for (i, out) in radiance.iter_mut().enumerate() {
        let (mut sum, mut weights) = (0.0, 0.0);
        for f in frames {
            let v = f.recorded[i] as f64;
            if v >= response.clip || !v.is_finite() {
                continue;
            }
            let w = f.exposure_s * f.exposure_s;
            sum += w * response.exposure(v) / f.exposure_s;
            weights += w;
        }
        *out = if weights > 0.0 {
            sum / weights
        } else {
            clipped_everywhere += 1;
            response.exposure(response.clip) / shortest
        };
    }
    Merged { radiance, clipped_everywhere }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

/// The background: the median of the pixels within `border` px of the frame's edge (where a
/// capture of a light near the middle holds no ghost), subtracted from every pixel. Returns
/// the level removed.
pub fn remove_background(values: &mut [f64], width: usize, height: usize, border: usize) -> f64 {
    let mut ring = Vec::new();
    for y in 0..height {
        for x in 0..width {
            if x < border || y < border || x + border >= width || y + border >= height {
                ring.push(values[y * width + x]);
            }
        }
    }
    let level = median(&mut ring);
    for v in values.iter_mut() {
        *v -= level;
    }
    level
}

/// The light's own glare about `light_px` (pixel centres at +0.5), out to `radius_px`: at each
/// whole distance from the light the median of the pixels at that distance (over the azimuth)
/// is subtracted from them. A ghost that covers less than half of the azimuths at a distance
/// keeps its light there; one that covers more loses it there.
pub fn remove_glare(values: &mut [f64], width: usize, height: usize, light_px: [f64; 2], radius_px: f64) {
    let rings = radius_px.max(0.0).ceil() as usize + 1;
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); rings];
    for y in 0..height {
        for x in 0..width {
            let r = (x as f64 + 0.5 - light_px[0]).hypot(y as f64 + 0.5 - light_px[1]);
            if r <= radius_px {
                at[r.round() as usize].push(y * width + x);
            }
        }
    }
    for ring in at {
        let mut v: Vec<f64> = ring.iter().map(|&i| values[i]).collect();
        let m = median(&mut v);
        for i in ring {
            values[i] -= m;
        }
    }
}

/// A (processed) capture of `width` x `height` frame pixels as the fit's target: the box
/// `window` (frame px: x0, y0, x1, y1; None: the whole frame) in square cells of whole pixels,
/// at most `max_cells` across, each the mean of its pixels (light per frame pixel, as
/// [`super::traced_ghost_image`] has it).
pub fn capture_image(
    values: &[f64],
    width: usize,
    height: usize,
    window: Option<[f64; 4]>,
    max_cells: u32,
) -> GreyImage {
    let [x0, y0, x1, y1] = window.unwrap_or([0.0, 0.0, width as f64, height as f64]);
    let (x0, y0) = (x0.floor().clamp(0.0, width as f64), y0.floor().clamp(0.0, height as f64));
    let (x1, y1) = (x1.ceil().clamp(x0 + 1.0, width as f64), y1.ceil().clamp(y0 + 1.0, height as f64));
    let cell = ((x1 - x0).max(y1 - y0) / max_cells.max(1) as f64).ceil().max(1.0);
    let w = ((x1 - x0) / cell).floor().max(1.0) as u32;
    let h = ((y1 - y0) / cell).floor().max(1.0) as u32;
    let c = cell as usize;
    let mut out = vec![0.0; (w * h) as usize];
    for cy in 0..h as usize {
        for cx in 0..w as usize {
            let (mut s, mut n) = (0.0, 0.0);
            for y in (y0 as usize + cy * c)..(y0 as usize + (cy + 1) * c).min(height) {
                for x in (x0 as usize + cx * c)..(x0 as usize + (cx + 1) * c).min(width) {
                    s += values[y * width + x];
                    n += 1.0;
                }
            }
            out[cy * w as usize + cx] = if n > 0.0 { s / n } else { 0.0 };
        }
    }
    GreyImage { width: w, height: h, origin_px: [x0, y0], cell_px: cell, values: out }
}

/// Synthetic captures' noise: standard normal values (Box-Muller over a 64-bit LCG), the same
/// sequence for the same seed (the captures' tests).
#[doc(hidden)]
pub fn seeded_gauss(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        let mut u = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::flare_fit::{fit_restarted, moments_guess, traced_ghost_image, FitOptions, MARGIN};

    #[test]
    fn a_capture_names_its_angle_and_exposure_or_says_what_is_missing() {
        let f = capture_file(Path::new("shots/capture_12.5deg_0.25s.exr"), None).unwrap();
        assert_eq!((f.angle_deg, f.exposure_s), (12.5, Some(0.25)));
        let f = capture_file(Path::new("capture_-3deg.exr"), None).unwrap();
        assert_eq!((f.angle_deg, f.exposure_s), (-3.0, None));
        // The sidecar wins over the name.
        let f = capture_file(Path::new("a_1deg.exr"), Some(r#"{"angle_deg": 7.5, "exposure_s": 4}"#)).unwrap();
        assert_eq!((f.angle_deg, f.exposure_s), (7.5, Some(4.0)));
        let e = capture_file(Path::new("shot.exr"), None).unwrap_err();
        assert!(e.to_string().contains("shot.exr.json") && e.to_string().contains("deg"), "{e}");
        let e = capture_file(Path::new("shot_xdeg.exr"), None).unwrap_err();
        assert!(matches!(e, CaptureError::BadField { field: "angle (deg in the name)", .. }), "{e}");
        let e = capture_file(Path::new("shot_1deg.exr"), Some(r#"{"exposure_s": -1}"#)).unwrap_err();
        assert!(e.to_string().contains("shot_1deg.exr.json") && e.to_string().contains("exposure_s"), "{e}");
    }

    #[test]
    fn brackets_merge_to_the_radiance_leaving_clipped_frames_out() {
        // Radiance 0.3 and 3 /s, gamma 2.2, clipped at 1: at 1 s the bright pixel clips (3 ->
        // 1), at 0.25 s it does not (0.75^(1/2.2)); the merge gives both back.
        let r = Response { gamma: 2.2, clip: 0.999 };
        let rec = |h: f64| (h.powf(1.0 / 2.2)).min(1.0) as f32;
        let frames: Vec<Bracket> = [0.25, 1.0]
            .iter()
            .map(|&t| Bracket { exposure_s: t, recorded: vec![rec(0.3 * t), rec(3.0 * t)] })
            .collect();
        let m = merge_brackets(&frames, r);
        assert!((m.radiance[0] - 0.3).abs() < 1e-5 && (m.radiance[1] - 3.0).abs() < 1e-4, "{:?}", m.radiance);
        assert_eq!(m.clipped_everywhere, 0);
        // Had the clipped frame been used, the bright pixel would read (0.0625 * 3 + 1 * 1) /
        // 1.0625 = 1.12, not 3. With the 1 s frame alone it is clipped everywhere, its
        // radiance only the bound 0.999^2.2 / 1 s.
        let only_long = merge_brackets(&frames[1..], r);
        assert_eq!(only_long.clipped_everywhere, 1);
        assert!((only_long.radiance[1] - 0.999f64.powf(2.2)).abs() < 1e-9);
    }

    #[test]
    fn a_block_of_pixels_becomes_one_cell_of_their_mean() {
        let values: Vec<f64> = (0..16).map(|i| i as f64).collect();
        let g = capture_image(&values, 4, 4, None, 2);
        assert_eq!((g.width, g.height, g.cell_px, g.origin_px), (2, 2, 2.0, [0.0, 0.0]));
        assert_eq!(g.values, vec![2.5, 4.5, 10.5, 12.5]);
    }

    #[test]
    fn fits_of_noisy_clipped_bracketed_captures_with_glare_agree_with_the_clean_fits() {
        // Issue 32 item 2's synthetic captures: the Tessar's ghost 4/0 in green traced on a
        // 320x180 frame at 2 and 5 degrees (48 rays across, at most 24 cells, each cell one
        // capture pixel), seen through a camera: a background of 4% of the ghost's peak, the
        // light's glare (a round bump of 3x the ghost's peak, 6 cells wide, beside the ghost's
        // edge: the median over the azimuth cannot tell a glare inside a ghost from it), sensor noise of 1% of the peak at 1 s, a response of gamma 2.2 clipped at 1,
        // brackets of 0.25, 1 and 4 s (the ghost's peak at 0.5 at 1 s: the 4 s frame clips
        // it and the glare). Merged, the background and glare removed, each is fitted as the
        // clean image is; the fits draw the clean fits' light within 5%.
        use crate::tools::accuracy_flare::light_slope;
        let (w, h) = (320, 180);
        let (model, sensor, path) = crate::tools::flare_fit::tests::tessar_320x180_ghost_4_0();
        let lens = model.lens.as_ref().unwrap();
        let mut gauss = seeded_gauss(0x5eed);
        let options = FitOptions::default();
        let response = Response { gamma: 2.2, clip: 0.999 };
        for angle in [2.0, 5.0] {
            let clean = traced_ghost_image(lens, path, light_slope(angle, w, h), 1, 48, sensor, MARGIN, 24).unwrap();
            let (cw, ch) = (clean.width as usize, clean.height as usize);
            let peak = clean.values.iter().copied().fold(0.0, f64::max);
            // Radiance in units where the ghost's peak is 0.5 /s.
            let k = 0.5 / peak;
            let light = [0.1 * cw as f64, 0.5 * ch as f64];
            let scene: Vec<f64> = (0..cw * ch)
                .map(|i| {
                    let (x, y) = ((i % cw) as f64 + 0.5, (i / cw) as f64 + 0.5);
                    let r = (x - light[0]).hypot(y - light[1]);
                    let glare = 1.5 * (1.0 - r / 3.0).max(0.0).powi(2);
                    k * clean.values[i] + 0.02 + glare
                })
                .collect();
            let frames: Vec<Bracket> = [0.25, 1.0, 4.0]
                .iter()
                .map(|&t| Bracket {
                    exposure_s: t,
                    recorded: scene
                        .iter()
                        .map(|l| {
                            let hx = l * t + 0.005 * gauss();
                            (hx.signum() * hx.abs().powf(1.0 / response.gamma)).min(1.0) as f32
                        })
                        .collect(),
                })
                .collect();
            let clipped_long = frames[2].recorded.iter().filter(|&&v| v >= 1.0).count();
            assert!(clipped_long > 10, "the 4 s frame clips: {clipped_long} px");
            let mut merged = merge_brackets(&frames, response).radiance;
            let background = remove_background(&mut merged, cw, ch, 1);
            assert!((background - 0.02).abs() < 0.005, "background {background}");
            remove_glare(&mut merged, cw, ch, light, 3.0);
            let captured = GreyImage { values: merged.iter().map(|v| v / k).collect(), ..clean.clone() };
            let fit_of = |image: &GreyImage| fit_restarted(image, &moments_guess(image).unwrap(), &options).ghost;
            let (from_clean, from_capture) = (fit_of(&clean), fit_of(&captured));
            let energy = |g| clean.draw(&g).iter().sum::<f64>();
            let ratio = energy(from_capture) / energy(from_clean);
            assert!(
                (ratio - 1.0).abs() < 0.05,
                "{angle} deg: the capture's fit draws {ratio:.4} of the clean fit's light"
            );
        }
    }
}
