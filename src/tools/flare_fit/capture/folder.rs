//! Issue 32 item 2: `realcam flare-fit --captures DIR`, Walch 2017's workflow from what a camera
//! recorded (ch. 5) instead of traced images. A folder of EXR captures of a point light, each
//! naming its angle (and, in a bracket, its exposure time) by its file name or a sidecar
//! ([`super::capture_file`]), is grouped by angle; each angle's bracket is merged to
//! HDR with clipped pixels left out (sec. 5.1), its background and the light's glare removed
//! (sec. 7.1.1), and each ghost's region binned into the fit's cells. The ghosts are then fitted
//! over the angles (ch. 7, sec. 7.3's seeding) and made polynomials of the angle (ch. 8) as the
//! traced path does ([`super::super::fit_traced_ghosts`]), with the same errors reported.

use super::super::{
    energy_centroid, fit_range, mse, polynomials, relight, worst_error, FitOptions, FittedRange, GreyImage,
};
use super::{
    capture_file, capture_image, merge_brackets, remove_background, remove_glare, sidecar_of, Bracket, CaptureError,
    Response,
};
use crate::io::lens_file::FittedGhostSpec;
use std::path::{Path, PathBuf};

/// How the captures are read and fitted.
#[derive(Clone, Debug)]
pub struct CaptureFitOptions {
    /// The camera's response (gamma 1: linear raw captures) and its clip level.
    pub response: Response,
    /// Pixels of the frame's border whose median is the background ([`remove_background`]).
    pub border_px: usize,
    /// The light's glare removed out to this radius about the light, the capture's brightest
    /// pixel ([`remove_glare`]); 0: none removed.
    pub glare_radius_px: f64,
    /// One region per ghost (frame px: x0, y0, x1, y1), each with its label; empty: one ghost,
    /// labelled "capture", anywhere in the frame.
    pub ghosts: Vec<(String, Option<[f64; 4]>)>,
    /// Channels to fit (0 red, 1 green, 2 blue); a grey capture (one channel Y) serves each.
    pub channels: Vec<usize>,
    pub max_cells: u32,
    pub order: usize,
    pub fit: FitOptions,
}

/// Why the captures cannot be fitted; the messages name the files and flags.
#[derive(Debug, thiserror::Error)]
pub enum CapturesError {
    #[error("--captures {dir}: {message}")]
    Folder { dir: String, message: String },
    #[error(transparent)]
    Capture(#[from] CaptureError),
    #[error("{path}: {message}")]
    Read { path: String, message: String },
    #[error("{path} is {w}x{h}, {first} is {w0}x{h0}: the captures must share one frame size")]
    Size { path: String, w: u32, h: u32, first: String, w0: u32, h0: u32 },
    #[error("{a} and {b} are both of {angle} deg with {what}: a bracket's frames need exposure times of their own (e.g. capture_{angle}deg_0.25s.exr)")]
    Bracket { a: String, b: String, angle: f64, what: String },
}

/// One capture as read: its angle, exposure time (1 s when it names none) and its grey values
/// in each of the 3 channels (a grey capture's one channel in all three).
struct Frame {
    path: PathBuf,
    angle_deg: f64,
    exposure_s: Option<f64>,
    width: u32,
    height: u32,
    channels: [Vec<f32>; 3],
}

fn read_frame(path: &Path) -> Result<Frame, CapturesError> {
    let sidecar_path = sidecar_of(path);
    let sidecar = match std::fs::read_to_string(&sidecar_path) {
        Ok(t) => Some(t),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(CapturesError::Read { path: sidecar_path.display().to_string(), message: e.to_string() }),
    };
    let file = capture_file(path, sidecar.as_deref())?;
    let read = |name: &str| crate::io::read_exr_channel(path, name);
    let shown = path.display().to_string();
    let (width, height, channels) = match (read("R"), read("G"), read("B")) {
        (Ok(r), Ok(g), Ok(b)) => (r.width, r.height, [r.data, g.data, b.data]),
        _ => match read("Y") {
            Ok(y) => (y.width, y.height, [y.data.clone(), y.data.clone(), y.data]),
            Err(e) => {
                return Err(CapturesError::Read {
                    path: shown,
                    message: format!("a capture needs channels R, G and B, or one channel Y ({e})"),
                })
            }
        },
    };
    Ok(Frame {
        path: path.to_path_buf(),
        angle_deg: file.angle_deg,
        exposure_s: file.exposure_s,
        width,
        height,
        channels,
    })
}

/// The `.exr` files of `dir` (not its sub-folders), sorted by name.
pub fn capture_paths(dir: &Path) -> Result<Vec<PathBuf>, CapturesError> {
    let folder = |message: String| CapturesError::Folder { dir: dir.display().to_string(), message };
    let entries = std::fs::read_dir(dir).map_err(|e| folder(e.to_string()))?;
    let mut paths = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| folder(e.to_string()))?.path();
        let is_exr = path.extension().is_some_and(|x| x.eq_ignore_ascii_case("exr"));
        if is_exr && path.is_file() {
            paths.push(path);
        }
    }
    paths.sort();
    if paths.is_empty() {
        return Err(folder("no .exr captures in the folder".into()));
    }
    Ok(paths)
}

