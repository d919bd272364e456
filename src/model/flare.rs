//! What a camera needs for lens flare: whether it is wanted, from how far over the sensor's
//! saturation a pixel counts as a light, the lights given explicitly (a renderer's list, lights
//! just outside the frame), the lens's prescription (for its ghosts), its coatings and halo.

use crate::optics::flare::starburst::Halo;
use crate::optics::prescription::Prescription;
use std::sync::Arc;

/// A light given by position and energy rather than found in the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlareLight {
    /// Position in the image's pixels (x right, y down, pixel centres at +0.5); may lie outside
    /// the frame.
    pub x_px: f64,
    pub y_px: f64,
    /// Energy per channel: the sum of the scene values of the pixels it would cover (value x
    /// pixels), before the exposure.
    pub energy: [f64; 3],
    /// Its visible area in pixels (at least 1).
    pub area_px: f64,
}

impl FlareLight {
    /// A white light of `energy` per channel covering one pixel.
    pub fn white(x_px: f64, y_px: f64, energy: f64) -> FlareLight {
        FlareLight { x_px, y_px, energy: [energy; 3], area_px: 1.0 }
    }

    /// Every number finite, the energy non-negative and the area at least 0.
    pub fn is_valid(&self) -> bool {
        [self.x_px, self.y_px, self.area_px].iter().chain(&self.energy).all(|v| v.is_finite())
            && self.energy.iter().all(|&e| e >= 0.0)
            && self.area_px >= 0.0
    }
}

/// The flare settings of a camera.
#[derive(Clone, Debug, PartialEq)]
pub struct FlareSettings {
    /// Record lens flare where it would be visible.
    pub enabled: bool,
    /// A pixel with a channel at this many times the sensor's saturation (after the exposure)
    /// belongs to a light.
    pub threshold: f64,
    /// Lights given explicitly, besides those found in the frame.
    pub lights: Vec<FlareLight>,
    /// The lens's prescription, for its ghosts (None: a lens file without `[[surface]]`s).
    pub prescription: Option<Arc<Prescription>>,
    /// Design wavelength of the single-layer quarter-wave coatings of its air|glass surfaces;
    /// None: uncoated.
    pub coating_design_nm: Option<f64>,
    /// The scattering around a light.
    pub halo: Halo,
}

impl FlareSettings {
    /// The default threshold: one stop over the sensor's saturation.
    pub const DEFAULT_THRESHOLD: f64 = 2.0;

    /// No flare.
    pub fn off() -> FlareSettings {
        FlareSettings {
            enabled: false,
            threshold: Self::DEFAULT_THRESHOLD,
            lights: Vec::new(),
            prescription: None,
            coating_design_nm: None,
            halo: Halo { fraction: 0.0, radius_mm: 0.0 },
        }
    }
}
