//! `realcam lens analyze`: the prescription of a lens file (its `[[surface]]` tables) or of a
//! bare prescription file, traced at an f-number and field angles; and, when asked, the lens
//! file with the tables that trace implies.

use crate::io::lens_file::{with_derived_tables, LensFile, LensFileError};
use crate::optics::prescription::{LensAnalysis, Prescription, PrescriptionError};
use std::path::{Path, PathBuf};

/// Why an analysis failed. [`LensAnalysisError::field`] names the argument an error is about.
#[derive(Debug, thiserror::Error)]
pub enum LensAnalysisError {
    #[error("lens file {}: cannot read it", .path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    LensFile(#[from] LensFileError),
    #[error(transparent)]
    Prescription(#[from] PrescriptionError),
    #[error("lens file {}: it has no [[surface]] tables to analyze", .path.display())]
    NoSurfaces { path: PathBuf },
    /// The prescription's focal length is not between 0.01 mm and 1 km: it forms no real image.
    #[error("lens file {}: the prescription forms no real image (EFL = {} mm)", .path.display(), crate::optics::Num(*.efl_mm))]
    NoImage { path: PathBuf, efl_mm: f64 },
    /// `f_number`.
    #[error("f-number must be a positive number, got {value}")]
    FNumber { value: f64 },
    /// `tables_path`: the traced fields do not make tables.
    #[error("cannot derive the tables: {reason}")]
    Tables { reason: String },
    /// `tables_path`: the lens file's text does not take the tables.
    #[error("cannot put the tables into the lens file: {0}")]
    TablesToml(toml_edit::TomlError),
    /// `tables_path`: the lens file with the tables does not parse (a bug if it happens).
    #[error("the derived lens file: {0}")]
    DerivedFile(LensFileError),
}

impl LensAnalysisError {
    /// The argument the error is about, if it is about one: `f_number` of [`analyze`],
    /// `tables_path` of [`LensReport::lens_file_with_tables`].
    pub fn field(&self) -> Option<&'static str> {
        match self {
            LensAnalysisError::FNumber { .. } => Some("f_number"),
            LensAnalysisError::Tables { .. } | LensAnalysisError::TablesToml(_) | LensAnalysisError::DerivedFile(_) => {
                Some("tables_path")
            }
            _ => None,
        }
    }
}

/// What [`analyze`] found.
#[derive(Debug, Clone)]
pub struct LensReport {
    /// The trace; its `Display` is the printed report.
    pub analysis: LensAnalysis,
    /// The analysed file and its text.
    path: PathBuf,
    text: String,
    is_lens_file: bool,
}

/// Whether `text` is a lens file, which has a focal length, rather than a bare prescription,
/// which has only a name, a source and surfaces.
pub fn is_lens_file(text: &str) -> bool {
    text.parse::<toml::Table>().is_ok_and(|t| t.contains_key("focal_length_mm"))
}

/// Reads the file at `path` and analyses it as [`analyze_text`] does.
pub fn analyze(path: &Path, f_number: Option<f64>, field_deg: &[f64]) -> Result<LensReport, LensAnalysisError> {
    let text =
        std::fs::read_to_string(path).map_err(|source| LensAnalysisError::Read { path: path.to_path_buf(), source })?;
    analyze_text(text, path, f_number, field_deg)
}

/// Traces the prescription in `text` (a lens file with `[[surface]]` tables, or a bare
/// prescription; `path` names it in messages) at `f_number` (default: the lens file's widest
/// aperture, or the prescription's own stop) and the field angles `field_deg`.
pub fn analyze_text(
    text: String,
    path: &Path,
    f_number: Option<f64>,
    field_deg: &[f64],
) -> Result<LensReport, LensAnalysisError> {
    let is_lens_file = is_lens_file(&text);
    let (prescription, f_number_min) = if is_lens_file {
        let lens = LensFile::parse(&text, path)?;
        if lens.surfaces.is_empty() {
            return Err(LensAnalysisError::NoSurfaces { path: path.to_path_buf() });
        }
        (lens.prescription(path, &text)?, Some(lens.f_number_min))
    } else {
        (Prescription::parse_toml(&text, &path.display().to_string())?, None)
    };
    let f_number = match f_number {
        Some(n) if n.is_finite() && n > 0.0 => n,
        Some(value) => return Err(LensAnalysisError::FNumber { value }),
        None => f_number_min.unwrap_or_else(|| prescription.f_number_at_table_stop()),
    };
    let efl_mm = prescription.paraxial(crate::optics::prescription::LAMBDA_D_NM).efl_mm;
    if !(efl_mm.is_finite() && (0.01..1e6).contains(&efl_mm)) {
        return Err(LensAnalysisError::NoImage { path: path.to_path_buf(), efl_mm });
    }
    let analysis = prescription.analyze(f_number, field_deg);
    Ok(LensReport { analysis, path: path.to_path_buf(), text, is_lens_file })
}

