//! Lens files (TOML, in lenses/): what a lens is and what it allows. Errors name the file and
//! the line. The full format (aberration tables, prescriptions) grows with the lens model; the
//! fields here are what the camera pipeline uses today.

use crate::optics::Num;
use serde::Deserialize;
use std::path::{Path, PathBuf};

mod write;

mod fitted_ghosts;
mod validate;
pub use fitted_ghosts::FittedGhostSpec;
pub use write::{number_text, rounded, with_derived_tables, LensFileWriter};

#[derive(Debug, thiserror::Error)]
pub enum LensFileError {
    #[error("lens file {path}: cannot read it: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("lens file {path}, line {line}: {message}")]
    Parse { path: PathBuf, line: usize, message: String },
    #[error("lens file {path}: {message}")]
    Invalid { path: PathBuf, message: String },
    /// The file's `[[surface]]` prescription is invalid (the message names file and line).
    #[error("lens file {0}")]
    Prescription(#[from] crate::optics::prescription::PrescriptionError),
}

/// The iris of a lens.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ApertureSpec {
    /// Number of blades; 0 for a circular aperture.
    pub blades: u32,
    #[serde(default)]
    pub rotation_deg: f64,
    /// 0 straight blades .. 1 circular (stopped down, see below).
    #[serde(default)]
    pub curvature: f64,
    /// Blade curvature wide open, when it differs: many lenses are round wide open and
    /// polygonal stopped down. Default: `curvature`.
    #[serde(default)]
    pub curvature_wide_open: Option<f64>,
    /// The f-number from which the blades have `curvature`; between f_number_min and this the
    /// curvature goes from `curvature_wide_open` to `curvature` linearly in stops.
    #[serde(default)]
    pub polygonal_from_f_number: Option<f64>,
    /// Cat's eye (optical vignetting of the bokeh) at the frame's farthest corner, 0..1.
    #[serde(default)]
    pub cats_eye: f64,
    /// The image height (mm) at which `cats_eye` holds, growing linearly from the centre; when
    /// absent, `cats_eye` holds at the frame's farthest corner, whatever the sensor.
    #[serde(default)]
    pub cats_eye_at_mm: Option<f64>,
}

impl ApertureSpec {
    /// Blade curvature at f-number `n` for a lens whose widest aperture is `f_number_min`.
    pub fn curvature_at(&self, n: f64, f_number_min: f64) -> f64 {
        let wide = self.curvature_wide_open.unwrap_or(self.curvature);
        let stopped_at = self.polygonal_from_f_number.unwrap_or(f_number_min);
        if stopped_at <= f_number_min || n >= stopped_at {
            return if n >= stopped_at { self.curvature } else { wide };
        }
        // Linear in stops (log2 of the f-number squared).
        let t = ((n / f_number_min).log2() / (stopped_at / f_number_min).log2()).clamp(0.0, 1.0);
        wide + (self.curvature - wide) * t
    }
}

/// The line (from 1; 0 if absent) of the `i`-th `header` (`[[tables.vignetting]]`) of `text`.
fn header_line(text: &str, header: &str, i: usize) -> usize {
    text.lines().enumerate().filter(|(_, l)| l.trim_start().starts_with(header)).nth(i).map_or(0, |(n, _)| n + 1)
}

