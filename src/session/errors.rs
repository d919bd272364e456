//! The library's errors name the fields they are about (`max_coc_px`, `f_number`); the user
//! set those with flags. [`FLAGS`] is the one table from field to flag, and [`NameFlags`]
//! shows a library error with the flag that sets its field.

use crate::io::lens_analysis::LensAnalysisError;
use crate::io::IoError;
use crate::model::camera::{CameraError, CameraField};
use anyhow::anyhow;

/// The flag that sets each field a library error can name.
pub const FLAGS: [(&str, &str); 36] = [
    ("focal_length_mm", "--focal-length"),
    ("f_number", "--fstop"),
    ("focus_distance_m", "--focus"),
    ("shutter_s", "--shutter"),
    ("iso", "--iso"),
    ("nits_per_unit", "--nits-per-unit"),
    ("blades", "--blades"),
    ("blade_curvature", "--blade-curvature"),
    ("spherical_aberration", "--spherical-aberration"),
    ("cats_eye", "--cats-eye"),
    ("max_coc", "--max-coc"),
    ("grain", "--grain"),
    ("flare_threshold", "--flare-threshold"),
    ("flare_lights", "--flare-light"),
    ("force", "--force"),
    ("depth_unit_m", "--depth-unit"),
    ("tables_path", "--write-tables"),
    ("distance_m", "--distance-m"),
    ("f_number_min", "--f-number-min"),
    ("focus_min_m", "--focus-min-m"),
    ("sensor_diagonal_mm", "--sensor-diagonal-mm"),
    ("output", "--output"),
    ("out", "--out"),
    ("png", "--png"),
    ("trace", "--trace"),
    ("state", "--state"),
    ("max_pixels", "--max-pixels"),
    ("blade_rotation_deg", "--blade-rotation"),
    ("fps", "--fps"),
    ("shutter_angle_deg", "--shutter-angle"),
    ("shutter_ramp", "--shutter-curve"),
    ("rolling_shutter_s", "--rolling-shutter"),
    ("max_blur_px", "--max-blur"),
    ("velocity_scale", "--velocity-scale"),
    ("velocity_interval_frames", "--velocity-interval"),
    ("velocity_format", "--velocity-format"),
];

/// The flag of a library field (the field's own name if it has none).
pub fn flag(field: &str) -> &str {
    FLAGS.iter().find(|(f, _)| *f == field).map_or(field, |(_, flag)| flag)
}

/// A library error that names the field it is about.
pub trait FieldError: std::error::Error + Send + Sync + 'static {
    fn field_name(&self) -> Option<&'static str>;

    /// The field that would let the refused value through, if one would.
    fn overridden_by(&self) -> Option<&'static str> {
        None
    }
}

impl FieldError for CameraError {
    fn field_name(&self) -> Option<&'static str> {
        self.field().map(CameraField::name)
    }

    fn overridden_by(&self) -> Option<&'static str> {
        matches!(self, CameraError::OutOfRange { .. }).then_some("force")
    }
}

/// A shot's camera names the flag of the refused setting only when a flag gave it; a key's or
/// an input header's says where it came from instead.
impl FieldError for crate::model::camera::ShotError {
    fn field_name(&self) -> Option<&'static str> {
        if self.from.is_some() {
            None
        } else {
            self.error.field_name()
        }
    }

    fn overridden_by(&self) -> Option<&'static str> {
        self.error.overridden_by()
    }
}

impl FieldError for IoError {
    fn field_name(&self) -> Option<&'static str> {
        self.field()
    }
}

impl FieldError for crate::io::lensfun::LensfunError {
    fn field_name(&self) -> Option<&'static str> {
        self.field()
    }
}

impl FieldError for crate::model::aperture::ApertureMaskError {
    fn field_name(&self) -> Option<&'static str> {
        self.field()
    }
}

impl FieldError for LensAnalysisError {
    fn field_name(&self) -> Option<&'static str> {
        self.field()
    }
}

/// `result.name_flags()?`: a library error as the command line shows it, with the flag of the
/// field it names: `ISO must be a positive number, got -5 (--iso)`, or for a setting outside
/// the lens's range `...; pass --force to use it anyway`.
pub trait NameFlags<T> {
    fn name_flags(self) -> anyhow::Result<T>;
}

impl<T, E: FieldError> NameFlags<T> for Result<T, E> {
    fn name_flags(self) -> anyhow::Result<T> {
        self.map_err(|e| match (e.overridden_by(), e.field_name()) {
            (Some(by), _) => anyhow!("{e}; pass {} to use it anyway", flag(by)),
            (None, Some(field)) => anyhow!("{:#} ({})", anyhow::Error::from(e), flag(field)),
            (None, None) => e.into(),
        })
    }
}

/// An error and its causes, each said once: a cause whose text the message already holds
/// (an error that prints its source, as io and exr errors do) is left out.
pub fn error_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if s.is_empty() || text.contains(&s) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&s);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_show_the_flag() {
        let lens = crate::io::lens_file::LensFile::default_lens();
        let camera = |req| crate::model::camera::Camera::new(&lens, &req).name_flags().map(|_| ()).unwrap_err();
        let req = crate::model::camera::CameraRequest {
            max_coc: crate::model::camera::CocLimit::Px(-1.0),
            ..Default::default()
        };
        assert_eq!(
            camera(req).to_string(),
            "maximum CoC diameter must be a diameter >= 0 (px, or mm on the film), got -1 (--max-coc)"
        );
        let req = crate::model::camera::CameraRequest { f_number: Some(1.0), ..Default::default() };
        assert_eq!(
            camera(req).to_string(),
            "f/1 is outside what the lens \"realcam standard 50 mm f/1.4\" allows (f/1.4 to f/16); \
             pass --force to use it anyway"
        );
        let passes = crate::io::PassSources { depth_unit_m: 0.0, ..crate::io::PassSources::new("c.exr") };
        let err = crate::io::load_passes(&passes).name_flags().map(|_| ()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "depth_unit_m must be a positive number of metres per depth unit, got 0 (--depth-unit)"
        );
    }
}
