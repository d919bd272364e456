//! Lens prescriptions (surface tables) and their analysis: paraxial ray-transfer matrices and
//! exact 3D ray tracing through spherical surfaces.
//!
//! Sources:
//! - Walch 2017, sec. 4.1.3 "Optical System Description" (the surface table: radius, thickness,
//!   material, aperture; Figure 4.3) and sec. 4.2.1 "Ray Transfer Matrix" (translation
//!   T = [[1, d], [0, 1]] and refraction R = [[1, 0], [(n1 - n2)/(R n2), n1/n2]] acting on the
//!   column vector (height y, angle u); the printed "d" in the refraction matrix's upper right is
//!   a typo, a refraction does not move the ray).
//! - Kyaw 2013, ch. 6: the aberrations, and eq. 6.8 for distortion D = 100 (R - r)/r percent.
//!
//! Conventions: light travels towards +z. The first surface's vertex is at z = 0; every `_z_mm`
//! is an axial position in that frame. A radius is positive when the centre of curvature lies
//! behind the vertex (+z); 0 or infinite is a flat surface. `n_d` is the index of the medium
//! after a surface; object space is air (n = 1). The last surface's thickness is the distance
//! from it to the image plane given in the table. Field angles are in the y-z (meridional)
//! plane; sagittal quantities are in x.
//!
//! Dispersion model: the index is linear in wavelength through the F, d and C lines,
//!     n(lambda) = n_d - (n_d - 1)/V_d * (lambda - lambda_d)/(lambda_C - lambda_F),
//! so that n_F - n_C = (n_d - 1)/V_d exactly (V_d = 0 means no dispersion, e.g. air).
//!
//! The module is split by layer of the analysis: `parse` reads and validates prescription
//! files, `paraxial` holds the ray-transfer matrices and first-order properties, `trace` the
//! exact ray tracing, and `analysis` the aberrations a trace finds and the lens-file tables
//! they imply (written by `crate::io::lens_file`, not here).

mod analysis;
mod paraxial;
mod parse;
mod trace;

pub use analysis::{
    cats_eye_from_transmission, circle_overlap_fraction, DerivedTables, FieldSample, LensAnalysis, LongitudinalColor,
    LsaSample,
};
pub use paraxial::{Paraxial, RayMatrix};
pub use parse::{toml_error, SurfaceSpec};
pub use trace::{Ray, RayFailure};

/// Fraunhofer F line (hydrogen, blue), nm.
pub const LAMBDA_F_NM: f64 = 486.1;
/// Fraunhofer d line (helium, yellow), nm: the reference wavelength.
pub const LAMBDA_D_NM: f64 = 587.6;
/// Fraunhofer C line (hydrogen, red), nm.
pub const LAMBDA_C_NM: f64 = 656.3;

/// One refracting (or stop) surface of a prescription.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Signed radius of curvature; 0 or infinite = flat.
    pub radius_mm: f64,
    /// Axial distance to the next surface (for the last one: to the image plane).
    pub thickness_mm: f64,
    /// Refractive index at the d line of the medium AFTER this surface; 1 for air.
    pub n_d: f64,
    /// Abbe number of that medium; 0 for air (no dispersion).
    pub v_d: f64,
    /// Clear semi-diameter (half the aperture) of this surface.
    pub semi_diameter_mm: f64,
    /// This surface is the aperture stop.
    pub stop: bool,
}

impl Surface {
    /// Curvature 1/R, 0 for a flat surface.
    pub fn curvature_per_mm(&self) -> f64 {
        if self.radius_mm == 0.0 || self.radius_mm.is_infinite() {
            0.0
        } else {
            1.0 / self.radius_mm
        }
    }

    /// Index of the medium after this surface at `lambda_nm` (linear F-d-C model).
    pub fn index_at(&self, lambda_nm: f64) -> f64 {
        index_at(self.n_d, self.v_d, lambda_nm)
    }
}

/// Index at `lambda_nm` from n_d and V_d, linear in wavelength through F, d and C.
pub fn index_at(n_d: f64, v_d: f64, lambda_nm: f64) -> f64 {
    if v_d <= 0.0 || n_d == 1.0 {
        return n_d;
    }
    n_d - (n_d - 1.0) / v_d * (lambda_nm - LAMBDA_D_NM) / (LAMBDA_C_NM - LAMBDA_F_NM)
}

/// A lens as a list of surfaces, front (object side) first.
#[derive(Debug, Clone, PartialEq)]
pub struct Prescription {
    pub name: String,
    pub surfaces: Vec<Surface>,
}

/// The most surfaces a prescription may have: twice the most of any photographic lens (a zoom
/// has 40-60); beyond it the work of the flare's ghosts (pairs of surfaces) has no useful bound.
pub const MAX_SURFACES: usize = 128;

/// Errors reading or validating a prescription.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PrescriptionError {
    #[error("{path}:{line}: TOML error: {message}")]
    Toml { path: String, line: usize, message: String },
    #[error("{path}: the prescription has no [[surface]] tables")]
    NoSurfaces { path: String },
    /// More surfaces than any lens has ([`MAX_SURFACES`]): the ghosts' catalogue grows as the
    /// square of the count (a lens file of 1,000 surfaces took 60 s and 1.45 GB, issue 34).
    #[error("{path}: the prescription has {count} [[surface]] tables; realcam takes at most {max} (a photographic lens has under 60)")]
    TooManySurfaces { path: String, count: usize, max: usize },
    #[error("{path}:{line}: surface {index}: {message}")]
    InvalidSurface { path: String, line: usize, index: usize, message: String },
    #[error(
        "{path}: exactly one surface must have stop = true, found {} (surfaces {indices:?})",
        indices.len()
    )]
    StopCount { path: String, indices: Vec<usize> },
}

impl Prescription {
    /// Index of the stop surface (validated prescriptions have exactly one; else 0).
    pub fn stop_index(&self) -> usize {
        self.surfaces.iter().position(|s| s.stop).unwrap_or(0)
    }

    /// Vertex z of every surface.
    pub fn vertex_z_mm(&self) -> Vec<f64> {
        let mut z = 0.0;
        self.surfaces
            .iter()
            .map(|s| {
                let here = z;
                z += s.thickness_mm;
                here
            })
            .collect()
    }

    /// Index of the medium before surface `i` at `lambda_nm`.
    fn index_before(&self, i: usize, lambda_nm: f64) -> f64 {
        if i == 0 {
            1.0
        } else {
            self.surfaces[i - 1].index_at(lambda_nm)
        }
    }
}

/// Lenses shared by the tests of the submodules.
#[cfg(test)]
mod test_lenses {
    use super::*;

    pub(super) fn surf(radius_mm: f64, thickness_mm: f64, n_d: f64, sd: f64, stop: bool) -> Surface {
        Surface { radius_mm, thickness_mm, n_d, v_d: if n_d > 1.0 { 60.0 } else { 0.0 }, semi_diameter_mm: sd, stop }
    }

    /// Biconvex R1 = +50, R2 = -50, d = 10, n = 1.5, stop on the first surface.
    pub(super) fn thick_lens(d: f64) -> Prescription {
        Prescription {
            name: "biconvex".into(),
            surfaces: vec![surf(50.0, d, 1.5, 10.0, true), surf(-50.0, 50.0, 1.0, 10.0, false)],
        }
    }

    pub(super) fn walch() -> Prescription {
        let text = include_str!("../../../lenses/tessar-walch.toml");
        Prescription::parse_toml(text, "lenses/tessar-walch.toml").unwrap()
    }

    pub(super) fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }
}
