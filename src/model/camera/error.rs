//! Why a camera request was refused, and the request's fields as messages name them.

use crate::optics::{Num, OpticsError};

/// Why [`Camera::new`](super::Camera::new) refused a request. A refused setting is named by
/// its field, with the value and what is allowed.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    #[error(transparent)]
    Optics(#[from] OpticsError),
    /// A setting the lens does not allow; [`CameraRequest::force`](super::CameraRequest::force)
    /// lets it through.
    #[error("{} is outside what the lens {lens:?} allows ({allowed})", .field.quantity(*.value))]
    OutOfRange { field: CameraField, value: f64, lens: String, allowed: String },
    /// A setting no camera takes.
    #[error("{} must be {allowed}, got {}", .field.label(), Num(*.value))]
    Invalid { field: CameraField, value: f64, allowed: &'static str },
    /// A setting whose result (the exposure's gain, the grain's spread) no 32-bit float holds
    /// within `limit`: the output could not be finite.
    #[error("{} makes the {what} {}, more than {}: the output cannot be finite; with the other settings as they are, it must be {} {}",
        .field.quantity(*.value), Num(*.result), Num(*.limit), .bound_word, .field.quantity(*.bound))]
    Overflow {
        field: CameraField,
        value: f64,
        what: &'static str,
        result: f64,
        limit: f64,
        bound_word: &'static str,
        bound: f64,
    },
}

impl CameraError {
    /// The request's field the error is about; None for an optics error.
    pub fn field(&self) -> Option<CameraField> {
        match self {
            CameraError::Optics(_) => None,
            CameraError::OutOfRange { field, .. }
            | CameraError::Invalid { field, .. }
            | CameraError::Overflow { field, .. } => Some(*field),
        }
    }
}

/// A field of [`CameraRequest`](super::CameraRequest) that [`Camera::new`](super::Camera::new)
/// checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CameraField {
    FocalLengthMm,
    FNumber,
    FocusDistanceM,
    ShutterS,
    Iso,
    NitsPerUnit,
    Blades,
    SphericalAberration,
    CatsEye,
    MaxCoc,
    Grain,
    BladeRotationDeg,
    BladeCurvature,
    Fps,
    ShutterAngleDeg,
    ShutterRamp,
    RollingShutterS,
    MaxBlurPx,
    FlareThreshold,
    FlareLight,
}

impl CameraField {
    pub const ALL: [CameraField; 20] = [
        CameraField::FocalLengthMm,
        CameraField::FNumber,
        CameraField::FocusDistanceM,
        CameraField::ShutterS,
        CameraField::Iso,
        CameraField::NitsPerUnit,
        CameraField::Blades,
        CameraField::SphericalAberration,
        CameraField::CatsEye,
        CameraField::MaxCoc,
        CameraField::Grain,
        CameraField::BladeRotationDeg,
        CameraField::BladeCurvature,
        CameraField::Fps,
        CameraField::ShutterAngleDeg,
        CameraField::ShutterRamp,
        CameraField::RollingShutterS,
        CameraField::MaxBlurPx,
        CameraField::FlareThreshold,
        CameraField::FlareLight,
    ];

    /// The field's name in [`CameraRequest`](super::CameraRequest).
    pub fn name(self) -> &'static str {
        match self {
            CameraField::FocalLengthMm => "focal_length_mm",
            CameraField::FNumber => "f_number",
            CameraField::FocusDistanceM => "focus_distance_m",
            CameraField::ShutterS => "shutter_s",
            CameraField::Iso => "iso",
            CameraField::NitsPerUnit => "nits_per_unit",
            CameraField::Blades => "blades",
            CameraField::SphericalAberration => "spherical_aberration",
            CameraField::CatsEye => "cats_eye",
            CameraField::MaxCoc => "max_coc",
            CameraField::Grain => "grain",
            CameraField::BladeRotationDeg => "blade_rotation_deg",
            CameraField::BladeCurvature => "blade_curvature",
            CameraField::Fps => "fps",
            CameraField::ShutterAngleDeg => "shutter_angle_deg",
            CameraField::ShutterRamp => "shutter_ramp",
            CameraField::RollingShutterS => "rolling_shutter_s",
            CameraField::MaxBlurPx => "max_blur_px",
            CameraField::FlareThreshold => "flare_threshold",
            CameraField::FlareLight => "flare_lights",
        }
    }

    /// The setting in words, as messages name it.
    pub fn label(self) -> &'static str {
        match self {
            CameraField::FocalLengthMm => "focal length",
            CameraField::FNumber => "f-number",
            CameraField::FocusDistanceM => "focus distance",
            CameraField::ShutterS => "shutter time",
            CameraField::Iso => "ISO",
            CameraField::NitsPerUnit => "nits per unit",
            CameraField::Blades => "number of aperture blades",
            CameraField::SphericalAberration => "spherical aberration",
            CameraField::CatsEye => "cat's eye",
            CameraField::MaxCoc => "maximum CoC diameter",
            CameraField::Grain => "grain",
            CameraField::BladeRotationDeg => "aperture rotation",
            CameraField::BladeCurvature => "blade curvature",
            CameraField::Fps => "frame rate",
            CameraField::ShutterAngleDeg => "shutter angle",
            CameraField::ShutterRamp => "shutter curve ramp",
            CameraField::RollingShutterS => "rolling-shutter readout time",
            CameraField::MaxBlurPx => "largest motion blur",
            CameraField::FlareThreshold => "flare threshold",
            CameraField::FlareLight => "a flare light's numbers",
        }
    }

    /// A value of this setting in words, with its unit: `f/2.8`, `focus distance 0.3 m`.
    pub fn quantity(self, value: f64) -> String {
        let value = Num(value);
        let unit = match self {
            CameraField::FNumber => return format!("f/{value}"),
            CameraField::FocalLengthMm => " mm",
            CameraField::FocusDistanceM => " m",
            CameraField::ShutterS => " s",
            CameraField::BladeRotationDeg => " deg",
            _ => "",
        };
        format!("{} {value}{unit}", self.label())
    }
}