/// A lens as a lens file describes it.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LensFile {
    pub name: String,
    /// Where the numbers come from.
    pub source: String,
    pub focal_length_mm: f64,
    pub f_number_min: f64,
    pub f_number_max: f64,
    /// Closest focus distance, metres from the entrance pupil.
    pub focus_min_m: f64,
    /// An ideal thin lens (the renderer's camera): any focal length, f-number and focus are
    /// allowed, and unless said otherwise it uses the renderers' CoC (`coc_model = "renderer"`)
    /// and has no natural vignetting.
    #[serde(default)]
    pub ideal: bool,
    /// How the circle of confusion follows depth: "physical" (Kyaw 2013 eq 5.3, the film at the
    /// image distance, with focus breathing) or "renderer" (a thin lens at the pinhole with the
    /// image scale of the focal length, as Cycles, Arnold and RenderMan draw it). Default:
    /// physical, or renderer for an ideal lens.
    #[serde(default)]
    pub coc_model: Option<crate::optics::lens::CocModel>,
    /// Whether the lens has natural (cos^4) vignetting; default: yes, except for an ideal lens.
    #[serde(default)]
    pub natural_vignetting: Option<bool>,
    #[serde(default = "one")]
    pub transmittance: f64,
    #[serde(default = "one")]
    pub pupil_magnification: f64,
    /// Spherical aberration amount in the bokeh, -1..1: > 0 under-corrected (soft background,
    /// harsh foreground), < 0 over-corrected, 0 uniform disks.
    #[serde(default)]
    pub spherical_aberration: f64,
    pub aperture: ApertureSpec,
    /// Quantities against image height (Kyaw 2013 sec 7.2: tables of off-axis distance).
    #[serde(default)]
    pub tables: Option<LensTables>,
    /// Traced longitudinal spherical aberration, used in the bokeh instead of
    /// `spherical_aberration` (src/optics/spherical.rs strength_traced).
    #[serde(default)]
    pub longitudinal_spherical_aberration: Option<LsaSpec>,
    /// Longitudinal (axial) colour: where the red and the blue image of an object focus
    /// relative to the green one, along the axis.
    #[serde(default)]
    pub longitudinal_color: Option<LongitudinalColorSpec>,
    /// The optical prescription, front surface first, if the file carries one
    /// (`realcam lens analyze` traces it; its keys are those of src/optics/prescription.rs).
    #[serde(default, rename = "surface")]
    pub surfaces: Vec<crate::optics::prescription::SurfaceSpec>,
    /// Lens flare: the coatings (for the ghosts of the prescription) and the halo.
    #[serde(default)]
    pub flare: FlareSpec,
    /// Walch's measured ghosts as polynomials of the angle (src/io/lens_file/fitted_ghosts.rs).
    #[serde(default, rename = "fitted_ghost")]
    pub fitted_ghosts: Vec<FittedGhostSpec>,
}

/// `[flare]`: what the lens's flare depends on besides its prescription and aperture.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FlareSpec {
    /// Design wavelength (nm) of the single-layer quarter-wave anti-reflection coatings of the
    /// air|glass surfaces; 0: uncoated.
    #[serde(default = "FlareSpec::default_coating_nm")]
    pub coating_design_nm: f64,
    /// Share of a light the glass scatters into the halo around it.
    #[serde(default = "FlareSpec::default_halo_fraction")]
    pub halo_fraction: f64,
    /// The halo's radius on the film (mm): its light falls as (1 + r^2/rho^2)^-1.5.
    #[serde(default = "FlareSpec::default_halo_radius_mm")]
    pub halo_radius_mm: f64,
}

impl FlareSpec {
    fn default_coating_nm() -> f64 {
        550.0
    }

    fn default_halo_fraction() -> f64 {
        0.01
    }

    fn default_halo_radius_mm() -> f64 {
        0.1
    }

    /// The coatings' design wavelength, None when uncoated.
    pub fn coating_nm(&self) -> Option<f64> {
        (self.coating_design_nm > 0.0).then_some(self.coating_design_nm)
    }
}

impl Default for FlareSpec {
    /// Coatings for 550 nm; an illustrative halo of 1% of the light within about 0.1 mm.
    fn default() -> Self {
        FlareSpec {
            coating_design_nm: Self::default_coating_nm(),
            halo_fraction: Self::default_halo_fraction(),
            halo_radius_mm: Self::default_halo_radius_mm(),
        }
    }
}

