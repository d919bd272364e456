//! The aperture: the iris ([`ApertureShape`]: blades, rotation, curvature, spherical aberration,
//! cat's eye), or a user-supplied aperture image (PNG or EXR, [`ApertureMask`]): the iris shape as
//! a grey-level mask, used instead of the bladed polygon for the bokeh. Resampled to a fixed square grid that spans the
//! CoC's circumscribed square; its mean sets the area over which each sample's energy spreads.

use std::path::{Path, PathBuf};

/// The iris: n blades (< 3 means circular), rotation, blade curvature 0 (straight) .. 1 (round).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApertureShape {
    pub blades: u32,
    pub rotation_deg: f64,
    pub curvature: f64,
    /// Spherical aberration amount (-1..1): > 0 under-corrected, < 0 over-corrected, 0 uniform
    /// disks (src/optics/spherical.rs).
    pub spherical_aberration: f64,
    /// Cat's eye (optical vignetting) at the frame's farthest corner, 0..1: the aperture is
    /// clipped by a circle shifted by this fraction of its radius there (less nearer the centre).
    pub cats_eye: f64,
    /// Traced spherical aberration instead of `spherical_aberration`: the rim zone's focus
    /// shift (marginal minus paraxial focus, mm, < 0 under-corrected) at this f-number; None
    /// for the amount model.
    pub lsa_rim_mm: Option<f64>,
    /// The image height (mm) at which `cats_eye` holds; None: at the frame's farthest corner.
    pub cats_eye_at_mm: Option<f64>,
}

impl ApertureShape {
    pub const CIRCLE: ApertureShape = ApertureShape {
        blades: 0,
        rotation_deg: 0.0,
        curvature: 1.0,
        spherical_aberration: 0.0,
        cats_eye: 0.0,
        lsa_rim_mm: None,
        cats_eye_at_mm: None,
    };

    /// cats_eye / (distance from the optical centre to the farthest corner), per pixel.
    pub fn cats_eye_per_px(&self, width: u32, height: u32, centre_px: [f64; 2]) -> f64 {
        let corner = [(0.0, 0.0), (width as f64, 0.0), (0.0, height as f64), (width as f64, height as f64)]
            .iter()
            .map(|&(x, y)| ((x - centre_px[0]).powi(2) + (y - centre_px[1]).powi(2)).sqrt())
            .fold(0.0, f64::max);
        self.cats_eye_per_px_at(corner)
    }

    /// The same with the farthest corner `corner` px from the centre.
    pub fn cats_eye_per_px_at(&self, corner: f64) -> f64 {
        if corner > 0.0 {
            self.cats_eye.clamp(0.0, 1.0) / corner
        } else {
            0.0
        }
    }
}

/// Grid the mask is resampled to (MASK_SIZE x MASK_SIZE values).
pub const MASK_SIZE: u32 = 64;

#[derive(Debug, thiserror::Error)]
pub enum ApertureMaskError {
    #[error("aperture image {path}: {message}")]
    Read { path: PathBuf, message: String },
    /// Larger than the memory budget (checked before decoding).
    #[error(transparent)]
    TooLarge(crate::io::IoError),
    #[error("aperture image {path}: the mask is empty (every value is 0 or below)")]
    Empty { path: PathBuf },
    /// Open somewhere, but too thin or small for any of the mask's samples to fall on it.
    #[error("aperture image {path}: its open part (values above 0) is too thin or small to show in the {size}x{size} mask made of its {width}x{height} px, centred in a square of its longer side; draw the aperture to fill a square image")]
    TooThin { path: PathBuf, width: u32, height: u32, size: u32 },
}

impl ApertureMaskError {
    /// The setting the error is about, if any (`max_pixels`).
    pub fn field(&self) -> Option<&'static str> {
        match self {
            ApertureMaskError::TooLarge(e) => e.field(),
            _ => None,
        }
    }
}

/// Bytes per pixel an aperture image takes while loaded: the decoded image (at most 4 channels
/// of 16 bits) and its grey levels with alpha as f32.
const APERTURE_BYTES_PER_PX: u64 = 8 + 8 + 4;

#[derive(Clone, Debug, PartialEq)]
pub struct ApertureMask {
    /// MASK_SIZE^2 values in 0..1, row-major, top row first (the aperture as seen for background
    /// bokeh, upright).
    pub values: Vec<f32>,
    /// Mean of the values: the fraction of the circumscribed square the aperture covers.
    pub mean: f32,
}

