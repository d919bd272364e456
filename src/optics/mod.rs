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

pub mod bezier_ghost;
pub mod colour;
pub mod diffraction;
pub mod distortion;
pub mod dof;
pub mod exposure;
pub mod film;
pub mod flare;
pub mod focus_processor;
pub mod ghost_prediction;
pub mod lens;
pub mod prescription;
pub mod sensor;
pub mod shutter;
pub mod spherical;
pub mod wavelengths;

pub use dof::{dof_limits, dof_report, CocCriterion, DofLimits};
pub use film::FilmCurve;
pub use lens::{OpticsError, ThinLens};
pub use sensor::{Sensor, SensorFit};

/// A number as messages print it: as Rust writes it when that is short, in scientific notation
/// when it is very large or very small (`1e308`, not 309 digits).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        if x.is_finite() && x != 0.0 && !(1e-6..1e9).contains(&x.abs()) {
            write!(f, "{x:e}")
        } else {
            write!(f, "{x}")
        }
    }
}

#[cfg(test)]
mod num_tests {
    use super::Num;

    #[test]
    fn numbers_in_messages_stay_short() {
        assert_eq!(Num(1e308).to_string(), "1e308");
        assert_eq!(Num(f64::MAX).to_string(), "1.7976931348623157e308");
        assert_eq!(Num(-2.5e-9).to_string(), "-2.5e-9");
        for (x, text) in
            [(0.0, "0"), (2.8, "2.8"), (-50.0, "-50"), (123456789.0, "123456789"), (-1e9, "-1e9"), (f64::NAN, "NaN")]
        {
            assert_eq!(Num(x).to_string(), text);
        }
        assert_eq!(Num(f64::INFINITY).to_string(), "inf");
    }
}
