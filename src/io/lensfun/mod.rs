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

    fn describe(&self) -> String {
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

    fn describe(&self) -> String {
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

    fn file_name(&self) -> String {
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

/// The parsed database (every `<lens>` of every XML file).
#[derive(Clone, Debug, Default)]
pub struct Database {
    /// Where it came from, for messages.
    pub origin: String,
    pub lenses: Vec<LensEntry>,
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

impl Database {
    /// Parses every `*.xml` in `dir` (sorted by name).
    pub fn load(dir: &Path) -> Result<Database, LensfunError> {
        let read_dir =
            std::fs::read_dir(dir).map_err(|error| LensfunError::ReadDir { dir: dir.to_path_buf(), error })?;
        let mut paths = Vec::new();
        for entry in read_dir {
            let entry = entry.map_err(|error| LensfunError::ReadDir { dir: dir.to_path_buf(), error })?;
            let path = entry.path();
            if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml")) {
                paths.push(path);
            }
        }
        if paths.is_empty() {
            return Err(LensfunError::Empty { dir: dir.to_path_buf() });
        }
        paths.sort();
        let mut db = Database { origin: dir.display().to_string(), lenses: Vec::new() };
        for path in paths {
            let text =
                std::fs::read_to_string(&path).map_err(|error| LensfunError::ReadFile { path: path.clone(), error })?;
            db.add_xml(&text, &path)?;
        }
        Ok(db)
    }

    /// A database from XML texts (name, text), e.g. for tests.
    pub fn from_xml(files: &[(&str, &str)]) -> Result<Database, LensfunError> {
        let mut db =
            Database { origin: files.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "), lenses: Vec::new() };
        for (name, text) in files {
            db.add_xml(text, Path::new(name))?;
        }
        Ok(db)
    }

    /// Adds the `<lens>` elements of one XML file.
    pub fn add_xml(&mut self, text: &str, path: &Path) -> Result<(), LensfunError> {
        let doc = roxmltree::Document::parse(text).map_err(|e| LensfunError::Xml {
            path: path.to_path_buf(),
            line: e.pos().row,
            message: e.to_string(),
        })?;
        let lines = LineIndex::new(text);
        for node in doc.root_element().children().filter(|n| n.has_tag_name("lens")) {
            self.lenses.push(parse_lens(&lines, node, path)?);
        }
        Ok(())
    }

    /// The entry of a model (case-insensitive, ',' and '.' alike, whitespace collapsed; the
    /// maker may be prefixed), and the other entries of the same model. Of several entries (the
    /// same model calibrated on several crop factors) the one with the smallest crop factor,
    /// the largest calibrated field, is chosen.
    pub fn find(&self, model: &str) -> Result<(&LensEntry, Vec<&LensEntry>), LensfunError> {
        let key = normalize(model);
        let by = |translations: bool| -> Vec<&LensEntry> {
            self.lenses
                .iter()
                .filter(|l| {
                    let names: Vec<&String> = if translations {
                        l.model_translations.iter().collect()
                    } else {
                        std::iter::once(&l.model).chain(&l.model_aliases).collect()
                    };
                    names.iter().any(|m| normalize(m) == key || normalize(&format!("{} {m}", l.maker)) == key)
                })
                .collect()
        };
        let mut found = by(false);
        if found.is_empty() {
            found = by(true);
        }
        if found.is_empty() {
            return Err(LensfunError::NotFound {
                model: model.to_string(),
                database: self.origin.clone(),
                close: self.close_names(model, 5),
            });
        }
        // Stable: of equal crop factors, the first in file order.
        found.sort_by(|a, b| a.crop_factor.unwrap_or(f64::INFINITY).total_cmp(&b.crop_factor.unwrap_or(f64::INFINITY)));
        let chosen = found.remove(0);
        Ok((chosen, found))
    }

    /// Up to `n` model names close to `model`: those containing it or contained in it, else
    /// those sharing the most words with it.
    pub fn close_names(&self, model: &str, n: usize) -> Vec<String> {
        let key = normalize(model);
        let mut names: Vec<&str> = Vec::new();
        for l in &self.lenses {
            let m = normalize(&l.model);
            if !key.is_empty() && (m.contains(&key) || key.contains(&m)) && !names.contains(&l.model.as_str()) {
                names.push(&l.model);
            }
        }
        if names.is_empty() {
            let words: Vec<&str> = key.split(' ').filter(|w| w.len() >= 2).collect();
            let mut scored: Vec<(usize, &str)> = self
                .lenses
                .iter()
                .map(|l| {
                    let m = normalize(&l.model);
                    (m.split(' ').filter(|w| words.contains(w)).count(), l.model.as_str())
                })
                .filter(|(s, _)| *s > 0)
                .collect();
            // Most shared words first; of equal scores, file order.
            scored.sort_by_key(|s| std::cmp::Reverse(s.0));
            for (_, m) in scored {
                if !names.contains(&m) {
                    names.push(m);
                }
            }
        }
        names.into_iter().take(n).map(str::to_string).collect()
    }

    /// Converts the lens `model` into a lens file.
    pub fn import(&self, model: &str, options: &ImportOptions) -> Result<Imported, LensfunError> {
        let (entry, others) = self.find(model)?;
        convert(entry, others.into_iter().cloned().collect(), options)
    }
}

/// Imports `model` from the database in `dir` (see [`database_dir`]).
pub fn import(model: &str, options: &ImportOptions, dir: Option<&Path>) -> Result<Imported, LensfunError> {
    Database::load(&database_dir(dir))?.import(model, options)
}

/// The lens file of `model` (for `--lens-lensfun`).
pub fn import_lens_file(model: &str, options: &ImportOptions, dir: Option<&Path>) -> Result<LensFile, LensfunError> {
    Ok(import(model, options, dir)?.lens)
}

/// Lower case, ',' as '.', whitespace collapsed to single spaces.
fn normalize(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ").to_lowercase().replace(',', ".")
}

/// The line of a byte offset, by binary search over the line starts (roxmltree's
/// `text_pos_at` scans from the start of the text: quadratic over a 2 MB file).
struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    fn new(text: &str) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    /// 1-based line of byte `offset`.
    fn line(&self, offset: usize) -> u32 {
        let line = self.starts.partition_point(|&s| s <= offset);
        u32::try_from(line).unwrap_or(u32::MAX)
    }
}

fn parse_lens(lines: &LineIndex, lens: roxmltree::Node, path: &Path) -> Result<LensEntry, LensfunError> {
    let line_of = |n: roxmltree::Node| lines.line(n.range().start);
    let at = |n: roxmltree::Node| Location { path: path.to_path_buf(), line: line_of(n) };
    let xml_err =
        |n: roxmltree::Node, message: String| LensfunError::Xml { path: path.to_path_buf(), line: line_of(n), message };
    let number = |n: roxmltree::Node, text: &str, what: &str| -> Result<f64, LensfunError> {
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| xml_err(n, format!("<{}> {what} = {text:?} is not a number", n.tag_name().name())))
    };
    let attr = |n: roxmltree::Node, name: &str, default: Option<f64>| -> Result<f64, LensfunError> {
        match n.attribute(name) {
            Some(v) => number(n, v, name),
            None => default.ok_or_else(|| xml_err(n, format!("<{}> has no {name} attribute", n.tag_name().name()))),
        }
    };
    let text_of = |n: roxmltree::Node| n.text().unwrap_or("").split_whitespace().collect::<Vec<_>>().join(" ");

    let mut entry = LensEntry {
        maker: String::new(),
        model: String::new(),
        model_aliases: Vec::new(),
        model_translations: Vec::new(),
        mounts: Vec::new(),
        crop_factor: None,
        aspect_ratio: DEFAULT_ASPECT_RATIO,
        lens_type: "rectilinear".to_string(),
        focal_range_mm: None,
        f_number_min: None,
        f_number_max: None,
        center: None,
        distortion: Vec::new(),
        tca: Vec::new(),
        vignetting: Vec::new(),
        calibration_notes: Vec::new(),
        at: at(lens),
    };
    for n in lens.children().filter(|n| n.is_element()) {
        match n.tag_name().name() {
            "maker" if n.attribute("lang").is_none() => entry.maker = text_of(n),
            "model" if n.attribute("lang").is_none() && entry.model.is_empty() => entry.model = text_of(n),
            "model" if n.attribute("lang").is_none() => entry.model_aliases.push(text_of(n)),
            "model" => entry.model_translations.push(text_of(n)),
            "mount" => entry.mounts.push(text_of(n)),
            "type" => entry.lens_type = text_of(n),
            "cropfactor" => {
                let c = number(n, &text_of(n), "value")?;
                if c <= 0.0 {
                    return Err(xml_err(n, format!("<cropfactor> {c} must be positive")));
                }
                entry.crop_factor = Some(c);
            }
            "aspect-ratio" => {
                entry.aspect_ratio = parse_aspect_ratio(&text_of(n)).ok_or_else(|| {
                    xml_err(n, format!("<aspect-ratio> {:?} is neither a ratio like 1.5 nor like 3:2", text_of(n)))
                })?
            }
            "focal" => {
                let (min, max) = match n.attribute("value") {
                    Some(v) => {
                        let v = number(n, v, "value")?;
                        (v, v)
                    }
                    None => {
                        let min = attr(n, "min", None)?;
                        (min, attr(n, "max", Some(min))?)
                    }
                };
                entry.focal_range_mm = Some((min, max));
            }
            "aperture" => {
                entry.f_number_min = n.attribute("min").map(|v| number(n, v, "min")).transpose()?;
                entry.f_number_max = n.attribute("max").map(|v| number(n, v, "max")).transpose()?;
            }
            "center" => entry.center = Some((attr(n, "x", Some(0.0))?, attr(n, "y", Some(0.0))?)),
            "calibration" => {
                for c in n.descendants() {
                    if c.is_comment() {
                        if let Some(t) = c.text() {
                            let t = t.split_whitespace().collect::<Vec<_>>().join(" ");
                            if !t.is_empty() {
                                entry.calibration_notes.push(t);
                            }
                        }
                        continue;
                    }
                    if !c.is_element() || c == n {
                        continue;
                    }
                    let model = c.attribute("model").unwrap_or("").to_string();
                    match c.tag_name().name() {
                        "distortion" => {
                            let m = match model.as_str() {
                                "none" => continue,
                                "poly3" => DistortionModel::Poly3 { k1: attr(c, "k1", Some(0.0))? },
                                "poly5" => DistortionModel::Poly5 {
                                    k1: attr(c, "k1", Some(0.0))?,
                                    k2: attr(c, "k2", Some(0.0))?,
                                },
                                "ptlens" => DistortionModel::Ptlens {
                                    a: attr(c, "a", Some(0.0))?,
                                    b: attr(c, "b", Some(0.0))?,
                                    c: attr(c, "c", Some(0.0))?,
                                },
                                _ => DistortionModel::Unknown(model),
                            };
                            entry.distortion.push(Distortion {
                                focal_mm: attr(c, "focal", None)?,
                                model: m,
                                at: at(c),
                            });
                        }
                        "tca" => {
                            let m = match model.as_str() {
                                "none" => continue,
                                "linear" => {
                                    TcaModel::Linear { kr: attr(c, "kr", Some(1.0))?, kb: attr(c, "kb", Some(1.0))? }
                                }
                                "poly3" => TcaModel::Poly3 {
                                    vr: attr(c, "vr", Some(1.0))?,
                                    cr: attr(c, "cr", Some(0.0))?,
                                    br: attr(c, "br", Some(0.0))?,
                                    vb: attr(c, "vb", Some(1.0))?,
                                    cb: attr(c, "cb", Some(0.0))?,
                                    bb: attr(c, "bb", Some(0.0))?,
                                },
                                _ => TcaModel::Unknown(model),
                            };
                            entry.tca.push(Tca { focal_mm: attr(c, "focal", None)?, model: m, at: at(c) });
                        }
                        "vignetting" => {
                            if model == "none" {
                                continue;
                            }
                            entry.vignetting.push(Vignetting {
                                focal_mm: attr(c, "focal", None)?,
                                f_number: attr(c, "aperture", None)?,
                                distance_m: attr(c, "distance", Some(1000.0))?,
                                model,
                                k1: attr(c, "k1", Some(0.0))?,
                                k2: attr(c, "k2", Some(0.0))?,
                                k3: attr(c, "k3", Some(0.0))?,
                                at: at(c),
                            });
                        }
                        // <real-focal-length>, <crop>, <field_of_view>: not used.
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }
    if entry.model.is_empty() {
        return Err(xml_err(lens, "<lens> has no <model>".into()));
    }
    Ok(entry)
}

/// "1.5" or "3:2" (lensfun database.cpp accepts both) as long side / short side.
fn parse_aspect_ratio(text: &str) -> Option<f64> {
    let ratio = match text.split_once(':') {
        Some((a, b)) => a.trim().parse::<f64>().ok()? / b.trim().parse::<f64>().ok()?,
        None => text.trim().parse::<f64>().ok()?,
    };
    (ratio.is_finite() && ratio > 0.0).then(|| ratio.max(1.0 / ratio))
}

/// A decimal number (',' or '.' as the decimal mark) at the start of `s`, and its length.
fn leading_number(s: &str) -> Option<(f64, usize)> {
    let bytes = s.as_bytes();
    let mut end = 0;
    let mut seen_mark = false;
    while end < bytes.len() {
        let b = bytes[end];
        let mark_then_digit =
            (b == b'.' || b == b',') && end > 0 && !seen_mark && bytes.get(end + 1).is_some_and(u8::is_ascii_digit);
        if b.is_ascii_digit() || mark_then_digit {
            seen_mark |= mark_then_digit;
            end += 1;
        } else {
            break;
        }
    }
    if end == 0 {
        return None;
    }
    s[..end].replace(',', ".").parse::<f64>().ok().map(|v| (v, end))
}

/// The words of a model name, without surrounding brackets.
fn words(model: &str) -> impl Iterator<Item = &str> {
    model.split_whitespace().map(|w| w.trim_matches(|c: char| matches!(c, '(' | ')' | '[' | ']')))
}

/// A word "N/F" with numbers on both sides (the Zeiss style "1,4/50"): (N, F).
fn f_number_slash_focal(word: &str) -> Option<(f64, f64)> {
    let (a, b) = word.split_once('/')?;
    let (n, n_len) = leading_number(a)?;
    let (f, _) = leading_number(b)?;
    (n_len == a.len()).then_some((n, f))
}

/// The widest f-number written in a model name: "f/1.4", "F1.4", "35mmF1.4", "1:2", or the
/// Zeiss style "1,4/50" / "1.4/50" (f-number / focal length). For zooms ("f/3.5-5.6") the first.
pub fn f_number_from_model(model: &str) -> Option<f64> {
    let plausible = |n: f64| (0.5..=64.0).contains(&n);
    words(model).find_map(|w| {
        // "XF35mmF1.4": the f-number after the focal length in one word.
        let w = w.find("mmF").or_else(|| w.find("mmf")).map_or(w, |i| &w[i + 2..]);
        let n = if let Some(rest) = w.strip_prefix(['f', 'F']) {
            leading_number(rest.strip_prefix('/').unwrap_or(rest)).map(|(n, _)| n)
        } else if let Some(rest) = w.strip_prefix("1:") {
            leading_number(rest).map(|(n, _)| n)
        } else {
            f_number_slash_focal(w).map(|(n, _)| n)
        };
        n.filter(|&n| plausible(n))
    })
}

/// The focal length written in a model name: "85mm", "50 mm", or the Zeiss style "1,4/50"
/// (the number after the '/'). For zooms ("24-70mm") the shortest.
pub fn focal_length_from_model(model: &str) -> Option<f64> {
    let list: Vec<&str> = words(model).collect();
    list.iter().enumerate().find_map(|(i, w)| {
        let (f, len) = leading_number(w)?;
        let rest = w[len..].to_ascii_lowercase();
        let zoom_mm = rest.starts_with('-') && rest.ends_with("mm");
        if rest == "mm" || zoom_mm || (rest.is_empty() && list.get(i + 1).is_some_and(|n| n.eq_ignore_ascii_case("mm")))
        {
            return Some(f);
        }
        f_number_slash_focal(w).map(|(_, f)| f)
    })
}

/// The focal length among `items` nearest `focal_mm`.
fn nearest_focal<T>(items: &[T], focal: impl Fn(&T) -> f64, focal_mm: f64) -> Option<f64> {
    items.iter().map(&focal).min_by(|a, b| (a - focal_mm).abs().total_cmp(&(b - focal_mm).abs()))
}

/// The heights of the tables: `HEIGHT_SAMPLES` from 0 to `max_mm`, plus the `special` heights
/// inside (0, max_mm) (grid points within a quarter step of one are dropped).
fn sample_heights(max_mm: f64, special: &[f64]) -> Vec<f64> {
    let step = max_mm / (HEIGHT_SAMPLES - 1) as f64;
    let special: Vec<f64> = special.iter().copied().filter(|&s| s > 0.25 * step && s < max_mm - 0.25 * step).collect();
    let mut h: Vec<f64> = (0..HEIGHT_SAMPLES)
        .map(|i| if i == HEIGHT_SAMPLES - 1 { max_mm } else { i as f64 * step })
        .filter(|g| *g == 0.0 || *g == max_mm || special.iter().all(|s| (s - g).abs() >= 0.25 * step))
        .collect();
    h.extend(special);
    h.sort_by(f64::total_cmp);
    h.dedup();
    h
}

fn positive(name: &'static str, value: Option<f64>) -> Result<Option<f64>, LensfunError> {
    match value {
        Some(v) if !(v.is_finite() && v > 0.0) => Err(LensfunError::BadOption { name, value: v }),
        _ => Ok(value),
    }
}

/// The calibrations an import uses.
struct Selection<'a> {
    /// The lens file's focal length: the calibrated one nearest the request.
    focal_length_mm: f64,
    distortion: Option<&'a Distortion>,
    tca: Option<&'a Tca>,
    /// Increasing f-number, one per f-number.
    vignetting: Vec<&'a Vignetting>,
}

impl<'a> Selection<'a> {
    /// For a zoom, the calibrations at the focal length nearest `requested_mm` (default the
    /// shortest calibrated), without interpolation; for vignetting, per f-number the distance
    /// nearest `distance_m` (default the farthest).
    fn choose(
        entry: &'a LensEntry,
        requested_mm: Option<f64>,
        distance_m: Option<f64>,
        warnings: &mut Vec<String>,
    ) -> Result<Selection<'a>, LensfunError> {
        let model = &entry.model;
        let mut focals: Vec<f64> = entry.distortion.iter().map(|d| d.focal_mm).collect();
        focals.extend(entry.tca.iter().map(|t| t.focal_mm));
        focals.extend(entry.vignetting.iter().map(|v| v.focal_mm));
        let focal_length_mm = if focals.is_empty() {
            warnings.push(format!("{model}: lensfun has no calibration for this lens; the lens file has no tables"));
            requested_mm.or(entry.focal_range_mm.map(|r| r.0)).or_else(|| focal_length_from_model(model)).ok_or_else(
                || LensfunError::Missing {
                    model: model.clone(),
                    message: "no focal length: no calibration, no <focal> and none in the model name".into(),
                },
            )?
        } else {
            let shortest = focals.iter().copied().fold(f64::INFINITY, f64::min);
            let chosen = nearest_focal(&focals, |f| *f, requested_mm.unwrap_or(shortest)).unwrap_or(shortest);
            if let Some(r) = requested_mm.filter(|r| (chosen - r).abs() > 1e-9) {
                warnings.push(format!(
                    "{model}: no calibration at {r} mm; using the nearest calibrated focal length, {chosen} mm"
                ));
            }
            chosen
        };
        // Each kind of calibration at its focal length nearest the chosen one.
        let mut nearest = |what: &str, nearest: Option<f64>| {
            if let Some(f) = nearest.filter(|f| (f - focal_length_mm).abs() > 1e-9) {
                warnings.push(format!(
                    "{model}: lensfun has no {what} calibration at {focal_length_mm} mm; using the one at {f} mm"
                ));
            }
            nearest
        };
        let distortion = nearest("distortion", nearest_focal(&entry.distortion, |d| d.focal_mm, focal_length_mm))
            .and_then(|f| entry.distortion.iter().find(|d| d.focal_mm == f));
        let tca = nearest("TCA", nearest_focal(&entry.tca, |t| t.focal_mm, focal_length_mm))
            .and_then(|f| entry.tca.iter().find(|t| t.focal_mm == f));
        let vignetting_focal = nearest("vignetting", nearest_focal(&entry.vignetting, |v| v.focal_mm, focal_length_mm));
        let mut vignetting: Vec<&Vignetting> = Vec::new();
        if let Some(f) = vignetting_focal {
            let at_focal: Vec<&Vignetting> = entry.vignetting.iter().filter(|v| v.focal_mm == f).collect();
            let mut f_numbers: Vec<f64> = at_focal.iter().map(|v| v.f_number).collect();
            f_numbers.sort_by(f64::total_cmp);
            f_numbers.dedup();
            for n in f_numbers {
                let candidates = at_focal.iter().copied().filter(|v| v.f_number == n);
                // Distances compared in dioptres (1/m), in which focus differences are even
                // (lensfun's 1000 m, its infinity, is then next to infinity itself).
                let best = match distance_m {
                    Some(d) => {
                        let off = |v: &Vignetting| (1.0 / v.distance_m - 1.0 / d).abs();
                        candidates.min_by(|a, b| off(a).total_cmp(&off(b)))
                    }
                    None => candidates.max_by(|a, b| a.distance_m.total_cmp(&b.distance_m)),
                };
                vignetting.extend(best);
            }
        }
        Ok(Selection { focal_length_mm, distortion, tca, vignetting })
    }
}

/// The converted tables, against image height.
struct Tables {
    heights_mm: Vec<f64>,
    distortion_percent: Option<Vec<f64>>,
    /// (red, blue) extra percent over green.
    lateral_color_percent: Option<Vec<(f64, f64)>>,
    /// (f-number, relative illumination), increasing f-number.
    vignetting: Vec<(f64, Vec<f64>)>,
    /// Some vignetting value was outside (0, 2] and clamped.
    clamped: bool,
}

impl Tables {
    /// The selected calibrations sampled from 0 to `target_mm` (see the module documentation
    /// for the models and their units).
    fn sample(sensor: &CalibrationSensor, selection: &Selection, target_mm: f64) -> Tables {
        let unit_mm = sensor.half_short_side_mm();
        let calibrated_mm = sensor.half_diagonal_mm();
        // The model's slope at the axis (module documentation): paraxial height = d0 r_u.
        let d0 = selection.distortion.map_or(1.0, |d| 1.0 + d.model.excess(0.0));
        let r_u = |h: f64| h / (d0 * unit_mm);
        let heights_mm = sample_heights(target_mm, &[d0 * unit_mm, calibrated_mm]);
        // Real over ideal height, r_d / h = (1 + excess(r_u)) / d0: 1 + Kyaw 2013 eq 6.8 / 100.
        let ratio = |h: f64| selection.distortion.map_or(1.0, |d| (1.0 + d.model.excess(r_u(h))) / d0);
        let distortion_percent =
            selection.distortion.map(|_| heights_mm.iter().map(|&h| 100.0 * (ratio(h) - 1.0)).collect());
        // The red image lands at k(r_g) r_g, with r_g = h ratio the green (distorted) radius:
        // over the ideal height that is 100 (k ratio - 1) percent, and less green's D the
        // extra is 100 (k - 1) ratio (100 (k - 1) to first order).
        let lateral_color_percent = selection.tca.map(|t| {
            heights_mm
                .iter()
                .map(|&h| {
                    let ratio = ratio(h);
                    let (kr, kb) = t.model.factors(h * ratio / unit_mm);
                    (100.0 * (kr - 1.0) * ratio, 100.0 * (kb - 1.0) * ratio)
                })
                .collect()
        });
        let mut clamped = false;
        let vignetting = selection
            .vignetting
            .iter()
            .map(|v| {
                let values = heights_mm
                    .iter()
                    .map(|&h| {
                        let ri = v.relative_illumination(h / calibrated_mm);
                        clamped |= !(MIN_RELATIVE_ILLUMINATION..=2.0).contains(&ri);
                        ri.clamp(MIN_RELATIVE_ILLUMINATION, 2.0)
                    })
                    .collect();
                (v.f_number, values)
            })
            .collect();
        Tables { heights_mm, distortion_percent, lateral_color_percent, vignetting, clamped }
    }

    fn is_empty(&self) -> bool {
        self.distortion_percent.is_none() && self.lateral_color_percent.is_none() && self.vignetting.is_empty()
    }

    /// The `[tables]` of the lens file.
    fn lens_tables(&self) -> LensTables {
        let color =
            |pick: fn(&(f64, f64)) -> f64| self.lateral_color_percent.as_ref().map(|c| c.iter().map(pick).collect());
        LensTables {
            image_height_mm: self.heights_mm.clone(),
            distortion_percent: self.distortion_percent.clone(),
            lateral_color_red_percent: color(|c| c.0),
            lateral_color_blue_percent: color(|c| c.1),
            relative_illumination: None,
            tangential_blur_mm: None,
            sagittal_blur_mm: None,
            field_curvature_mm: None,
            coma_mm: None,
            at_f_number: None,
            vignetting: self
                .vignetting
                .iter()
                .map(|(f_number, values)| IlluminationAt { f_number: *f_number, relative_illumination: values.clone() })
                .collect(),
        }
    }
}

/// A setting of the lens file and where it comes from (a TOML comment).
struct Setting<T> {
    value: T,
    note: &'static str,
}

/// The settings lensfun gives only sometimes or never.
struct Settings {
    f_number_min: Setting<f64>,
    f_number_max: Setting<f64>,
    focus_min_m: Setting<f64>,
    blades: Setting<u32>,
}

impl Settings {
    fn new(entry: &LensEntry, focal_length_mm: f64, options: &ImportOptions) -> Result<Settings, LensfunError> {
        let given = positive("f_number_min", options.f_number_min)?;
        let f_number_min = match (given, entry.f_number_min, f_number_from_model(&entry.model)) {
            (Some(n), ..) => Setting { value: n, note: "given in the import options (f_number_min)" },
            (None, Some(n), _) => Setting { value: n, note: "lensfun <aperture min>" },
            (None, None, Some(n)) => Setting { value: n, note: "from the model name (lensfun has no <aperture>)" },
            (None, None, None) => {
                return Err(LensfunError::Missing {
                    model: entry.model.clone(),
                    message: "no widest f-number: the entry has no <aperture min> and the model name none \
                              (like f/1.4, F1.4, 1:2 or 1,4/50); give it with --f-number-min"
                        .into(),
                })
            }
        };
        let f_number_max = match entry.f_number_max {
            Some(n) if n >= f_number_min.value => Setting { value: n, note: "lensfun <aperture max>" },
            _ => Setting {
                value: f_number_min.value.max(16.0),
                note: "ASSUMED: f/16 (or f_number_min if larger); lensfun gives no smallest aperture",
            },
        };
        let focus_min_m = match positive("focus_min_m", options.focus_min_m)? {
            Some(m) => Setting { value: m, note: "given in the import options (focus_min_m)" },
            None => Setting {
                value: 10.0 * focal_length_mm / 1000.0,
                note: "ASSUMED: 10 focal lengths; lensfun does not give the closest focus",
            },
        };
        let blades = match options.blades {
            Some(b) => Setting { value: b, note: "given in the import options (blades)" },
            None => Setting { value: 0, note: "ASSUMED: circular; lensfun does not give the blade count" },
        };
        Ok(Settings { f_number_min, f_number_max, focus_min_m, blades })
    }
}

/// The entry's calibration sensor, after checking realcam can use the entry at all.
fn check_supported(entry: &LensEntry) -> Result<CalibrationSensor, LensfunError> {
    let unsupported = |at: &Location, message: String| LensfunError::Unsupported {
        model: entry.model.clone(),
        path: at.path.clone(),
        line: at.line,
        message,
    };
    if !entry.lens_type.eq_ignore_ascii_case("rectilinear") {
        return Err(unsupported(
            &entry.at,
            format!(
                "its type is {0} (<type>{0}</type>), not rectilinear: realcam's lens files describe \
                 rectilinear lenses only (distortion as a percentage of the rectilinear image height)",
                entry.lens_type
            ),
        ));
    }
    if let Some(d) = entry.distortion.iter().find(|d| matches!(d.model, DistortionModel::Unknown(_))) {
        return Err(unsupported(
            &d.at,
            format!("distortion {}: realcam knows poly3, poly5 and ptlens", d.model.describe()),
        ));
    }
    if let Some(t) = entry.tca.iter().find(|t| matches!(t.model, TcaModel::Unknown(_))) {
        return Err(unsupported(&t.at, format!("TCA {}: realcam knows linear and poly3", t.model.describe())));
    }
    if let Some(v) = entry.vignetting.iter().find(|v| v.model != "pa") {
        return Err(unsupported(&v.at, format!("vignetting model {:?}: realcam knows pa", v.model)));
    }
    let calibrated = !(entry.distortion.is_empty() && entry.tca.is_empty() && entry.vignetting.is_empty());
    match entry.calibration_sensor() {
        Some(s) => Ok(s),
        None if calibrated => Err(LensfunError::Missing {
            model: entry.model.clone(),
            message: format!(
                "the entry at {} has no <cropfactor>, so its calibration's radii have no size in mm",
                entry.at
            ),
        }),
        None => Ok(CalibrationSensor { crop_factor: 1.0, aspect_ratio: entry.aspect_ratio }),
    }
}

/// Converts one database entry into a lens file.
fn convert(entry: &LensEntry, others: Vec<LensEntry>, options: &ImportOptions) -> Result<Imported, LensfunError> {
    options.check()?;
    let sensor = check_supported(entry)?;
    let requested_mm = positive("focal_length_mm", options.focal_length_mm)?;
    let distance_m = positive("distance_m", options.distance_m)?;
    let diagonal_mm = positive("sensor_diagonal_mm", options.sensor_diagonal_mm)?.unwrap_or(FULL_FRAME_DIAGONAL_MM);
    let mut warnings = Vec::new();
    let selection = Selection::choose(entry, requested_mm, distance_m, &mut warnings)?;
    let settings = Settings::new(entry, selection.focal_length_mm, options)?;
    let target_mm = diagonal_mm / 2.0;
    let tables = Tables::sample(&sensor, &selection, target_mm);
    let model = &entry.model;
    let extrapolated = !tables.is_empty() && target_mm > sensor.half_diagonal_mm() * (1.0 + 1e-9);
    if extrapolated {
        warnings.push(format!(
            "{model}: lensfun's calibration covers image heights up to {:.2} mm (crop factor {}); the tables from \
             there to {target_mm:.2} mm extrapolate its fitted polynomials",
            sensor.half_diagonal_mm(),
            sensor.crop_factor
        ));
    }
    if tables.clamped {
        warnings.push(format!(
            "{model}: the vignetting polynomial leaves (0, 2] inside the tables; clamped to [{MIN_RELATIVE_ILLUMINATION}, 2]"
        ));
    }
    if entry.center.is_some_and(|c| c != (0.0, 0.0)) {
        warnings.push(format!("{model}: lensfun's <center> offset is not used (realcam's tables are centred)"));
    }
    for w in &warnings {
        log::warn!("{w}");
    }
    let text = lens_file_text(entry, &others, &sensor, &selection, &settings, &tables, distance_m, diagonal_mm);
    let lens = LensFile::parse(&text, Path::new(&format!("<lensfun {model}>"))).map_err(|error| {
        let hint = if extrapolated {
            format!(
                ". The tables reach {target_mm:.2} mm but the calibration only {:.2} mm: give the sensor's \
                     diagonal in sensor_diagonal_mm (the calibration sensor's is {:.2} mm)",
                sensor.half_diagonal_mm(),
                2.0 * sensor.half_diagonal_mm()
            )
        } else {
            String::new()
        };
        LensfunError::Converted { model: model.clone(), error, hint }
    })?;
    Ok(Imported { toml: text, lens, entry: entry.clone(), others, warnings })
}

/// The lens file's text, with comments saying where every number comes from.
#[allow(clippy::too_many_arguments)]
fn lens_file_text(
    entry: &LensEntry,
    others: &[LensEntry],
    sensor: &CalibrationSensor,
    selection: &Selection,
    settings: &Settings,
    tables: &Tables,
    distance_m: Option<f64>,
    diagonal_mm: f64,
) -> String {
    let (unit_mm, calibrated_mm, target_mm) =
        (sensor.half_short_side_mm(), sensor.half_diagonal_mm(), diagonal_mm / 2.0);
    let mut source = format!(
        "lensfun {} ({}, calibrated on crop factor {}",
        entry.file_name(),
        if entry.mounts.is_empty() { "no mount given".to_string() } else { entry.mounts.join(" / ") },
        sensor.crop_factor
    );
    for note in &entry.calibration_notes {
        let _ = write!(source, ", {note}");
    }
    source.push_str("); converted by realcam lens import-lensfun");

    // The comment at the top of the file (the writer makes each line a comment).
    let mut t = String::new();
    let _ = writeln!(t, "Converted from the lensfun database by `realcam lens import-lensfun {:?}`.", entry.model);
    let _ =
        writeln!(t, "Entry: {} (maker {}).", entry.at, if entry.maker.is_empty() { "not given" } else { &entry.maker });
    for o in others {
        let crop = o.crop_factor.map_or_else(|| "not given".to_string(), |c| c.to_string());
        let _ = writeln!(
            t,
            "Not used: the same model at {} (crop factor {crop}); the entry with the smallest crop\n\
             factor, the largest calibrated field, is used.",
            o.at
        );
    }
    let _ = writeln!(
        t,
        "Models: lensfun include/lensfun/lensfun.h.in, libs/lensfun/mod-coord.cpp, mod-color.cpp.\n\
         Calibration sensor: crop factor {crop}, aspect ratio {aspect}. r = 1 is {unit_mm:.4} mm for\n\
         distortion and TCA (half the shorter side, hypot(36, 24) / crop / hypot(aspect, 1) / 2) and\n\
         {calibrated_mm:.4} mm for vignetting (half the diagonal, hypot(36, 24) / crop / 2).",
        crop = sensor.crop_factor,
        aspect = sensor.aspect_ratio,
    );
    match selection.distortion {
        Some(d) => {
            let _ = writeln!(
                t,
                "Distortion at {} mm ({}): {}.\n  \
                 distortion_percent = 100 (r_d / (d0 r_u) - 1) at each paraxial ideal height h = d0 r_u\n  \
                 (Kyaw 2013 eq 6.8), d0 the model's slope at the axis.",
                d.focal_mm,
                d.at,
                d.model.describe()
            );
            let d0 = 1.0 + d.model.excess(0.0);
            if (d0 - 1.0).abs() > 5e-8 {
                let _ = writeln!(
                    t,
                    "  lensfun keeps r_u = 1 fixed, not the axis; here d0 = {}: the paraxial focal length\n  \
                     is d0 x {} mm (lensfun's real focal length), and the tables are referred to it, so\n  \
                     distortion is 0 at the centre.",
                    number_text(d0, 6),
                    d.focal_mm
                );
            }
        }
        None => {
            let _ = writeln!(t, "Distortion: none in lensfun for this lens.");
        }
    }
    match selection.tca {
        Some(c) => {
            let _ = writeln!(
                t,
                "TCA at {} mm ({}): {}, r the green radius.\n  \
                 lateral_color_*_percent = 100 (k - 1) (1 + distortion_percent / 100): red/blue over green.",
                c.focal_mm,
                c.at,
                c.model.describe()
            );
        }
        None => {
            let _ = writeln!(t, "TCA (lateral colour): none in lensfun for this lens.");
        }
    }
    match selection.vignetting.first() {
        Some(first) => {
            let used: Vec<String> =
                selection.vignetting.iter().map(|v| format!("f/{} at {} m", v.f_number, v.distance_m)).collect();
            let _ = writeln!(
                t,
                "Vignetting at {} mm ({} on), model pa: relative illumination 1 + k1 r^2 + k2 r^4 + k3 r^6;\n  \
                 per f-number {}: {}.",
                first.focal_mm,
                first.at,
                match distance_m {
                    Some(d) => format!("the calibration focused nearest {d} m (compared in dioptres)"),
                    None => "the calibration focused farthest".to_string(),
                },
                used.join(", ")
            );
        }
        None => {
            let _ = writeln!(t, "Vignetting: none in lensfun for this lens (the camera's cos^4 law applies).");
        }
    }
    if !tables.is_empty() {
        let _ = writeln!(
            t,
            "Tables: {HEIGHT_SAMPLES} heights from 0 to {target_mm:.4} mm (half the diagonal of a {diagonal_mm:.3} mm\n\
             target sensor), plus r = 1 and the edge of the calibrated field where they fall inside."
        );
    }
    if !tables.is_empty() && target_mm > calibrated_mm * (1.0 + 1e-9) {
        let _ = writeln!(
            t,
            "EXTRAPOLATED: lensfun's calibration covers heights up to {calibrated_mm:.2} mm (crop factor {});\n\
             the values beyond are its fitted polynomials extrapolated, not measured.",
            sensor.crop_factor
        );
    }
    if tables.clamped {
        let _ = writeln!(
            t,
            "The vignetting polynomial leaves (0, 2] inside the tables: those values are clamped to\n\
             [{MIN_RELATIVE_ILLUMINATION}, 2]."
        );
    }

    let s = settings;
    let mut w = LensFileWriter::new(&t);
    w.string("name", &entry.model, None)
        .string("source", &source, None)
        .number("focal_length_mm", selection.focal_length_mm, 4, None)
        .number("f_number_min", s.f_number_min.value, 3, Some(s.f_number_min.note))
        .number("f_number_max", s.f_number_max.value, 3, Some(s.f_number_max.note))
        .number("focus_min_m", s.focus_min_m.value, 4, Some(s.focus_min_m.note))
        .integer("aperture.blades", i64::from(s.blades.value), Some(s.blades.note));
    if !tables.is_empty() {
        w.tables(&tables.lens_tables(), None);
    }
    w.finish()
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
