//! Camera optics on the CPU: plain `f64` math, no Vulkan.
//!
//! Everything here is a paraxial thin-lens model (Gaussian optics). Each quantity carries its
//! unit in its name (`_mm`, `_s`, `_deg`, `_rad`, `_lux_s`); dimensionless ratios (f-number,
//! magnification, transmittance, gains) carry none. Distances are measured along the optical
//! axis from the lens (the pupils, for a thick lens).
//!
//! Sources, cited next to each equation:
//! - Kyaw 2013, *A Realistic Camera Model for Real-time Rendering*, ch. 3-5 (lens, exposure,
//!   vignetting, film, circle of confusion).
//! - Potmesil & Chakravarty 1981, *A Lens and Aperture Camera Model for Synthetic Image
//!   Generation*, sec. 2.2-2.3 (depth of field limits, Table 1).
//!
//! Sign conventions: the magnification returned by [`ThinLens::magnification`] is the
//! positive |m| = v/S; the circle of confusion from [`ThinLens::coc_mm`] is signed
//! (positive behind the focus plane, negative in front).

pub mod diffraction;
pub mod distortion;
pub mod dof;
pub mod exposure;
pub mod film;
pub mod flare;
pub mod focus_processor;
pub mod lens;
pub mod prescription;
pub mod sensor;
pub mod shutter;
pub mod spherical;

pub use dof::{dof_limits, dof_report, CocCriterion, DofLimits};
pub use film::FilmCurve;
pub use lens::{OpticsError, ThinLens};
pub use sensor::{Sensor, SensorFit};