/// Longitudinal colour in mm on the image side: + = the channel focuses behind green.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LongitudinalColorSpec {
    /// Red (C line, 656 nm) focus minus green (d line, 588 nm) focus.
    pub red_mm: f64,
    /// Blue (F line, 486 nm) focus minus green focus.
    pub blue_mm: f64,
}

/// Longitudinal spherical aberration: the rim zone's focus minus the paraxial focus (mm; < 0
/// under-corrected), at `at_f_number`; it scales with the square of the pupil height.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LsaSpec {
    pub rim_mm: f64,
    pub at_f_number: f64,
}

/// Relative illumination measured at one f-number (vignetting changes as the lens stops down).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct IlluminationAt {
    pub f_number: f64,
    pub relative_illumination: Vec<f64>,
}

/// Tables against image height on the film, all of the length of `image_height_mm`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LensTables {
    /// Heights in mm from the optical centre, increasing, from 0.
    pub image_height_mm: Vec<f64>,
    /// Distortion in percent at each ideal height (Kyaw 2013 eq 6.8; < 0 barrel, > 0 pincushion).
    #[serde(default)]
    pub distortion_percent: Option<Vec<f64>>,
    /// Lateral colour: the extra distortion of the red and of the blue image relative to green.
    #[serde(default)]
    pub lateral_color_red_percent: Option<Vec<f64>>,
    #[serde(default)]
    pub lateral_color_blue_percent: Option<Vec<f64>>,
    /// Relative illumination (1 at the centre): natural and optical vignetting as measured.
    #[serde(default)]
    pub relative_illumination: Option<Vec<f64>>,
    /// Astigmatism: the length in mm on the film of the blur along the tangential direction
    /// (perpendicular to the radius) and along the sagittal one (the radius).
    #[serde(default)]
    pub tangential_blur_mm: Option<Vec<f64>>,
    #[serde(default)]
    pub sagittal_blur_mm: Option<Vec<f64>>,
    /// Field curvature: how far (mm) behind the film the sharp image surface lies at each height.
    #[serde(default)]
    pub field_curvature_mm: Option<Vec<f64>>,
    /// Coma: the length in mm of the comet (tangential coma, three times the sagittal coma)
    /// from the chief ray's image; > 0 when its flare points away from the centre.
    #[serde(default)]
    pub coma_mm: Option<Vec<f64>>,
    /// The f-number at which the blur tables (tangential, sagittal, coma) hold. When given, the
    /// blurs scale with the aperture at other f-numbers: astigmatic blur with the pupil
    /// diameter (N0/N), coma with its square ((N0/N)^2), as third-order aberrations do. When
    /// absent the blurs are the same at every f-number (as in Kyaw 2013).
    #[serde(default)]
    pub at_f_number: Option<f64>,
    /// Relative illumination at several f-numbers (`[[tables.vignetting]]`), interpolated in
    /// stops; instead of the single `relative_illumination` table.
    #[serde(default)]
    pub vignetting: Vec<IlluminationAt>,
}

