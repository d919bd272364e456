//! What a camera needs for lens flare: whether it is wanted, from how far over the sensor's
//! saturation a pixel counts as a light, the lights given explicitly (a renderer's list, lights
//! just outside the frame), the lens's prescription (for its ghosts), its coatings and halo.

use crate::io::lens_file::FittedGhostSpec;
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
    /// Why it is off, when it is: the user's `--no-flare`, or the lens's own default (the ideal
    /// lens, the renderer's camera, draws no flare unless asked for with `--flare`).
    pub off_by: FlareOff,
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
    /// Which model draws the ghosts (`--flare-ghosts`).
    pub ghosts: FlareGhosts,
    /// The lens file's `[[fitted_ghost]]` entries (Walch 2017 ch. 6-8), empty without.
    pub fitted: Vec<FittedGhostSpec>,
}

/// Which model draws a lens's ghosts (`--flare-ghosts`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FlareGhosts {
    /// The fitted primitives when the lens file has `[[fitted_ghost]]`, else the matrices.
    #[default]
    Auto,
    /// Walch's fitted primitives (ch. 6-8) from the lens file's `[[fitted_ghost]]`.
    Fitted,
    /// The ray-transfer matrices of the prescription (src/optics/flare/ghosts.rs).
    Matrix,
}

impl FlareGhosts {
    /// The flag's word for it.
    pub fn name(self) -> &'static str {
        match self {
            FlareGhosts::Auto => "auto",
            FlareGhosts::Fitted => "fitted",
            FlareGhosts::Matrix => "matrix",
        }
    }

    /// Whether the fitted primitives draw the ghosts of a lens with `fits` entries.
    pub fn draws_fitted(self, fits: usize) -> bool {
        match self {
            FlareGhosts::Auto | FlareGhosts::Fitted => fits > 0,
            FlareGhosts::Matrix => false,
        }
    }
}

/// Who turned the flare off.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FlareOff {
    /// The user (`--no-flare`; a camera built with `flare: Some(false)`).
    #[default]
    Asked,
    /// The lens: `--lens ideal` is the renderer's camera, which draws no ghosts, starburst or
    /// halo; `--flare` turns them on.
    IdealLens,
}

impl FlareOff {
    /// Why the flare is off, in the words of `--explain`.
    pub fn reason(self) -> &'static str {
        match self {
            FlareOff::Asked => "turned off (--no-flare)",
            FlareOff::IdealLens => "off: --lens ideal is the renderer's camera, which draws none; --flare draws it",
        }
    }
}

impl FlareSettings {
    /// The default threshold: one stop over the sensor's saturation.
    pub const DEFAULT_THRESHOLD: f64 = 2.0;

    /// No flare.
    pub fn off() -> FlareSettings {
        FlareSettings {
            enabled: false,
            off_by: FlareOff::Asked,
            threshold: Self::DEFAULT_THRESHOLD,
            lights: Vec::new(),
            prescription: None,
            coating_design_nm: None,
            halo: Halo { fraction: 0.0, radius_mm: 0.0 },
            ghosts: FlareGhosts::Auto,
            fitted: Vec::new(),
        }
    }
}
