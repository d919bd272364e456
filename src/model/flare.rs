//! What a camera needs for lens flare: whether it is wanted, from how far over the sensor's
//! saturation a pixel counts as a light, the lights given explicitly (a renderer's list, lights
//! just outside the frame), the lens's prescription (for its ghosts), its coatings and halo.

use crate::optics::flare::starburst::Halo;
use crate::optics::prescription::Prescription;
use std::sync::Arc;

/// Defined with the flare optics (the flare-lights file reads it too).
pub use crate::optics::flare::FlareLight;

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
