//! One `<lens>` of the database: its distortion, TCA and vignetting calibrations and the
//! sensor they were made on.

use super::{Location, FULL_FRAME_DIAGONAL_MM};

/// A distortion model (lensfun.h.in, mod-coord.cpp).
#[derive(Clone, Debug, PartialEq)]
pub enum DistortionModel {
    Poly3 {
        k1: f64,
    },
    Poly5 {
        k1: f64,
        k2: f64,
    },
    Ptlens {
        a: f64,
        b: f64,
        c: f64,
    },
    /// A model realcam does not know (rejected when the lens is imported).
    Unknown(String),
}

impl DistortionModel {
    /// r_d / r_u - 1 at undistorted radius `r` (in the model's unit), from the model equations
    /// in the module documentation, each rearranged so that r = 1 gives exactly 0 for poly3
    /// and ptlens (poly3: k1 (r^2 - 1); ptlens: a (r^3 - 1) + b (r^2 - 1) + c (r - 1)).
    pub fn excess(&self, r: f64) -> f64 {
        match *self {
            DistortionModel::Poly3 { k1 } => k1 * (r * r - 1.0),
            DistortionModel::Poly5 { k1, k2 } => k1 * r * r + k2 * r.powi(4),
            DistortionModel::Ptlens { a, b, c } => a * (r.powi(3) - 1.0) + b * (r * r - 1.0) + c * (r - 1.0),
            DistortionModel::Unknown(_) => 0.0,
        }
    }

    pub(super) fn describe(&self) -> String {
        match self {
            DistortionModel::Poly3 { k1 } => format!("poly3 k1 = {k1}: r_d = r_u (1 - k1 + k1 r_u^2)"),
            DistortionModel::Poly5 { k1, k2 } => {
                format!("poly5 k1 = {k1}, k2 = {k2}: r_d = r_u (1 + k1 r_u^2 + k2 r_u^4)")
            }
            DistortionModel::Ptlens { a, b, c } => {
                format!("ptlens a = {a}, b = {b}, c = {c}: r_d = r_u (a r_u^3 + b r_u^2 + c r_u + 1 - a - b - c)")
            }
            DistortionModel::Unknown(m) => format!("unknown model {m:?}"),
        }
    }
}

/// A transverse-chromatic-aberration model (lensfun.h.in, mod-color.cpp): the red and blue
/// radius relative to the green one.
#[derive(Clone, Debug, PartialEq)]
pub enum TcaModel {
    Linear { kr: f64, kb: f64 },
    Poly3 { vr: f64, cr: f64, br: f64, vb: f64, cb: f64, bb: f64 },
    Unknown(String),
}

impl TcaModel {
    /// The factors (red, blue) on the green radius `r` (in the model's unit).
    pub fn factors(&self, r: f64) -> (f64, f64) {
        match *self {
            TcaModel::Linear { kr, kb } => (kr, kb),
            TcaModel::Poly3 { vr, cr, br, vb, cb, bb } => (br * r * r + cr * r + vr, bb * r * r + cb * r + vb),
            TcaModel::Unknown(_) => (1.0, 1.0),
        }
    }

    pub(super) fn describe(&self) -> String {
        match self {
            TcaModel::Linear { kr, kb } => format!("linear kr = {kr}, kb = {kb}: r_R = kr r, r_B = kb r"),
            TcaModel::Poly3 { vr, cr, br, vb, cb, bb } => format!(
                "poly3 vr = {vr}, cr = {cr}, br = {br}, vb = {vb}, cb = {cb}, bb = {bb}: \
                 r_R = r (br r^2 + cr r + vr), r_B = r (bb r^2 + cb r + vb)"
            ),
            TcaModel::Unknown(m) => format!("unknown model {m:?}"),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Distortion {
    pub focal_mm: f64,
    pub model: DistortionModel,
    pub at: Location,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Tca {
    pub focal_mm: f64,
    pub model: TcaModel,
    pub at: Location,
}

/// One vignetting calibration, model `pa` (others are kept as `model` and rejected on import).
#[derive(Clone, Debug, PartialEq)]
pub struct Vignetting {
    pub focal_mm: f64,
    pub f_number: f64,
    /// Focus distance of the calibration in m; lensfun writes 1000 for infinity.
    pub distance_m: f64,
    pub model: String,
    pub k1: f64,
    pub k2: f64,
    pub k3: f64,
    pub at: Location,
}

impl Vignetting {
    /// Relative illumination at radius `r` (1 = half the calibration sensor's diagonal):
    /// 1 + k1 r^2 + k2 r^4 + k3 r^6 (lensfun's pa model).
    pub fn relative_illumination(&self, r: f64) -> f64 {
        let r2 = r * r;
        1.0 + self.k1 * r2 + self.k2 * r2 * r2 + self.k3 * r2 * r2 * r2
    }
}

/// One `<lens>` of the database.
#[derive(Clone, Debug, PartialEq)]
pub struct LensEntry {
    pub maker: String,
    /// The first `<model>` without a `lang` attribute.
    pub model: String,
    /// Further `<model>`s without `lang` (other names of the same lens).
    pub model_aliases: Vec<String>,
    /// The translated `<model lang="..">` names.
    pub model_translations: Vec<String>,
    pub mounts: Vec<String>,
    pub crop_factor: Option<f64>,
    /// Long side / short side of the calibration sensor.
    pub aspect_ratio: f64,
    /// `<type>`, rectilinear when absent.
    pub lens_type: String,
    /// `<focal min max>` or `<focal value>`: (min, max) in mm.
    pub focal_range_mm: Option<(f64, f64)>,
    /// `<aperture min>`: the widest f-number.
    pub f_number_min: Option<f64>,
    /// `<aperture max>`: the smallest aperture's f-number.
    pub f_number_max: Option<f64>,
    /// `<center x y>`: the optical centre's offset (not used: realcam's tables are centred).
    pub center: Option<(f64, f64)>,
    pub distortion: Vec<Distortion>,
    pub tca: Vec<Tca>,
    pub vignetting: Vec<Vignetting>,
    /// XML comments inside `<calibration>` (e.g. "Taken with Nikon D90").
    pub calibration_notes: Vec<String>,
    pub at: Location,
}

impl LensEntry {
    /// The calibration sensor (from the crop factor and aspect ratio), if the entry has a crop factor.
    pub fn calibration_sensor(&self) -> Option<CalibrationSensor> {
        self.crop_factor.map(|crop_factor| CalibrationSensor { crop_factor, aspect_ratio: self.aspect_ratio })
    }

    pub(super) fn file_name(&self) -> String {
        self.at.path.file_name().map_or_else(|| self.at.path.display().to_string(), |n| n.to_string_lossy().into())
    }
}

/// The sensor a lensfun calibration was made on, which sets the unit of the model radii.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationSensor {
    pub crop_factor: f64,
    pub aspect_ratio: f64,
}

impl CalibrationSensor {
    /// r = 1 of the distortion and TCA models: half the shorter side,
    /// hypot(36, 24) / cropfactor / hypot(aspect, 1) / 2 mm (lensfun mod-coord.cpp).
    pub fn half_short_side_mm(&self) -> f64 {
        FULL_FRAME_DIAGONAL_MM / self.crop_factor / self.aspect_ratio.hypot(1.0) / 2.0
    }

    /// r = 1 of the vignetting model: half the diagonal, hypot(36, 24) / cropfactor / 2 mm
    /// (lensfun mod-color.cpp). Also the edge of the calibrated field.
    pub fn half_diagonal_mm(&self) -> f64 {
        FULL_FRAME_DIAGONAL_MM / self.crop_factor / 2.0
    }
}
