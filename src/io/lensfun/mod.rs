//! Lens files from the lensfun database (<https://lensfun.github.io>, XML in
//! `/usr/share/lensfun/version_1`, Debian package liblensfun-data-v1): a lens's distortion,
//! transverse chromatic aberration (lateral colour) and vignetting calibrations, converted into
//! the tables of a realcam lens file (src/io/lens_file.rs) against image height in mm.
//!
//! The models, as lensfun defines them (lensfun include/lensfun/lensfun.h.in,
//! libs/lensfun/mod-coord.cpp, mod-color.cpp, database.cpp). Every model describes the lens,
//! i.e. maps the undistorted (ideal) radius r_u to the distorted (real) one r_d:
//! - distortion `poly3`: r_d = r_u (1 - k1 + k1 r_u^2); `poly5`: r_d = r_u (1 + k1 r_u^2 +
//!   k2 r_u^4); `ptlens`: r_d = r_u (a r_u^3 + b r_u^2 + c r_u + 1 - a - b - c); missing terms
//!   are 0.
//! - TCA, the red and the blue radius relative to the green one: `linear`: r_R = kr r,
//!   r_B = kb r; `poly3`: r_R = r (br r^2 + cr r + vr), the same for blue with bb, cb, vb
//!   (v defaults to 1, the others to 0).
//! - vignetting `pa`: the relative illumination is 1 + k1 r^2 + k2 r^4 + k3 r^6.
//! - For distortion and TCA, r = 1 is half the SHORTER side of the calibration sensor:
//!   hypot(36, 24) / cropfactor / hypot(aspect, 1) / 2 mm, with the lens's `<cropfactor>` and
//!   `<aspect-ratio>` (long/short, default 1.5). For vignetting, r = 1 is half the DIAGONAL:
//!   hypot(36, 24) / cropfactor / 2 mm.
//!
//! realcam's tables (src/optics/distortion.rs): distortion percent at each ideal height h is
//! Kyaw 2013 eq 6.8, D = 100 (R - r) / r, with r the PARAXIAL ideal height, so D = 0 on the axis.
//! lensfun normalises its models to keep r_u = 1 fixed instead: near the axis
//! r_d = d0 r_u with d0 = 1 - k1 (poly3), 1 - a - b - c (ptlens), 1 (poly5), which is why
//! lensfun's "real focal length" is d0 times the nominal one. The paraxial ideal height is
//! therefore h = d0 r_u (in the model's unit), and D(h) = 100 (r_d / (d0 r_u) - 1). The
//! lateral-colour tables are the extra percent of red and blue over green at the same h.

use crate::io::lens_file::{number_text, IlluminationAt, LensFile, LensFileError, LensFileWriter, LensTables};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

mod calibration;
mod convert;
mod database;
mod parse;
mod write;

pub use calibration::{CalibrationSensor, Distortion, DistortionModel, LensEntry, Tca, TcaModel, Vignetting};
use convert::{convert, positive, Selection, Settings, Tables};
pub use database::Database;
pub use parse::{f_number_from_model, focal_length_from_model};
use parse::{parse_lens, LineIndex};
use write::lens_file_text;

/// Where lensfun's Debian package puts its database.
pub const DEFAULT_DIR: &str = "/usr/share/lensfun/version_1";
/// Environment variable that overrides [`DEFAULT_DIR`].
pub const DIR_ENV: &str = "REALCAM_LENSFUN_DIR";
/// The diagonal of the 36 x 24 mm frame, the reference of lensfun's crop factors.
pub const FULL_FRAME_DIAGONAL_MM: f64 = 43.266_615_305_567_875; // hypot(36, 24)
/// Heights sampled from 0 to the target sensor's half diagonal (plus r = 1 of the models and
/// the edge of the calibrated field when they fall inside).
pub const HEIGHT_SAMPLES: usize = 17;
/// lensfun's default aspect ratio of the calibration sensor (long side / short side), 3:2.
pub const DEFAULT_ASPECT_RATIO: f64 = 1.5;
/// Extrapolated relative illumination is kept at or above this (a lens file needs (0, 2]).
const MIN_RELATIVE_ILLUMINATION: f64 = 0.01;