impl LensReport {
    /// The lens file with the `[tables]` and `[longitudinal_color]` the trace implies, to be
    /// written at `tables_path` (which names it in messages): the analysed lens file's own
    /// settings and comments, or for a bare prescription settings derived from the trace; the
    /// traced field angles must start at 0. Checked to parse as a lens file.
    pub fn lens_file_with_tables(&self, tables_path: &Path) -> Result<String, LensAnalysisError> {
        let derived = self.analysis.derived_tables().map_err(|reason| LensAnalysisError::Tables { reason })?;
        let source = self.path.display().to_string();
        let text = with_derived_tables(&self.text, self.is_lens_file, &self.analysis, &derived, &source)
            .map_err(LensAnalysisError::TablesToml)?;
        LensFile::parse(&text, tables_path).map_err(LensAnalysisError::DerivedFile)?;
        Ok(text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TESSAR: &str = include_str!("../../lenses/tessar-walch.toml");
    const TESSAR_LENS: &str = include_str!("../../lenses/tessar-walch-lens.toml");

    #[test]
    fn lens_files_have_a_focal_length_prescriptions_do_not() {
        assert!(!is_lens_file(TESSAR));
        assert!(is_lens_file(TESSAR_LENS));
        assert!(is_lens_file(crate::io::lens_file::DEFAULT_LENS_TOML));
        assert!(!is_lens_file("not = = toml"));
    }

    #[test]
    fn a_prescription_traces_and_makes_a_lens_file() {
        let path = Path::new("lenses/tessar-walch.toml");
        let report = analyze_text(TESSAR.into(), path, None, &[0.0, 10.0, 20.0]).unwrap();
        // The published focal length of the design is 100 mm; with Schott's SF7 and LLF7 the
        // paraxial trace gives 100.013 mm (101.83 mm with SF2's data in place of SF7's).
        assert!((report.analysis.paraxial.efl_mm - 100.0129).abs() < 1e-3, "{}", report.analysis.paraxial.efl_mm);
        assert_eq!(report.analysis.f_number, Prescription::parse_toml(TESSAR, "t").unwrap().f_number_at_table_stop());
        let text = report.lens_file_with_tables(Path::new("out.toml")).unwrap();
        let lens = LensFile::parse(&text, Path::new("out.toml")).unwrap();
        assert!(lens.tables.is_some() && lens.longitudinal_color.is_some());
        assert!((lens.focal_length_mm - 100.0129).abs() < 1e-3);
        assert!(text.contains("from the prescription lenses/tessar-walch.toml"));
        let report = analyze_text(TESSAR.into(), path, Some(4.0), &[0.0]).unwrap();
        assert_eq!(report.analysis.f_number, 4.0);
    }

    #[test]
    fn a_lens_file_analyses_at_its_widest_aperture_and_keeps_its_settings() {
        let path = Path::new("lenses/tessar-walch-lens.toml");
        let own = LensFile::parse(TESSAR_LENS, path).unwrap();
        let report = analyze_text(TESSAR_LENS.into(), path, None, &[0.0, 20.0]).unwrap();
        assert_eq!(report.analysis.f_number, own.f_number_min);
        let lens = LensFile::parse(&report.lens_file_with_tables(Path::new("o.toml")).unwrap(), path).unwrap();
        assert_eq!((lens.name, lens.focus_min_m), (own.name, own.focus_min_m));
    }

    #[test]
    fn errors_name_the_file_or_the_argument() {
        let default = Path::new("lenses/default.toml");
        let err = analyze_text(crate::io::lens_file::DEFAULT_LENS_TOML.into(), default, None, &[0.0]).unwrap_err();
        assert_eq!(err.to_string(), "lens file lenses/default.toml: it has no [[surface]] tables to analyze");
        assert_eq!(err.field(), None);

        let path = Path::new("t.toml");
        for bad in [0.0, -2.0, f64::NAN] {
            let err = analyze_text(TESSAR.into(), path, Some(bad), &[0.0]).unwrap_err();
            assert_eq!(err.field(), Some("f_number"));
            assert_eq!(err.to_string(), format!("f-number must be a positive number, got {bad}"));
        }

        let report = analyze_text(TESSAR.into(), path, None, &[5.0, 10.0]).unwrap();
        let err = report.lens_file_with_tables(Path::new("o.toml")).unwrap_err();
        assert_eq!(err.field(), Some("tables_path"));
        assert_eq!(err.to_string(), "cannot derive the tables: the field angles must start at 0 degrees");

        let err = analyze(Path::new("/no/such/lens.toml"), None, &[0.0]).unwrap_err();
        assert_eq!(err.to_string(), "lens file /no/such/lens.toml: cannot read it");
        // Flat glass has no power: no real image, and a message instead of EFL 0 or NaN.
        let flat = "name = \"x\"\n[[surface]]\nradius_mm = 0\nthickness_mm = 5\nn_d = 1.5\nsemi_diameter_mm = 10\nstop = true\n[[surface]]\nradius_mm = 0\nthickness_mm = 50\nsemi_diameter_mm = 10\n";
        let err = analyze_text(flat.into(), path, Some(2.0), &[0.0]).unwrap_err();
        assert!(err.to_string().starts_with("lens file t.toml: the prescription forms no real image (EFL = "), "{err}");
        for (key, bad, message) in [
            ("n_d = 1.5", "n_d = 1e12", "n_d = 1e12 must be at most 3 (no optical material has more)"),
            ("thickness_mm = 5", "thickness_mm = -5", "thickness_mm = -5 must not be negative"),
        ] {
            let err = analyze_text(flat.replacen(key, bad, 1), path, None, &[0.0]).unwrap_err();
            assert!(err.to_string().ends_with(&format!("surface 0: {message}")), "{err}");
        }
        let err = analyze_text("name = \"x\"\n[[surface]]\nradius_mm = 1\n".into(), path, None, &[0.0]).unwrap_err();
        assert!(matches!(err, LensAnalysisError::Prescription(_)), "{err:?}");
    }
}