/// The box about a ghost within `region` of `values` (`width` px wide): the pixels of at least
/// a tenth of the region's peak, grown on every side by [`super::super::MARGIN`] of its larger side
/// (at least 4 px: room for the primitive's outer fade, as the traced images have), kept in the
/// region. None when the region holds no light.
pub fn ghost_window(values: &[f64], width: usize, region: [f64; 4]) -> Option<[f64; 4]> {
    let height = values.len() / width.max(1);
    let x0 = region[0].floor().clamp(0.0, width as f64) as usize;
    let y0 = region[1].floor().clamp(0.0, height as f64) as usize;
    let x1 = region[2].ceil().clamp(0.0, width as f64) as usize;
    let y1 = region[3].ceil().clamp(0.0, height as f64) as usize;
    let peak =
        (y0..y1).flat_map(|y| (x0..x1).map(move |x| (x, y))).map(|(x, y)| values[y * width + x]).fold(0.0, f64::max);
    if !(peak > 0.0) {
        return None;
    }
    let (mut b0, mut b1) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for y in y0..y1 {
        for x in x0..x1 {
            if values[y * width + x] >= 0.1 * peak {
                b0 = [b0[0].min(x as f64), b0[1].min(y as f64)];
                b1 = [b1[0].max(x as f64 + 1.0), b1[1].max(y as f64 + 1.0)];
            }
        }
    }
    let grow = (super::super::MARGIN * (b1[0] - b0[0]).max(b1[1] - b0[1])).max(4.0).ceil();
    Some([
        (b0[0] - grow).max(x0 as f64),
        (b0[1] - grow).max(y0 as f64),
        (b1[0] + grow).min(x1 as f64),
        (b1[1] + grow).min(y1 as f64),
    ])
}

/// Each angle's captures merged and cleaned, in channel `c`: (angle, radiance per pixel).
fn merged_angles(
    frames: &[Frame],
    c: usize,
    options: &CaptureFitOptions,
) -> Result<Vec<(f64, Vec<f64>)>, CapturesError> {
    let (w, h) = (frames[0].width as usize, frames[0].height as usize);
    let mut out: Vec<(f64, Vec<f64>)> = Vec::new();
    let mut i = 0;
    while i < frames.len() {
        let angle = frames[i].angle_deg;
        let group: Vec<&Frame> = frames[i..].iter().take_while(|f| f.angle_deg == angle).collect();
        i += group.len();
        for (k, a) in group.iter().enumerate() {
            for b in &group[k + 1..] {
                let what = match (a.exposure_s, b.exposure_s) {
                    (None, _) | (_, None) => "no exposure time in one of them".to_string(),
                    (Some(x), Some(y)) if x == y => format!("the same exposure time {x} s"),
                    _ => continue,
                };
                let (a, b) = (a.path.display().to_string(), b.path.display().to_string());
                return Err(CapturesError::Bracket { a, b, angle, what });
            }
        }
        let brackets: Vec<Bracket> = group
            .iter()
            .map(|f| Bracket { exposure_s: f.exposure_s.unwrap_or(1.0), recorded: f.channels[c].clone() })
            .collect();
        let mut radiance = merge_brackets(&brackets, options.response).radiance;
        remove_background(&mut radiance, w, h, options.border_px);
        if options.glare_radius_px > 0.0 {
            let brightest = (0..radiance.len()).max_by(|&p, &q| radiance[p].total_cmp(&radiance[q])).unwrap_or(0);
            let light = [(brightest % w) as f64 + 0.5, (brightest / w) as f64 + 0.5];
            remove_glare(&mut radiance, w, h, light, options.glare_radius_px);
        }
        out.push((angle, radiance));
    }
    Ok(out)
}

