//! Issue 32 item 2: `realcam flare-fit --captures DIR`, Walch 2017's workflow from what a camera
//! recorded (ch. 5) instead of traced images. A folder of EXR captures of a point light, each
//! naming its angle (and, in a bracket, its exposure time) by its file name or a sidecar
//! ([`super::capture_file`]), is grouped by angle; each angle's bracket is merged to
//! HDR with clipped pixels left out (sec. 5.1), its background and the light's glare removed
//! (sec. 7.1.1), and each ghost's region binned into the fit's cells. The ghosts are then fitted
//! over the angles (ch. 7, sec. 7.3's seeding) and made polynomials of the angle (ch. 8) as the
//! traced path does ([`super::super::fit_traced_ghosts`]), with the same errors reported.

use super::super::{fit_range, fitted_range, FitOptions, FittedRange, GreyImage};
use super::{
    capture_file, capture_image, merge_brackets, remove_background, remove_glare, sidecar_of, Bracket, CaptureError,
    CaptureFile, Response,
};
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

/// A capture's name read ([`capture_file`], with its sidecar where there is one).
fn named(path: &Path) -> Result<CaptureFile, CapturesError> {
    let sidecar_path = sidecar_of(path);
    let sidecar = match std::fs::read_to_string(&sidecar_path) {
        Ok(t) => Some(t),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(CapturesError::Read { path: sidecar_path.display().to_string(), message: e.to_string() }),
    };
    Ok(capture_file(path, sidecar.as_deref())?)
}

/// The grey values of `channels` (0 red, 1 green, 2 blue) of the capture at `path`, and its
/// size: its channel R, G or B, or, where it has not that one, its one channel Y.
fn read_channels(path: &Path, channels: &[usize]) -> Result<(u32, u32, Vec<Vec<f32>>), CapturesError> {
    let mut size = (0, 0);
    let mut out = Vec::with_capacity(channels.len());
    for &c in channels {
        let name = ["R", "G", "B"][c.min(2)];
        let image = crate::io::read_exr_channel(path, name).or_else(|_| crate::io::read_exr_channel(path, "Y"));
        let image = image.map_err(|e| CapturesError::Read {
            path: path.display().to_string(),
            message: format!("a capture needs channel {name} (or one channel Y): {e}"),
        })?;
        size = (image.width, image.height);
        out.push(image.data);
    }
    Ok((size.0, size.1, out))
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

/// The files of one angle (sorted by angle) checked as a bracket: several frames need exposure
/// times, each its own.
fn check_bracket(group: &[CaptureFile]) -> Result<(), CapturesError> {
    for (k, a) in group.iter().enumerate() {
        for b in &group[k + 1..] {
            let what = match (a.exposure_s, b.exposure_s) {
                (None, _) | (_, None) => "no exposure time in one of them".to_string(),
                (Some(x), Some(y)) if x == y => format!("the same exposure time {x} s"),
                _ => continue,
            };
            let (p, q) = (a.path.display().to_string(), b.path.display().to_string());
            return Err(CapturesError::Bracket { a: p, b: q, angle: a.angle_deg, what });
        }
    }
    Ok(())
}

/// One angle's bracket (`frames`: exposure time, recorded values) merged and cleaned: the
/// radiance per pixel of a `w` x `h` frame.
fn cleaned(frames: &[(f64, Vec<f32>)], w: usize, h: usize, options: &CaptureFitOptions) -> Vec<f64> {
    let brackets: Vec<Bracket> = frames.iter().map(|(t, v)| Bracket { exposure_s: *t, recorded: v.clone() }).collect();
    let mut radiance = merge_brackets(&brackets, options.response).radiance;
    remove_background(&mut radiance, w, h, options.border_px);
    if options.glare_radius_px > 0.0 {
        let brightest = (0..radiance.len()).max_by(|&p, &q| radiance[p].total_cmp(&radiance[q])).unwrap_or(0);
        let light = [(brightest % w) as f64 + 0.5, (brightest / w) as f64 + 0.5];
        remove_glare(&mut radiance, w, h, light, options.glare_radius_px);
    }
    radiance
}

/// One ghost's samples fitted over the angles and made polynomials by the stage the traced
/// path uses ([`fitted_range`], as [`super::super::fit_traced_ghosts`] does each traced
/// ghost); None with too few samples.
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
    Some(fitted_range(samples, fits, label, channel, frame_px, order, options))
}

