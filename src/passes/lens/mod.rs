//! The lens's aberrations of the image and its light falloff: longitudinal colour, distortion,
//! astigmatism, coma and vignetting, a pass each. README.md says what each simulates.

pub mod astigmatism;
pub mod coma;
pub mod distortion;
pub mod longitudinal_color;
pub mod vignette;