/// One ghost's samples fitted over the angles and made polynomials (as
/// [`super::super::fit_traced_ghosts`] does each traced ghost); None with too few samples.
pub fn fit_samples(
    samples: &[(f64, GreyImage)],
    label: &str,
    channel: usize,
    frame_px: [u32; 2],
    order: usize,
    options: &FitOptions,
) -> Option<FittedRange> {
    if samples.len() <= order {
        return None;
    }
    let fits = fit_range(samples, None, order, options);
    if fits.len() <= order {
        return None;
    }
    let used = &samples[..fits.len()];
    let plain = polynomials(samples, &fits, order);
    let relit = relight(used, &plain, order);
    let poly = if worst_error(used, &relit) <= worst_error(used, &plain) { relit } else { plain };
    let (mut rmse, mut energy, mut moved, mut fit_rmse, mut fit_energy) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for ((a, image), fit1) in used.iter().zip(&fits) {
        let drawn = image.draw(&poly.at(*a));
        let own = image.draw(&fit1.ghost);
        let peak = image.values.iter().copied().fold(0.0, f64::max);
        let (e_t, c_t) = energy_centroid(image, &image.values);
        let (e_f, c_f) = energy_centroid(image, &drawn);
        fit_rmse = fit_rmse.max(mse(&own, &image.values).sqrt() / peak);
        fit_energy = fit_energy.max((energy_centroid(image, &own).0 / e_t - 1.0).abs());
        rmse = rmse.max(mse(&drawn, &image.values).sqrt() / peak);
        energy = energy.max((e_f / e_t - 1.0).abs());
        moved = moved.max((c_t[0] - c_f[0]).hypot(c_t[1] - c_f[1]));
    }
    Some(FittedRange {
        spec: FittedGhostSpec::new(label, channel as u32, frame_px, &poly),
        samples: fits.len(),
        worst_rmse_over_peak: rmse,
        worst_energy_error: energy,
        worst_centroid_px: moved,
        worst_fit_rmse_over_peak: fit_rmse,
        worst_fit_energy_error: fit_energy,
    })
}

/// What [`fit_captures`] found: the fitted ghosts, the frame, the angles and the files read.
#[derive(Clone, Debug)]
pub struct CapturesFit {
    pub fitted: Vec<FittedRange>,
    pub frame_px: [u32; 2],
    pub angles_deg: Vec<f64>,
    pub files: usize,
}

/// The captures of `dir` fitted: every ghost region in every channel over the angles.
/// `progress` hears each ghost.
pub fn fit_captures(
    dir: &Path,
    options: &CaptureFitOptions,
    mut progress: impl FnMut(&str),
) -> Result<CapturesFit, CapturesError> {
    let paths = capture_paths(dir)?;
    let mut frames = paths.iter().map(|p| read_frame(p)).collect::<Result<Vec<_>, _>>()?;
    let (w, h) = (frames[0].width, frames[0].height);
    if let Some(f) = frames.iter().find(|f| (f.width, f.height) != (w, h)) {
        let (path, first) = (f.path.display().to_string(), frames[0].path.display().to_string());
        return Err(CapturesError::Size { path, w: f.width, h: f.height, first, w0: w, h0: h });
    }
    frames.sort_by(|a, b| a.angle_deg.total_cmp(&b.angle_deg));
    let mut angles_deg: Vec<f64> = frames.iter().map(|f| f.angle_deg).collect();
    angles_deg.dedup();
    let regions: Vec<(String, Option<[f64; 4]>)> =
        if options.ghosts.is_empty() { vec![("capture".into(), None)] } else { options.ghosts.clone() };
    let mut fitted = Vec::new();
    for &c in &options.channels {
        let merged = merged_angles(&frames, c, options)?;
        for (label, region) in &regions {
            progress(&format!("ghost {label} channel {c}"));
            let region = region.unwrap_or([0.0, 0.0, w as f64, h as f64]);
            let samples: Vec<(f64, GreyImage)> = merged
                .iter()
                .filter_map(|(a, values)| {
                    let window = ghost_window(values, w as usize, region)?;
                    Some((*a, capture_image(values, w as usize, h as usize, Some(window), options.max_cells)))
                })
                .collect();
            fitted.extend(fit_samples(&samples, label, c, [w, h], options.order, &options.fit));
        }
    }
    Ok(CapturesFit { fitted, frame_px: [w, h], angles_deg, files: paths.len() })
}