impl LensTables {
    /// The tables against `image_height_mm`, each with its key.
    pub fn columns(&self) -> [(&'static str, &Option<Vec<f64>>); 8] {
        [
            ("distortion_percent", &self.distortion_percent),
            ("lateral_color_red_percent", &self.lateral_color_red_percent),
            ("lateral_color_blue_percent", &self.lateral_color_blue_percent),
            ("relative_illumination", &self.relative_illumination),
            ("tangential_blur_mm", &self.tangential_blur_mm),
            ("sagittal_blur_mm", &self.sagittal_blur_mm),
            ("field_curvature_mm", &self.field_curvature_mm),
            ("coma_mm", &self.coma_mm),
        ]
    }

    /// The astigmatism tables (tangential, sagittal blur in mm), if the lens file has either.
    pub fn astigmatism(
        &self,
    ) -> Option<(crate::optics::distortion::HeightTable, crate::optics::distortion::HeightTable)> {
        if self.tangential_blur_mm.is_none() && self.sagittal_blur_mm.is_none() {
            return None;
        }
        let table = |v: &Option<Vec<f64>>| crate::optics::distortion::HeightTable {
            image_height_mm: self.image_height_mm.clone(),
            values: v.clone().unwrap_or_else(|| vec![0.0; self.image_height_mm.len()]),
        };
        Some((table(&self.tangential_blur_mm), table(&self.sagittal_blur_mm)))
    }

    /// The field-curvature table, if the lens file has one.
    pub fn field_curvature(&self) -> Option<crate::optics::distortion::HeightTable> {
        self.field_curvature_mm.as_ref().map(|v| crate::optics::distortion::HeightTable {
            image_height_mm: self.image_height_mm.clone(),
            values: v.clone(),
        })
    }

    /// The relative-illumination table at f-number `n`: the single table, or the
    /// `[[tables.vignetting]]` entries interpolated linearly in stops (clamped at the ends).
    pub fn relative_illumination(&self, n: f64) -> Option<crate::optics::distortion::HeightTable> {
        let table = |values: Vec<f64>| crate::optics::distortion::HeightTable {
            image_height_mm: self.image_height_mm.clone(),
            values,
        };
        if let Some(v) = &self.relative_illumination {
            return Some(table(v.clone()));
        }
        let entries = &self.vignetting;
        let first = entries.first()?;
        let stops = |f: f64| 2.0 * f.max(1e-9).log2();
        let i = entries.iter().position(|e| e.f_number >= n).unwrap_or(entries.len());
        let values = if i == 0 {
            first.relative_illumination.clone()
        } else if i == entries.len() {
            entries[i - 1].relative_illumination.clone()
        } else {
            let (a, b) = (&entries[i - 1], &entries[i]);
            let t = (stops(n) - stops(a.f_number)) / (stops(b.f_number) - stops(a.f_number));
            a.relative_illumination.iter().zip(&b.relative_illumination).map(|(x, y)| x + (y - x) * t).collect()
        };
        Some(table(values))
    }

    /// How a blur that grows with the pupil diameter scales at f-number `n` (1 when the
    /// tables give no `at_f_number`).
    pub fn blur_scale(&self, n: f64) -> f64 {
        self.at_f_number.map_or(1.0, |n0| n0 / n)
    }

    /// The coma table at f-number `n` (scaled with the square of the pupil diameter).
    pub fn coma(&self, n: f64) -> Option<crate::optics::distortion::HeightTable> {
        let s = self.blur_scale(n);
        self.coma_mm.as_ref().map(|v| crate::optics::distortion::HeightTable {
            image_height_mm: self.image_height_mm.clone(),
            values: v.iter().map(|x| x * s * s).collect(),
        })
    }

    /// The distortion tables for the camera (zeros where a table is absent).
    pub fn distortion(&self) -> crate::optics::distortion::DistortionTables {
        use crate::optics::distortion::{DistortionTables, HeightTable};
        let table = |v: &Option<Vec<f64>>| HeightTable {
            image_height_mm: self.image_height_mm.clone(),
            values: v.clone().unwrap_or_else(|| vec![0.0; self.image_height_mm.len()]),
        };
        DistortionTables {
            green_percent: table(&self.distortion_percent),
            red_extra_percent: table(&self.lateral_color_red_percent),
            blue_extra_percent: table(&self.lateral_color_blue_percent),
        }
    }
}

fn one() -> f64 {
    1.0
}

/// The lens used when no --lens is given (lenses/default.toml, embedded).
pub const DEFAULT_LENS_TOML: &str = include_str!("../../../lenses/default.toml");
/// The ideal thin lens, `--lens ideal`: the renderers' camera (lenses/ideal.toml).
pub const IDEAL_LENS_TOML: &str = include_str!("../../../lenses/ideal.toml");

impl LensFile {
    /// The prescription the file carries (its `[[surface]]` tables), checked as
    /// `realcam lens analyze` would.
    pub fn prescription(
        &self,
        path: &Path,
        text: &str,
    ) -> Result<crate::optics::prescription::Prescription, crate::optics::prescription::PrescriptionError> {
        crate::optics::prescription::Prescription::from_specs(
            &self.name,
            &self.surfaces,
            text,
            &path.display().to_string(),
        )
    }