#[derive(Debug, thiserror::Error)]
pub enum LensfunError {
    #[error(
        "lensfun database {dir}: cannot read it: {error}. Install lensfun's data (Debian package \
         liblensfun-data-v1, scripts/install-deps.sh) or point {DIR_ENV} at its version_1 folder"
    )]
    ReadDir { dir: PathBuf, error: std::io::Error },
    #[error(
        "lensfun database {dir}: no .xml files in it. Install lensfun's data (Debian package \
         liblensfun-data-v1, scripts/install-deps.sh) or point {DIR_ENV} at its version_1 folder"
    )]
    Empty { dir: PathBuf },
    #[error("lensfun file {path}: cannot read it: {error}")]
    ReadFile { path: PathBuf, error: std::io::Error },
    /// The XML is malformed, or an element or attribute has a value that cannot be read.
    #[error("lensfun file {path}, line {line}: {message}")]
    Xml { path: PathBuf, line: u32, message: String },
    #[error("lensfun: no lens {model:?} in {database}; {}", close_names(.close))]
    NotFound { model: String, database: String, close: Vec<String> },
    /// The lens is in the database but realcam cannot use it (a fisheye, an unknown model).
    #[error("lensfun lens {model:?} ({path}, line {line}): {message}")]
    Unsupported { model: String, path: PathBuf, line: u32, message: String },
    /// A number realcam needs is neither in the database nor given.
    #[error("lensfun lens {model:?}: {message}")]
    Missing { model: String, message: String },
    #[error("lensfun import: {name} = {value} must be a positive number")]
    BadOption { name: &'static str, value: f64 },
    /// The converted tables do not make a valid lens file (e.g. an extrapolated distortion
    /// beyond the lens-file range).
    #[error("lensfun lens {model:?}: the converted lens file is not valid: {error}{hint}")]
    Converted { model: String, error: LensFileError, hint: String },
}

impl LensfunError {
    /// The import option the error is about, if one is.
    pub fn field(&self) -> Option<&'static str> {
        match self {
            LensfunError::BadOption { name, .. } => Some(name),
            LensfunError::Converted { hint, .. } if !hint.is_empty() => Some("sensor_diagonal_mm"),
            _ => None,
        }
    }
}

fn close_names(close: &[String]) -> String {
    if close.is_empty() {
        "no model names are close to it".to_string()
    } else {
        format!("close model names: {}", close.iter().map(|m| format!("{m:?}")).collect::<Vec<_>>().join(", "))
    }
}

/// The database folder: `dir` if given, else `$REALCAM_LENSFUN_DIR`, else [`DEFAULT_DIR`].
pub fn database_dir(dir: Option<&Path>) -> PathBuf {
    match dir {
        Some(d) => d.to_path_buf(),
        None => std::env::var_os(DIR_ENV).map_or_else(|| PathBuf::from(DEFAULT_DIR), PathBuf::from),
    }
}

/// Where an element is in the database.
#[derive(Clone, Debug, PartialEq)]
pub struct Location {
    pub path: PathBuf,
    pub line: u32,
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}, line {}", self.path.display(), self.line)
    }
}

/// Settings of an import that lensfun does not give (or that choose among its calibrations).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// For a zoom: use the calibrations at the focal length nearest this; default the shortest.
    pub focal_length_mm: Option<f64>,
    /// Vignetting: per f-number, the calibration at the distance nearest this; default the farthest.
    pub distance_m: Option<f64>,
    /// The widest f-number, when neither `<aperture>` nor the model name gives it (overrides both).
    pub f_number_min: Option<f64>,
    /// Closest focus; default 10 focal lengths (an assumption, lensfun does not give it).
    pub focus_min_m: Option<f64>,
    /// Aperture blades; default 0 (circular, an assumption).
    pub blades: Option<u32>,
    /// The diagonal of the sensor the tables are for; default full frame, hypot(36, 24) mm.
    pub sensor_diagonal_mm: Option<f64>,
}

impl ImportOptions {
    /// Every number given must be finite and positive.
    pub fn check(&self) -> Result<(), LensfunError> {
        positive("focal_length_mm", self.focal_length_mm)?;
        positive("distance_m", self.distance_m)?;
        positive("f_number_min", self.f_number_min)?;
        positive("focus_min_m", self.focus_min_m)?;
        positive("sensor_diagonal_mm", self.sensor_diagonal_mm)?;
        Ok(())
    }
}

/// The result of an import.
#[derive(Clone, Debug)]
pub struct Imported {
    /// The lens file's text (TOML with comments saying where each number comes from).
    pub toml: String,
    /// The same, parsed.
    pub lens: LensFile,
    /// The database entry used.
    pub entry: LensEntry,
    /// The other entries of the same model (not used), e.g. calibrations on other crop factors.
    pub others: Vec<LensEntry>,
    /// What the import had to assume or extrapolate (also logged with log::warn).
    pub warnings: Vec<String>,
}

/// Imports `model` from the database in `dir` (see [`database_dir`]).
pub fn import(model: &str, options: &ImportOptions, dir: Option<&Path>) -> Result<Imported, LensfunError> {
    Database::load(&database_dir(dir))?.import(model, options)
}