/// What [`fit_captures`] found: the fitted ghosts, the frame, the angles and the files read.
#[derive(Clone, Debug)]
pub struct CapturesFit {
    pub fitted: Vec<FittedRange>,
    pub frame_px: [u32; 2],
    pub angles_deg: Vec<f64>,
    pub files: usize,
}

/// The captures of `dir` fitted: every ghost region in every channel over the angles. The
/// names are all read (and the brackets checked) first; then one angle's files at a time, so
/// that only one bracket's pixels are held. `progress` hears each angle and each ghost.
pub fn fit_captures(
    dir: &Path,
    options: &CaptureFitOptions,
    mut progress: impl FnMut(&str),
) -> Result<CapturesFit, CapturesError> {
    let paths = capture_paths(dir)?;
    let mut files = paths.iter().map(|p| named(p)).collect::<Result<Vec<_>, _>>()?;
    files.sort_by(|a, b| a.angle_deg.total_cmp(&b.angle_deg));
    let groups: Vec<&[CaptureFile]> = files.chunk_by(|a, b| a.angle_deg == b.angle_deg).collect();
    groups.iter().try_for_each(|g| check_bracket(g))?;
    let regions: Vec<(String, Option<[f64; 4]>)> =
        if options.ghosts.is_empty() { vec![("capture".into(), None)] } else { options.ghosts.clone() };
    // samples[channel][region]: (angle, the ghost's cells).
    let mut samples: Vec<Vec<Vec<(f64, GreyImage)>>> = vec![vec![Vec::new(); regions.len()]; options.channels.len()];
    let mut first: Option<(u32, u32, &Path)> = None;
    for group in &groups {
        let angle = group[0].angle_deg;
        progress(&format!("captures at {angle} deg"));
        let mut frames: Vec<(f64, Vec<Vec<f32>>)> = Vec::new();
        for f in group.iter() {
            let (w, h, values) = read_channels(&f.path, &options.channels)?;
            let (w0, h0, p0) = *first.get_or_insert((w, h, &f.path));
            if (w, h) != (w0, h0) {
                let (path, first) = (f.path.display().to_string(), p0.display().to_string());
                return Err(CapturesError::Size { path, w, h, first, w0, h0 });
            }
            frames.push((f.exposure_s.unwrap_or(1.0), values));
        }
        let (w, h) = first.map(|f| (f.0 as usize, f.1 as usize)).unwrap_or((0, 0));
        for (ci, per_region) in samples.iter_mut().enumerate() {
            let bracket: Vec<(f64, Vec<f32>)> = frames.iter().map(|(t, v)| (*t, v[ci].clone())).collect();
            let radiance = cleaned(&bracket, w, h, options);
            for ((_, region), out) in regions.iter().zip(per_region.iter_mut()) {
                let region = region.unwrap_or([0.0, 0.0, w as f64, h as f64]);
                if let Some(window) = ghost_window(&radiance, w, region) {
                    out.push((angle, capture_image(&radiance, w, h, Some(window), options.max_cells)));
                }
            }
        }
    }
    let (w, h, _) = first.unwrap_or((0, 0, dir));
    let mut fitted = Vec::new();
    for (&c, per_region) in options.channels.iter().zip(&samples) {
        for ((label, _), s) in regions.iter().zip(per_region) {
            progress(&format!("ghost {label} channel {c}"));
            fitted.extend(fit_samples(s, label, c, [w, h], options.order, &options.fit));
        }
    }
    let angles_deg = groups.iter().map(|g| g[0].angle_deg).collect();
    Ok(CapturesFit { fitted, frame_px: [w, h], angles_deg, files: paths.len() })
}