    /// Whether `n` is an f-number this lens has (1% either way for rounding): the f-number at
    /// which its blur tables or its spherical aberration were measured must be, or scaling them
    /// to the lens's own f-numbers would blow them up.
    fn is_own_f_number(&self, n: f64) -> bool {
        n.is_finite() && n >= 0.99 * self.f_number_min && n <= 1.01 * self.f_number_max
    }

    fn f_number_range(&self) -> String {
        format!("f/{} to f/{}", Num(self.f_number_min), Num(self.f_number_max))
    }

    pub fn load(path: &Path) -> Result<LensFile, LensFileError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| LensFileError::Read { path: path.to_path_buf(), source })?;
        Self::parse(&text, path)
    }

    /// A lens built into realcam by name: `default` or `ideal`.
    pub fn built_in(name: &str) -> Option<LensFile> {
        let (text, path) = match name {
            "default" => (DEFAULT_LENS_TOML, "lenses/default.toml"),
            "ideal" => (IDEAL_LENS_TOML, "lenses/ideal.toml"),
            _ => return None,
        };
        Self::parse(text, Path::new(path)).ok()
    }

    pub fn default_lens() -> LensFile {
        // The embedded default is checked by a unit test, so this cannot fail at run time.
        Self::parse(DEFAULT_LENS_TOML, Path::new("lenses/default.toml")).unwrap_or_else(|e| panic!("{e}"))
    }

    pub fn parse(text: &str, path: &Path) -> Result<LensFile, LensFileError> {
        let lens: LensFile = toml::from_str(text).map_err(|e| {
            let (line, message) = crate::optics::prescription::toml_error(text, &e);
            LensFileError::Parse { path: path.to_path_buf(), line, message }
        })?;
        lens.validate(path, text)?;
        FittedGhostSpec::validate(&lens.fitted_ghosts, path, text)?;
        Ok(lens)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ideal_lens_is_any_thin_lens_without_aberrations() {
        let ideal = LensFile::built_in("ideal").unwrap();
        assert!(ideal.ideal && ideal.tables.is_none() && ideal.spherical_aberration == 0.0);
        assert_eq!((ideal.aperture.blades, ideal.aperture.curvature), (0, 0.0));
        assert_eq!(LensFile::built_in("default").unwrap(), LensFile::default_lens());
        assert!(LensFile::built_in("tessar").is_none());
    }

    #[test]
    fn default_lens_parses() {
        let lens = LensFile::default_lens();
        assert!(lens.focal_length_mm > 0.0);
    }

    #[test]
    fn syntax_error_names_file_and_line() {
        let text = "name = \"x\"\nsource = \"y\"\nfocal_length_mm = = 50\n";
        let err = LensFile::parse(text, Path::new("bad.toml")).unwrap_err().to_string();
        assert!(err.starts_with("lens file bad.toml, line 3:"), "{err}");
    }

    #[test]
    fn unknown_key_names_the_key_and_line() {
        let text = "name = \"x\"\nsource = \"y\"\nfocal_length_mm = 50\nf_number_min = 1.4\nf_number_max = 16\nfocus_min_m = 0.45\nfocal_lenght = 3\n[aperture]\nblades = 9\n";
        let err = LensFile::parse(text, Path::new("l.toml")).unwrap_err().to_string();
        assert!(err.contains("line 7") && err.contains("focal_lenght"), "{err}");
    }

    #[test]
    fn blades_round_wide_open_and_polygonal_stopped_down() {
        let text = "name = \"x\"\nsource = \"y\"\nfocal_length_mm = 50\nf_number_min = 1.4\nf_number_max = 16\nfocus_min_m = 0.45\n[aperture]\nblades = 9\ncurvature = 0.2\ncurvature_wide_open = 1.0\npolygonal_from_f_number = 5.6\n";
        let lens = LensFile::parse(text, Path::new("l.toml")).unwrap();
        let a = lens.aperture;
        assert_eq!(a.curvature_at(1.4, 1.4), 1.0);
        assert_eq!(a.curvature_at(8.0, 1.4), 0.2);
        // f/2.8 is one of the two stops between f/1.4 and f/5.6: halfway.
        assert!((a.curvature_at(2.8, 1.4) - 0.6).abs() < 1e-12);
    }

    #[test]
    fn tables_must_increase_and_match_in_length() {
        let head = "name = \"x\"\nsource = \"y\"\nfocal_length_mm = 50\nf_number_min = 1.4\nf_number_max = 16\nfocus_min_m = 0.45\n[aperture]\nblades = 9\n[tables]\n";
        let text = format!("{head}image_height_mm = [0, 10, 5]\ndistortion_percent = [0, -1, -2]\n");
        let err = LensFile::parse(&text, Path::new("t.toml")).unwrap_err().to_string();
        assert_eq!(
            err,
            "lens file t.toml, line 10: tables.image_height_mm is not increasing: 10 then 5 (entries 2 and 3)"
        );
        let text = format!("{head}image_height_mm = [0, 10, 20]\ndistortion_percent = [0, -1]\n");
        let err = LensFile::parse(&text, Path::new("t.toml")).unwrap_err().to_string();
        assert_eq!(err, "lens file t.toml, line 11: tables.distortion_percent has 2 values but image_height_mm has 3");
        let text = format!("{head}image_height_mm = [0, 10]\ndistortion = [0, -1]\n");
        let err = LensFile::parse(&text, Path::new("t.toml")).unwrap_err().to_string();
        assert!(err.contains("line 11") && err.contains("distortion"), "{err}");
        let text = format!("{head}image_height_mm = [0, 10, 20]\ndistortion_percent = [0, -1, -2.5]\n");
        let lens = LensFile::parse(&text, Path::new("t.toml")).unwrap();
        assert_eq!(lens.tables.unwrap().distortion().green_percent.at(15.0), -1.75);
    }

    const HEAD: &str = "name = \"x\"\nsource = \"y\"\nfocal_length_mm = 50\nf_number_min = 1.4\nf_number_max = 16\nfocus_min_m = 0.45\n[aperture]\nblades = 9\n[tables]\nimage_height_mm = [0, 10, 20]\n";

    #[test]
    fn vignetting_per_f_number_interpolates_in_stops() {
        let text = format!(
            "{HEAD}[[tables.vignetting]]\nf_number = 1.4\nrelative_illumination = [1, 0.7, 0.4]\n\
             [[tables.vignetting]]\nf_number = 5.6\nrelative_illumination = [1, 0.9, 0.8]\n"
        );
        let t = LensFile::parse(&text, Path::new("v.toml")).unwrap().tables.unwrap();
        // f/2.8 is one of two stops from f/1.4 to f/5.6: halfway.
        assert!((t.relative_illumination(2.8).unwrap().at(20.0) - 0.6).abs() < 1e-12);
        assert_eq!(t.relative_illumination(1.0).unwrap().at(10.0), 0.7);
        assert_eq!(t.relative_illumination(11.0).unwrap().at(10.0), 0.9);
        let bad = format!(
            "{HEAD}[[tables.vignetting]]\nf_number = 4\nrelative_illumination = [1, 0.7, 0.4]\n\
             [[tables.vignetting]]\nf_number = 2\nrelative_illumination = [1, 0.9, 0.8]\n"
        );
        let err = LensFile::parse(&bad, Path::new("v.toml")).unwrap_err().to_string();
        assert_eq!(
            err,
            "lens file v.toml, line 14: tables.vignetting entries must have increasing f-numbers: f/2 after f/4"
        );
        let bad = format!("{HEAD}[[tables.vignetting]]\nf_number = 4\nrelative_illumination = [1, 0.7]\n");
        let err = LensFile::parse(&bad, Path::new("v.toml")).unwrap_err().to_string();
        assert_eq!(err, "lens file v.toml, line 11: tables.vignetting at f/4 has 2 values but image_height_mm has 3");
    }

    #[test]
    fn blur_tables_scale_with_the_aperture() {
        let text = format!("{HEAD}at_f_number = 2.8\ncoma_mm = [0, 0.02, 0.04]\n");
        let t = LensFile::parse(&text, Path::new("c.toml")).unwrap().tables.unwrap();
        // coma grows with the square of the pupil diameter: f/5.6 has a quarter of f/2.8's
        assert!((t.coma(5.6).unwrap().at(20.0) - 0.01).abs() < 1e-15);
        assert_eq!(t.blur_scale(1.4), 2.0);
    }

    #[test]
    fn lens_file_carries_a_prescription() {
        let text = format!(
            "{}[[surface]]\nradius_mm = 50\nthickness_mm = 5\nn_d = 1.5\nsemi_diameter_mm = 10\nstop = true\n\
             [[surface]]\nradius_mm = -50\nthickness_mm = 48\nsemi_diameter_mm = 10\n",
            HEAD.replace("[tables]\nimage_height_mm = [0, 10, 20]\n", "")
        );
        let lens = LensFile::parse(&text, Path::new("p.toml")).unwrap();
        let p = lens.prescription(Path::new("p.toml"), &text).unwrap();
        assert_eq!(p.surfaces.len(), 2);
        let bad = text.replace("n_d = 1.5", "n_d = 0.5");
        let err = LensFile::parse(&bad, Path::new("p.toml")).unwrap_err().to_string();
        assert_eq!(err, "lens file p.toml:9: surface 0: n_d = 0.5 must be >= 1");
        let bad = format!("{text}[longitudinal_color]\nred_mm = 20\nblue_mm = 0\n");
        let err = LensFile::parse(&bad, Path::new("p.toml")).unwrap_err().to_string();
        assert!(err.contains("longitudinal_color.red_mm = 20"), "{err}");
    }

    #[test]
    fn flare_settings_default_and_are_checked() {
        let head = "name = \"x\"\nsource = \"y\"\nfocal_length_mm = 50\nf_number_min = 1.4\nf_number_max = 16\nfocus_min_m = 0.45\n[aperture]\nblades = 9\n";
        let lens = LensFile::parse(head, Path::new("f.toml")).unwrap();
        assert_eq!(lens.flare, FlareSpec::default());
        assert_eq!(lens.flare.coating_nm(), Some(550.0));
        let text = format!("{head}[flare]\ncoating_design_nm = 0\nhalo_fraction = 0.02\n");
        let lens = LensFile::parse(&text, Path::new("f.toml")).unwrap();
        assert_eq!((lens.flare.coating_nm(), lens.flare.halo_fraction, lens.flare.halo_radius_mm), (None, 0.02, 0.1));
        let err = |extra: &str| {
            LensFile::parse(&format!("{head}[flare]\n{extra}\n"), Path::new("f.toml")).unwrap_err().to_string()
        };
        assert_eq!(
            err("coating_design_nm = 50"),
            "lens file f.toml: flare.coating_design_nm = 50 must be 0 (uncoated) or a wavelength in 200..2000 nm"
        );
        assert_eq!(err("halo_fraction = 0.9"), "lens file f.toml: flare.halo_fraction = 0.9 must be in [0, 0.5]");
        assert_eq!(err("halo_radius_mm = -1"), "lens file f.toml: flare.halo_radius_mm = -1 must be a positive length");
        assert!(err("halo = 1").contains("line 10"), "{}", err("halo = 1"));
    }

    #[test]
    fn every_table_has_its_own_range_and_unit() {
        let cases = [
            (
                "relative_illumination = [1, 0.5, -0.2]",
                "tables.relative_illumination value -0.2 is out of range (in (0, 2])",
            ),
            (
                "relative_illumination = [1, 2.5, 1]",
                "tables.relative_illumination value 2.5 is out of range (in (0, 2])",
            ),
            ("coma_mm = [0, 49, 0]", "tables.coma_mm value 49 is out of range (-5..5 mm, a tenth of the focal length)"),
            (
                "field_curvature_mm = [0, -6, 0]",
                "tables.field_curvature_mm value -6 is out of range (-5..5 mm, a tenth of the focal length)",
            ),
            (
                "tangential_blur_mm = [0, 0.01, -0.01]",
                "tables.tangential_blur_mm value -0.01 is out of range (from 0 to 5 mm, a tenth of the focal length)",
            ),
            (
                "sagittal_blur_mm = [0, 49, 0]",
                "tables.sagittal_blur_mm value 49 is out of range (from 0 to 5 mm, a tenth of the focal length)",
            ),
            (
                "distortion_percent = [0, 1e300, 0]",
                "tables.distortion_percent value 1e300 is out of range (-50..50 percent)",
            ),
        ];
        for (line, message) in cases {
            let err = LensFile::parse(&format!("{HEAD}{line}\n"), Path::new("t.toml")).unwrap_err().to_string();
            assert_eq!(err, format!("lens file t.toml, line 11: {message}"));
        }
        let err = LensFile::parse(&format!("{HEAD}at_f_number = 1e308\ncoma_mm = [0, 1, 2]\n"), Path::new("t.toml"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "lens file t.toml, line 11: tables.at_f_number = 1e308 must be an f-number of the lens (f/1.4 to f/16)"
        );
        let ok = format!("{HEAD}relative_illumination = [1, 1.1, 0.4]\ncoma_mm = [0, -4.9, 4.9]\n");
        LensFile::parse(&ok, Path::new("t.toml")).unwrap();
    }

    #[test]
    fn bad_values_and_characters_are_named() {
        let head = "name = \"x\"\nsource = \"y\"\nfocal_length_mm = 50\nf_number_min = 1.4\nf_number_max = 16\nfocus_min_m = 0.45\n[aperture]\nblades = 9\n";
        for (value, shown) in [("nan", "NaN"), ("inf", "inf"), ("-inf", "-inf")] {
            let err = LensFile::parse(&format!("{head}rotation_deg = {value}\n"), Path::new("r.toml")).unwrap_err();
            assert_eq!(
                err.to_string(),
                format!("lens file r.toml: aperture.rotation_deg = {shown} must be a finite angle in degrees")
            );
        }
        let err = LensFile::parse(&format!("{head}# a comment \0 with NUL\n"), Path::new("n.toml")).unwrap_err();
        assert_eq!(
            err.to_string(),
            "lens file n.toml, line 9: control character U+0000 is not allowed in a TOML file, not even in a comment"
        );
        let big = head
            .replace("f_number_max = 16", "f_number_max = 1e308")
            .replace("f_number_min = 1.4", "f_number_min = inf");
        let err = LensFile::parse(&big, Path::new("b.toml")).unwrap_err();
        assert_eq!(err.to_string(), "lens file b.toml: f_number_min = inf must be a positive number");
    }

    #[test]
    fn out_of_range_values_are_rejected() {
        let text = "name = \"x\"\nsource = \"y\"\nfocal_length_mm = 50\nf_number_min = 4\nf_number_max = 2\nfocus_min_m = 0.45\n[aperture]\nblades = 9\n";
        let err = LensFile::parse(text, Path::new("l.toml")).unwrap_err().to_string();
        assert_eq!(err, "lens file l.toml: f_number_max = 2 is below f_number_min = 4");
    }
}