/// The lens file of `model` (for `--lens-lensfun`).
pub fn import_lens_file(model: &str, options: &ImportOptions, dir: Option<&Path>) -> Result<LensFile, LensfunError> {
    Ok(import(model, options, dir)?.lens)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `<lens>` of crop factor `crop` with the extra elements and calibration given.
    fn lens(model: &str, crop: f64, extra: &str, calibration: &str) -> String {
        format!(
            "  <lens>\n    <maker>Test</maker>\n    <model>{model}</model>\n    <mount>Test Mount</mount>\n    \
             <cropfactor>{crop}</cropfactor>\n{extra}    <calibration>\n      <!-- Taken with a test body -->\n      \
             {calibration}\n    </calibration>\n  </lens>\n"
        )
    }

    fn database(lenses: &[String]) -> Database {
        let xml = format!("<lensdatabase version=\"1\">\n{}</lensdatabase>\n", lenses.concat());
        Database::from_xml(&[("test.xml", &xml)]).unwrap_or_else(|e| panic!("{e}"))
    }

    fn import_one(lens_xml: String, options: &ImportOptions) -> Imported {
        let db = database(&[lens_xml]);
        let model = db.lenses[0].model.clone();
        db.import(&model, options).unwrap_or_else(|e| panic!("{e}"))
    }

    /// The value of a table at a height that is one of the samples (to the 4 decimals written).
    fn sample(lens: &LensFile, values: impl Fn(&LensTables) -> Vec<f64>, height_mm: f64) -> f64 {
        let t = lens.tables.as_ref().expect("tables");
        let i = t
            .image_height_mm
            .iter()
            .position(|h| (h - height_mm).abs() < 1e-4)
            .unwrap_or_else(|| panic!("{height_mm} mm is not a sample of {:?}", t.image_height_mm));
        values(t)[i]
    }

    use crate::io::lens_file::LensTables;
    fn distortion(t: &LensTables) -> Vec<f64> {
        t.distortion_percent.clone().expect("distortion table")
    }
    fn red(t: &LensTables) -> Vec<f64> {
        t.lateral_color_red_percent.clone().expect("red table")
    }
    fn blue(t: &LensTables) -> Vec<f64> {
        t.lateral_color_blue_percent.clone().expect("blue table")
    }

    /// hypot(36, 24) / 2: the full frame's half diagonal.
    const FF_HALF_DIAGONAL_MM: f64 = 21.633_307_652_783_937;

    /// poly3 referred to the axis, worked by hand: with d0 = 1 - k1 and r = h / (d0 unit),
    /// D = 100 ((1 - k1 + k1 r^2) / d0 - 1) = 100 k1 r^2 / (1 - k1): pure h^2, 0 on the axis.
    fn poly3_percent(k1: f64, h_mm: f64, unit_mm: f64) -> f64 {
        let r = h_mm / ((1.0 - k1) * unit_mm);
        100.0 * k1 * r * r / (1.0 - k1)
    }

    #[test]
    fn poly3_distortion_is_100_k1_r2_minus_1() {
        let k1 = 0.01;
        // A 48 mm diagonal puts the last sample at 24 mm (r = 1 is 12 mm on full frame).
        let options = ImportOptions { sensor_diagonal_mm: Some(48.0), ..Default::default() };
        let imported = import_one(
            lens("Poly3 50mm f/2", 1.0, "", &format!("<distortion model=\"poly3\" focal=\"50\" k1=\"{k1}\"/>")),
            &options,
        );
        let l = &imported.lens;
        // On the axis: exactly 0 (Kyaw eq 6.8 is relative to the paraxial image).
        assert_eq!(sample(l, distortion, 0.0), 0.0);
        // lensfun's r_u = 1 lies at the paraxial height d0 x 12 mm, where r_d = r_u: the
        // image there is 1/d0 - 1 larger than the paraxial one.
        let d0 = 1.0 - k1;
        assert!((sample(l, distortion, 12.0 * d0) - 100.0 * (1.0 / d0 - 1.0)).abs() < 1e-5);
        let t = l.tables.as_ref().unwrap();
        for (h, d) in t.image_height_mm.iter().zip(distortion(t)) {
            assert!((d - poly3_percent(k1, *h, 12.0)).abs() < 2e-4, "h {h}: {d}");
        }
        // 24 mm is beyond the calibrated field (half the diagonal, 21.63 mm): said so.
        assert!(imported.warnings.iter().any(|w| w.contains("extrapolate")), "{:?}", imported.warnings);
        assert!(imported.toml.contains("# EXTRAPOLATED"), "{}", imported.toml);
        assert!(t.image_height_mm.iter().any(|h| (h - FF_HALF_DIAGONAL_MM).abs() < 1e-4));
    }

    #[test]
    fn ptlens_is_zero_at_r1_and_follows_the_formula() {
        let (a, b, c) = (0.01, -0.02, 0.005);
        let options = ImportOptions { sensor_diagonal_mm: Some(48.0), ..Default::default() };
        let xml = format!("<distortion model=\"ptlens\" focal=\"21\" a=\"{a}\" b=\"{b}\" c=\"{c}\"/>");
        let l = import_one(lens("Pt 21mm f/2.8", 1.0, "", &xml), &options).lens;
        // Referred to the axis (d0 = 1 - a - b - c, r = h / (12 d0)):
        // D = 100 (a r^3 + b r^2 + c r) / d0, 0 on the axis.
        let d0 = 1.0 - a - b - c;
        let expect = |h: f64| {
            let r = h / (12.0 * d0);
            100.0 * (a * r.powi(3) + b * r * r + c * r) / d0
        };
        assert_eq!(sample(&l, distortion, 0.0), 0.0);
        assert!((sample(&l, distortion, 24.0) - expect(24.0)).abs() < 1e-5);
        assert!((sample(&l, distortion, 12.0 * d0) - 100.0 * (1.0 / d0 - 1.0)).abs() < 1e-5);
        // No warning at full frame for a crop-1 calibration.
        let imported = import_one(lens("Pt 21mm f/2.8", 1.0, "", &xml), &ImportOptions::default());
        assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
        assert!(!imported.toml.contains("EXTRAPOLATED"));
    }

    #[test]
    fn poly5_model() {
        let m = DistortionModel::Poly5 { k1: 0.02, k2: -0.01 };
        assert!((m.excess(2.0) - (0.02 * 4.0 - 0.01 * 16.0)).abs() < 1e-15);
        assert_eq!(m.excess(0.0), 0.0);
    }

    #[test]
    fn crop_factor_scales_the_heights() {
        let k1 = -0.02;
        let xml = format!("<distortion model=\"poly3\" focal=\"50\" k1=\"{k1}\"/>");
        let full = import_one(lens("L 50mm f/2", 1.0, "", &xml), &ImportOptions::default());
        let crop = import_one(lens("L 50mm f/2", 1.5, "", &xml), &ImportOptions::default());
        // The same coefficients put r = 1 at 12 mm on crop 1 and at 8 mm on crop 1.5.
        let d0 = 1.0 - k1;
        assert!((sample(&full.lens, distortion, 12.0 * d0) - 100.0 * (1.0 / d0 - 1.0)).abs() < 1e-5);
        assert!((sample(&crop.lens, distortion, 8.0 * d0) - 100.0 * (1.0 / d0 - 1.0)).abs() < 1e-5);
        let corner = sample(&crop.lens, distortion, FF_HALF_DIAGONAL_MM);
        assert!((corner - poly3_percent(k1, FF_HALF_DIAGONAL_MM, 8.0)).abs() < 1e-5);
        // Crop 1.5 is calibrated to 14.42 mm: full frame beyond is extrapolated; crop 1 is not.
        assert!(crop.toml.contains("covers heights up to 14.42 mm"), "{}", crop.toml);
        assert!(full.warnings.is_empty());
        // The edge of the calibrated field is a sample.
        sample(&crop.lens, distortion, FULL_FRAME_DIAGONAL_MM / 1.5 / 2.0);
    }

    #[test]
    fn aspect_ratio_changes_the_unit() {
        let k1 = 0.01;
        let xml = format!("<distortion model=\"poly3\" focal=\"50\" k1=\"{k1}\"/>");
        let four_thirds = import_one(
            lens("L 50mm f/2", 1.0, "    <aspect-ratio>4:3</aspect-ratio>\n", &xml),
            &ImportOptions::default(),
        );
        // hypot(36, 24) / hypot(4/3, 1) / 2 = 43.267 / (5/3) / 2 = 12.98 mm.
        let unit_mm = FULL_FRAME_DIAGONAL_MM / (5.0 / 3.0) / 2.0;
        assert!((unit_mm - 12.98).abs() < 1e-3);
        let expect = poly3_percent(k1, FF_HALF_DIAGONAL_MM, unit_mm);
        assert!((sample(&four_thirds.lens, distortion, FF_HALF_DIAGONAL_MM) - expect).abs() < 1e-5);
        let on_full_frame = import_one(lens("L 50mm f/2", 1.0, "", &xml), &ImportOptions::default());
        assert!(sample(&on_full_frame.lens, distortion, FF_HALF_DIAGONAL_MM) > expect);
        // "1.5" and "3:2" are the default.
        let default = import_one(lens("L 50mm f/2", 1.0, "", &xml), &ImportOptions::default());
        for written in ["1.5", "3:2"] {
            let extra = format!("    <aspect-ratio>{written}</aspect-ratio>\n");
            let same = import_one(lens("L 50mm f/2", 1.0, &extra, &xml), &ImportOptions::default());
            assert_eq!(same.lens.tables, default.lens.tables, "{written}");
        }
    }

    #[test]
    fn tca_linear_is_a_constant_extra_percent() {
        let xml = "<tca model=\"linear\" focal=\"50\" kr=\"1.0005\" kb=\"0.9995\"/>";
        let l = import_one(lens("L 50mm f/2", 1.0, "", xml), &ImportOptions::default()).lens;
        let t = l.tables.as_ref().unwrap();
        assert!(t.distortion_percent.is_none());
        for (r, b) in red(t).iter().zip(blue(t)) {
            assert!((r - 0.05).abs() < 1e-9 && (b + 0.05).abs() < 1e-9, "{r} {b}");
        }
        // With distortion D the red image is kr times the green one: extra = 100 (kr - 1)(1 + D/100).
        let both = format!("{xml}\n<distortion model=\"poly3\" focal=\"50\" k1=\"0.05\"/>");
        let l = import_one(lens("L 50mm f/2", 1.0, "", &both), &ImportOptions::default()).lens;
        let t = l.tables.as_ref().unwrap();
        for ((r, d), h) in red(t).iter().zip(distortion(t)).zip(&t.image_height_mm) {
            assert!((r - 0.05 * (1.0 + d / 100.0)).abs() < 2e-5, "h {h}: {r} {d}");
        }
        // red real height = kr x green real height, at r = 0 (D = -5 %):
        let (red0, d0) = (red(t)[0], distortion(t)[0]);
        assert!(((1.0 + (d0 + red0) / 100.0) - 1.0005 * (1.0 + d0 / 100.0)).abs() < 1e-7);
    }

    #[test]
    fn tca_poly3_at_r1() {
        // k = br r^2 + cr r + vr; r is the green radius, r = 1 at 12 mm without distortion.
        let xml = "<tca model=\"poly3\" focal=\"50\" vr=\"1.0002\" cr=\"0.0001\" br=\"0.0003\" vb=\"0.9999\"/>";
        let l = import_one(lens("L 50mm f/2", 1.0, "", xml), &ImportOptions::default()).lens;
        assert!((sample(&l, red, 12.0) - 100.0 * (1.0002 + 0.0001 + 0.0003 - 1.0)).abs() < 1e-9);
        assert!((sample(&l, red, 0.0) - 0.02).abs() < 1e-9);
        assert!((sample(&l, blue, 12.0) - -0.01).abs() < 1e-9);
    }

    #[test]
    fn pa_vignetting_at_the_half_diagonal() {
        let (k1, k2, k3) = (-0.5, 0.1, -0.02);
        let xml = format!(
            "<vignetting model=\"pa\" focal=\"50\" aperture=\"2\" distance=\"1000\" k1=\"{k1}\" k2=\"{k2}\" k3=\"{k3}\"/>"
        );
        let l = import_one(lens("L 50mm f/2", 1.0, "", &xml), &ImportOptions::default()).lens;
        let t = l.tables.as_ref().unwrap();
        assert_eq!(t.vignetting.len(), 1);
        let v = &t.vignetting[0];
        assert_eq!(v.f_number, 2.0);
        assert_eq!(v.relative_illumination[0], 1.0);
        // r = 1 at half the diagonal: 1 + k1 + k2 + k3.
        let last = *v.relative_illumination.last().unwrap();
        assert!((last - (1.0 + k1 + k2 + k3)).abs() < 1e-9, "{last}");
        // r = 0.5 at a quarter of the diagonal (interpolated between samples: loose).
        let quarter = t.relative_illumination(2.0).unwrap().at(FF_HALF_DIAGONAL_MM / 2.0);
        let expect = 1.0 + k1 / 4.0 + k2 / 16.0 + k3 / 64.0;
        assert!((quarter - expect).abs() < 2e-3, "{quarter} vs {expect}");
        // On crop 1.5 the same coefficients reach 1 + k1 + k2 + k3 at its half diagonal.
        let crop = import_one(lens("L 50mm f/2", 1.5, "", &xml), &ImportOptions::default()).lens;
        let edge_mm = FULL_FRAME_DIAGONAL_MM / 1.5 / 2.0;
        let at = sample(&crop, |t| t.vignetting[0].relative_illumination.clone(), edge_mm);
        assert!((at - (1.0 + k1 + k2 + k3)).abs() < 1e-9);
    }

    #[test]
    fn zoom_uses_the_nearest_calibrated_focal_length() {
        let xml = "<distortion model=\"poly3\" focal=\"24\" k1=\"0.024\"/>\n\
                   <distortion model=\"poly3\" focal=\"35\" k1=\"0.035\"/>\n\
                   <distortion model=\"poly3\" focal=\"70\" k1=\"0.070\"/>";
        let zoom = lens("Zoom 24-70mm f/2.8", 1.0, "    <focal min=\"24\" max=\"70\"/>\n", xml);
        let db = database(&[zoom]);
        let at = |focal: Option<f64>| {
            let options = ImportOptions { focal_length_mm: focal, ..Default::default() };
            let l = db.import("Zoom 24-70mm f/2.8", &options).unwrap().lens;
            // D at the corner identifies the calibration used.
            (l.focal_length_mm, sample(&l, distortion, FF_HALF_DIAGONAL_MM))
        };
        let corner = |k1: f64| poly3_percent(k1, FF_HALF_DIAGONAL_MM, 12.0);
        let close = |(f, d): (f64, f64), (f0, k1): (f64, f64)| f == f0 && (d - corner(k1)).abs() < 1e-5;
        assert!(close(at(None), (24.0, 0.024))); // default: the shortest
        assert!(close(at(Some(50.0)), (35.0, 0.035))); // |50 - 35| < |50 - 70|: no interpolation
        assert!(close(at(Some(60.0)), (70.0, 0.070)));
        assert!(close(at(Some(200.0)), (70.0, 0.070)));
        let imported =
            db.import("Zoom 24-70mm f/2.8", &ImportOptions { focal_length_mm: Some(50.0), ..Default::default() });
        assert!(imported.unwrap().warnings.iter().any(|w| w.contains("nearest calibrated focal length, 35 mm")));
    }

    #[test]
    fn vignetting_entries_by_f_number_and_distance() {
        let v = |n: f64, d: f64, k1: f64| {
            format!("<vignetting model=\"pa\" focal=\"50\" aperture=\"{n}\" distance=\"{d}\" k1=\"{k1}\" k2=\"0\" k3=\"0\"/>\n")
        };
        // Written out of order; k1 = -(f-number)/100, minus 0.001 more at 1000 m.
        let xml = [
            v(8.0, 10.0, -0.08),
            v(8.0, 1000.0, -0.081),
            v(2.8, 1000.0, -0.029),
            v(2.8, 10.0, -0.028),
            v(4.0, 10.0, -0.04),
        ]
        .concat();
        let db = database(&[lens("L 50mm f/2.8", 1.0, "", &xml)]);
        let k1s = |distance_m: Option<f64>| {
            let options = ImportOptions { distance_m, ..Default::default() };
            let t = db.import("L 50mm f/2.8", &options).unwrap().lens.tables.unwrap();
            t.vignetting
                .iter()
                .map(|e| (e.f_number, ((e.relative_illumination.last().unwrap() - 1.0) * 1000.0).round() / 1000.0))
                .collect::<Vec<_>>()
        };
        // Increasing f-number; by default the farthest distance (f/4 has only 10 m).
        assert_eq!(k1s(None), vec![(2.8, -0.029), (4.0, -0.04), (8.0, -0.081)]);
        assert_eq!(k1s(Some(10.0)), vec![(2.8, -0.028), (4.0, -0.04), (8.0, -0.08)]);
        // 500 m is nearer 1000 m than 10 m in dioptres.
        assert_eq!(k1s(Some(500.0)), k1s(None));
    }

    #[test]
    fn model_names_match_with_comma_or_dot_case_and_spaces() {
        let xml = "<distortion model=\"poly3\" focal=\"50\" k1=\"0.01\"/>";
        let db = database(&[
            lens("Carl Zeiss Planar T* 1,4/50 ZF.2", 1.5, "", xml),
            lens("Carl Zeiss Planar T* 1,4/50 ZF.2", 1.0, "", xml),
            lens("Carl Zeiss Planar T* 1,4/50 ZE", 1.0, "", xml),
        ]);
        for query in [
            "Carl Zeiss Planar T* 1.4/50 ZF.2",
            "carl zeiss  planar t* 1,4/50 zf,2",
            "Test Carl Zeiss Planar T* 1.4/50 ZF.2",
        ] {
            let (entry, others) = db.find(query).unwrap_or_else(|e| panic!("{query}: {e}"));
            // The smallest crop factor, the largest calibrated field; the other one reported.
            assert_eq!((entry.model.as_str(), entry.crop_factor), ("Carl Zeiss Planar T* 1,4/50 ZF.2", Some(1.0)));
            assert_eq!(others.len(), 1);
            assert_eq!(others[0].crop_factor, Some(1.5));
        }
        let imported = db.import("Carl Zeiss Planar T* 1.4/50 ZF.2", &ImportOptions::default()).unwrap();
        assert!(
            imported.toml.contains("# Not used: the same model at test.xml, line 2 (crop factor 1.5)"),
            "{}",
            imported.toml
        );
        assert_eq!(imported.lens.f_number_min, 1.4);
        assert_eq!(imported.lens.name, "Carl Zeiss Planar T* 1,4/50 ZF.2");
        assert!(imported
            .lens
            .source
            .contains("test.xml (Test Mount, calibrated on crop factor 1, Taken with a test body)"));
    }

    #[test]
    fn unknown_model_lists_close_names() {
        let xml = "<distortion model=\"poly3\" focal=\"50\" k1=\"0.01\"/>";
        let db = database(&[
            lens("Carl Zeiss Planar T* 1,4/50 ZF.2", 1.0, "", xml),
            lens("Carl Zeiss Planar T* 1,4/50 ZE", 1.0, "", xml),
            lens("Canon EF 50mm f/1.4 USM", 1.0, "", xml),
        ]);
        let err = db.import("Planar T* 1.4/50", &ImportOptions::default()).unwrap_err();
        let LensfunError::NotFound { close, .. } = &err else { panic!("{err}") };
        assert_eq!(close, &["Carl Zeiss Planar T* 1,4/50 ZF.2", "Carl Zeiss Planar T* 1,4/50 ZE"]);
        let message = err.to_string();
        assert!(message.contains("no lens \"Planar T* 1.4/50\" in test.xml"), "{message}");
        assert!(message.contains("\"Carl Zeiss Planar T* 1,4/50 ZE\""), "{message}");
        // No substring: the names sharing the most words.
        let err = db.import("Canon 50mm f/1.4 II", &ImportOptions::default()).unwrap_err().to_string();
        assert!(err.contains("close model names: \"Canon EF 50mm f/1.4 USM\""), "{err}");
    }

    #[test]
    fn fisheye_is_rejected() {
        let xml = "<distortion model=\"ptlens\" focal=\"8\" a=\"0.01\"/>";
        let db = database(&[lens("Fish 8mm f/3.5", 1.0, "    <type>fisheye</type>\n", xml)]);
        let err = db.import("Fish 8mm f/3.5", &ImportOptions::default()).unwrap_err().to_string();
        assert!(
            err.contains("test.xml, line 2")
                && err.contains("its type is fisheye")
                && err.contains("rectilinear lenses only"),
            "{err}"
        );
    }

    #[test]
    fn malformed_xml_names_file_and_line() {
        let text = "<lensdatabase>\n  <lens>\n    <model>X</model>\n  </lense>\n</lensdatabase>\n";
        let err = Database::from_xml(&[("bad.xml", text)]).unwrap_err().to_string();
        assert!(err.starts_with("lensfun file bad.xml, line 4:"), "{err}");
        let text = "<lensdatabase>\n  <lens>\n    <model>X</model>\n    <cropfactor>1</cropfactor>\n    <calibration>\n      \
                    <distortion model=\"poly3\" focal=\"50\" k1=\"abc\"/>\n    </calibration>\n  </lens>\n</lensdatabase>\n";
        let err = Database::from_xml(&[("bad.xml", text)]).unwrap_err().to_string();
        assert_eq!(err, "lensfun file bad.xml, line 6: <distortion> k1 = \"abc\" is not a number");
    }

    #[test]
    fn f_number_and_focal_length_from_model_names() {
        for (model, n) in [
            ("Zeiss Otus 85mm f/1.4", Some(1.4)),
            ("Sony 50mm F1.4 ZA", Some(1.4)),
            ("Pentax SMC 1:2 50mm", Some(2.0)),
            ("Pentax 1:2.8 28mm", Some(2.8)),
            ("Carl Zeiss Planar T* 1,4/50 ZF.2", Some(1.4)),
            ("Carl Zeiss Planar T* 1.4/50", Some(1.4)),
            ("Carl Zeiss Distagon T* 2/35 ZF.2", Some(2.0)),
            ("Nikkor 18-55mm f/3.5-5.6G", Some(3.5)),
            ("XF35mmF1.4 R", Some(1.4)),
            ("XC16-50mmF3.5-5.6 OIS", Some(3.5)),
            ("Nikon F AF 50mm", None),
        ] {
            assert_eq!(f_number_from_model(model), n, "{model}");
        }
        for (model, f) in [
            ("Zeiss Otus 85mm f/1.4", Some(85.0)),
            ("Nikkor 18-55mm f/3.5-5.6G", Some(18.0)),
            ("Carl Zeiss Planar T* 1,4/50 ZF.2", Some(50.0)),
            ("Lens 50 mm", Some(50.0)),
            ("fixed lens", None),
        ] {
            assert_eq!(focal_length_from_model(model), f, "{model}");
        }
    }

    #[test]
    fn settings_lensfun_lacks_are_assumed_and_marked() {
        let xml = "<distortion model=\"poly3\" focal=\"35\" k1=\"0.01\"/>";
        let imported = import_one(lens("Plain 35mm f/2", 1.0, "", xml), &ImportOptions::default());
        let l = &imported.lens;
        assert_eq!((l.f_number_min, l.f_number_max, l.focus_min_m, l.aperture.blades), (2.0, 16.0, 0.35, 0));
        assert!(imported.toml.contains("# ASSUMED: 10 focal lengths"));
        assert!(imported.toml.contains("# ASSUMED: circular"));
        assert!(imported.toml.contains("# ASSUMED: f/16"));
        // <aperture> and the options win.
        let extra = "    <aperture min=\"1.8\" max=\"22\"/>\n";
        let options = ImportOptions { focus_min_m: Some(0.3), blades: Some(7), ..Default::default() };
        let l = import_one(lens("Plain 35mm f/2", 1.0, extra, xml), &options).lens;
        assert_eq!((l.f_number_min, l.f_number_max, l.focus_min_m, l.aperture.blades), (1.8, 22.0, 0.3, 7));
        // No f-number anywhere: an error naming the option, unless given.
        let db = database(&[lens("Nameless 35mm", 1.0, "", xml)]);
        let err = db.import("Nameless 35mm", &ImportOptions::default()).unwrap_err().to_string();
        assert!(err.contains("--f-number-min"), "{err}");
        let options = ImportOptions { f_number_min: Some(2.5), ..Default::default() };
        assert_eq!(db.import("Nameless 35mm", &options).unwrap().lens.f_number_min, 2.5);
        let options = ImportOptions { focus_min_m: Some(-1.0), ..Default::default() };
        let err = db.import("Nameless 35mm", &options).unwrap_err().to_string();
        assert!(err.contains("focus_min_m = -1 must be a positive number"), "{err}");
    }

    #[test]
    fn the_written_file_marks_assumptions_above_their_keys_and_reads_back() {
        let (k1, xml) = (0.01, "<distortion model=\"poly3\" focal=\"35\" k1=\"0.01\"/>");
        let imported = import_one(lens("Plain 35mm f/2", 1.0, "", xml), &ImportOptions::default());
        let text = &imported.toml;
        assert!(text.starts_with(
            "# Converted from the lensfun database by `realcam lens import-lensfun \"Plain 35mm f/2\"`.\n"
        ));
        for marked in [
            "# from the model name (lensfun has no <aperture>)\nf_number_min = 2.0\n",
            "# ASSUMED: f/16 (or f_number_min if larger); lensfun gives no smallest aperture\nf_number_max = 16.0\n",
            "# ASSUMED: 10 focal lengths; lensfun does not give the closest focus\nfocus_min_m = 0.35\n",
            "[aperture]\n# ASSUMED: circular; lensfun does not give the blade count\nblades = 0\n",
        ] {
            assert!(text.contains(marked), "{marked:?} not in\n{text}");
        }
        // Read back: the heights to 4 decimals, the percentages to 5 (not to 17 digits): D at the
        // height before it was rounded (within 0.5e-4 mm, D' = 2 D / h for D ~ h^2), rounded.
        let t = imported.lens.tables.as_ref().expect("tables");
        let d = t.distortion_percent.as_ref().expect("distortion");
        for (h, d) in t.image_height_mm.iter().zip(d) {
            assert_eq!((*h, *d), ((h * 1e4).round() / 1e4, (d * 1e5).round() / 1e5));
            let expect = poly3_percent(k1, *h, 12.0);
            let slack = 2.0 * expect / h.max(1.0) * 0.5e-4;
            assert!((d - expect).abs() <= 0.5e-5 + slack + 1e-12, "{h}: {d} vs {expect}");
        }
        assert!(text.contains(&format!("image_height_mm = [0.0, {}, ", t.image_height_mm[1])), "{text}");
        // Edited without changes, the file is the same text.
        assert_eq!(LensFileWriter::edit(text).unwrap().finish(), *text);
    }

    #[test]
    fn invalid_conversion_is_an_error_not_a_bad_file() {
        // 50 % distortion is beyond what a lens file accepts.
        let xml = "<distortion model=\"poly3\" focal=\"50\" k1=\"0.6\"/>";
        let db = database(&[lens("Wild 50mm f/2", 1.0, "", xml)]);
        let err = db.import("Wild 50mm f/2", &ImportOptions::default()).unwrap_err();
        assert!(matches!(err, LensfunError::Converted { .. }), "{err}");
        assert!(err.to_string().contains("distortion_percent"), "{err}");
        // A small-sensor calibration extrapolated to full frame: the error says what to give.
        let xml = "<distortion model=\"poly3\" focal=\"6\" k1=\"0.05\"/>";
        let db = database(&[lens("Compact 6mm f/2", 5.0, "", xml)]);
        let err = db.import("Compact 6mm f/2", &ImportOptions::default()).unwrap_err().to_string();
        assert!(err.contains("sensor_diagonal_mm (the calibration sensor's is 8.65 mm)"), "{err}");
        let options = ImportOptions { sensor_diagonal_mm: Some(8.65), ..Default::default() };
        assert!(db.import("Compact 6mm f/2", &options).is_ok());
    }

    #[test]
    fn a_lens_with_two_names_is_found_by_either() {
        let xml = "<distortion model=\"poly3\" focal=\"10\" k1=\"0.01\"/>";
        let entry = lens(
            "Zoom 10-20mm f/4.5 VR 168",
            1.5,
            "    <model>Zoom 10-20mm f/4.5 VR</model>\n    <model lang=\"de\">Zoomobjektiv</model>\n",
            xml,
        );
        let db = database(&[entry]);
        for name in ["Zoom 10-20mm f/4.5 VR 168", "zoom 10-20mm f/4.5 vr", "Zoomobjektiv"] {
            let (found, _) = db.find(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(found.model, "Zoom 10-20mm f/4.5 VR 168");
        }
        assert_eq!(db.lenses[0].model_aliases, ["Zoom 10-20mm f/4.5 VR"]);
        assert_eq!(db.lenses[0].model_translations, ["Zoomobjektiv"]);
    }
}