impl ApertureMask {
    /// Load a PNG (luminance, times alpha if any) or an EXR (the first of A, Y, R, G, B found as
    /// its colour channels' mean) and resample it, centred, into the square grid. Its declared
    /// size is checked against `budget` before it is decoded.
    pub fn load(path: &Path, budget: &crate::io::MemoryBudget) -> Result<ApertureMask, ApertureMaskError> {
        let err = |message: String| ApertureMaskError::Read { path: path.to_path_buf(), message };
        let is_exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let (w, h, grey) = if is_exr {
            let img = crate::io::read_exr_rgba_within(path, budget).map_err(|e| match e {
                e @ crate::io::IoError::TooLarge { .. } => ApertureMaskError::TooLarge(e),
                e => err(e.to_string()),
            })?;
            let grey: Vec<f32> = img.data.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) / 3.0).collect();
            (img.width, img.height, grey)
        } else {
            let reader = || {
                image::ImageReader::open(path)
                    .map_err(|e| err(e.to_string()))?
                    .with_guessed_format()
                    .map_err(|e| err(e.to_string()))
            };
            let (w, h) = reader()?.into_dimensions().map_err(|e| err(e.to_string()))?;
            let (w, h) = (w as u64, h as u64);
            budget
                .check("aperture image", path, w, h, w.saturating_mul(h).saturating_mul(APERTURE_BYTES_PER_PX))
                .map_err(ApertureMaskError::TooLarge)?;
            let mut reader = reader()?;
            let mut limits = image::Limits::default();
            limits.max_alloc = Some(budget.max_bytes);
            reader.limits(limits);
            let img = reader.decode().map_err(|e| err(e.to_string()))?.to_luma_alpha32f();
            let grey: Vec<f32> = img.pixels().map(|p| p.0[0] * p.0[1]).collect();
            (img.width(), img.height(), grey)
        };
        Self::from_grey(w, h, &grey).ok_or_else(|| {
            let path = path.to_path_buf();
            if grey.iter().any(|&v| v > 0.0 && v.is_finite()) {
                ApertureMaskError::TooThin { path, width: w, height: h, size: MASK_SIZE }
            } else {
                ApertureMaskError::Empty { path }
            }
        })
    }

    /// Resample a grey image (values clamped to 0..1) into the square grid, each cell the mean
    /// of 8x8 point samples (nearest source pixel); a non-square image is centred in the square
    /// of its longer side. None if it is empty.
    pub fn from_grey(width: u32, height: u32, grey: &[f32]) -> Option<ApertureMask> {
        const SUB: u32 = 8;
        let side = width.max(height) as f64;
        let (ox, oy) = ((side - width as f64) / 2.0, (side - height as f64) / 2.0);
        let n = MASK_SIZE;
        let sample = |sx: f64, sy: f64| {
            let (x, y) = (sx - ox, sy - oy);
            if x < 0.0 || y < 0.0 || x >= width as f64 || y >= height as f64 {
                return 0.0;
            }
            let v = grey[(y as u32 * width + x as u32) as usize];
            if v.is_finite() {
                v.clamp(0.0, 1.0)
            } else {
                0.0
            }
        };
        let mut values = Vec::with_capacity((n * n) as usize);
        for gy in 0..n {
            for gx in 0..n {
                let mut sum = 0.0;
                for j in 0..SUB {
                    for i in 0..SUB {
                        let u = (gx as f64 + (i as f64 + 0.5) / SUB as f64) / n as f64 * side;
                        let v = (gy as f64 + (j as f64 + 0.5) / SUB as f64) / n as f64 * side;
                        sum += sample(u, v);
                    }
                }
                values.push(sum / (SUB * SUB) as f32);
            }
        }
        let mean = values.iter().sum::<f32>() / (n * n) as f32;
        (mean > 0.0).then_some(ApertureMask { values, mean })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_filled_disk_covers_pi_over_4_of_the_square() {
        let s = 256u32;
        let grey: Vec<f32> = (0..s * s)
            .map(|i| {
                let (x, y) = ((i % s) as f64 + 0.5 - 128.0, (i / s) as f64 + 0.5 - 128.0);
                if x * x + y * y <= 128.0 * 128.0 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let m = ApertureMask::from_grey(s, s, &grey).unwrap();
        assert!((m.mean as f64 - std::f64::consts::FRAC_PI_4).abs() < 0.01, "{}", m.mean);
    }

    #[test]
    fn wide_image_is_centred_and_empty_is_rejected() {
        // 128x64 all ones: the middle half of the rows is filled.
        let m = ApertureMask::from_grey(128, 64, &vec![1.0; 128 * 64]).unwrap();
        assert!((m.mean - 0.5).abs() < 1e-6);
        assert_eq!(m.values[0], 0.0);
        assert_eq!(m.values[32 * 64 + 32], 1.0);
        assert!(ApertureMask::from_grey(8, 8, &[0.0; 64]).is_none());
    }

    #[test]
    fn missing_file_is_named() {
        let budget = crate::io::MemoryBudget::system();
        let e = ApertureMask::load(Path::new("/nonexistent/iris.png"), &budget).unwrap_err().to_string();
        assert!(e.starts_with("aperture image /nonexistent/iris.png:"), "{e}");
    }
}
