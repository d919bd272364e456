//! A parsed lens file checked: every number in its range, the tables consistent, the
//! prescription valid. Errors name the key, and its line where it is known.

use super::{header_line, LensFile, LensFileError, LensTables};
use crate::optics::Num;
use std::path::Path;

impl LensFile {
    pub(super) fn validate(&self, path: &Path, text: &str) -> Result<(), LensFileError> {
        let bad = |message: String| Err(LensFileError::Invalid { path: path.to_path_buf(), message });
        if let Some(t) = &self.tables {
            self.validate_tables(t, path, text)?;
        }
        // The name goes into every output's EXR header (lensModel), whose text is Latin-1.
        if let Some(c) = self.name.chars().find(|&c| u32::from(c) > 0xff) {
            return bad(format!(
                "name = {:?} has the character {c:?} (U+{:04X}), outside Latin-1, which EXR headers (lensModel) cannot hold",
                self.name,
                u32::from(c)
            ));
        }
        let positive = [
            ("focal_length_mm", self.focal_length_mm),
            ("f_number_min", self.f_number_min),
            ("f_number_max", self.f_number_max),
            ("focus_min_m", self.focus_min_m),
            ("pupil_magnification", self.pupil_magnification),
        ];
        for (key, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return bad(format!("{key} = {} must be a positive number", Num(value)));
            }
        }
        // Finite but beyond any lens: refused here, where the file is named, not later by the
        // optics with no file (issue 34: focal_length_mm = 1e308).
        let at_most =
            [("focal_length_mm", self.focal_length_mm, 1e6, "1 km"), ("focus_min_m", self.focus_min_m, 1e6, "1000 km")];
        for (key, value, limit, words) in at_most {
            if value > limit {
                return bad(format!("{key} = {} must be at most {} ({words})", Num(value), Num(limit)));
            }
        }
        if self.f_number_max < self.f_number_min {
            return bad(format!(
                "f_number_max = {} is below f_number_min = {}",
                Num(self.f_number_max),
                Num(self.f_number_min)
            ));
        }
        if !self.aperture.rotation_deg.is_finite() {
            return bad(format!(
                "aperture.rotation_deg = {} must be a finite angle in degrees",
                self.aperture.rotation_deg
            ));
        }
        if !(self.transmittance > 0.0 && self.transmittance <= 1.0) {
            return bad(format!("transmittance = {} must be in (0, 1]", self.transmittance));
        }
        if self.aperture.blades > 32 || self.aperture.blades == 1 || self.aperture.blades == 2 {
            return bad(format!("aperture.blades = {} must be 0 (circular) or 3..32", self.aperture.blades));
        }
        if !(-1.0..=1.0).contains(&self.spherical_aberration) {
            return bad(format!("spherical_aberration = {} must be in [-1, 1]", self.spherical_aberration));
        }
        let a = &self.aperture;
        for (key, value) in [
            ("aperture.curvature", Some(a.curvature)),
            ("aperture.curvature_wide_open", a.curvature_wide_open),
            ("aperture.cats_eye", Some(a.cats_eye)),
        ] {
            if let Some(v) = value {
                if !(0.0..=1.0).contains(&v) {
                    return bad(format!("{key} = {v} must be in [0, 1]"));
                }
            }
        }
        if let Some(l) = &self.longitudinal_spherical_aberration {
            if !(l.rim_mm.is_finite() && l.rim_mm.abs() < 0.1 * self.focal_length_mm) {
                return bad(format!(
                    "longitudinal_spherical_aberration.rim_mm = {} must be finite and below a tenth of the focal length",
                    l.rim_mm
                ));
            }
            if !self.is_own_f_number(l.at_f_number) {
                return bad(format!(
                    "longitudinal_spherical_aberration.at_f_number = {} must be an f-number of the lens ({})",
                    Num(l.at_f_number),
                    self.f_number_range()
                ));
            }
        }
        if let Some(lc) = &self.longitudinal_color {
            for (key, v) in [("red_mm", lc.red_mm), ("blue_mm", lc.blue_mm)] {
                if !(v.is_finite() && v.abs() < 0.1 * self.focal_length_mm) {
                    return bad(format!(
                        "longitudinal_color.{key} = {v} must be a finite focus shift smaller than a tenth of the focal length"
                    ));
                }
            }
        }
        if !self.surfaces.is_empty() {
            self.prescription(path, text)?;
        }
        let f = &self.flare;
        if !(f.coating_design_nm == 0.0 || (200.0..=2000.0).contains(&f.coating_design_nm)) {
            return bad(format!(
                "flare.coating_design_nm = {} must be 0 (uncoated) or a wavelength in 200..2000 nm",
                f.coating_design_nm
            ));
        }
        if !(0.0..=0.5).contains(&f.halo_fraction) {
            return bad(format!("flare.halo_fraction = {} must be in [0, 0.5]", f.halo_fraction));
        }
        if !(f.halo_radius_mm.is_finite() && f.halo_radius_mm > 0.0) {
            return bad(format!("flare.halo_radius_mm = {} must be a positive length", f.halo_radius_mm));
        }
        if let Some(h) = a.cats_eye_at_mm {
            if !(h.is_finite() && h > 0.0) {
                return bad(format!("aperture.cats_eye_at_mm = {h} must be a positive height"));
            }
        }
        if let Some(n) = a.polygonal_from_f_number {
            if !(n.is_finite() && n >= self.f_number_min) {
                return bad(format!(
                    "aperture.polygonal_from_f_number = {n} must be at least f_number_min = {}",
                    self.f_number_min
                ));
            }
        }
        Ok(())
    }

    /// The `[tables]`: increasing heights, columns of their length and range, the vignetting
    /// entries, the f-number they are for.
    fn validate_tables(&self, t: &LensTables, path: &Path, text: &str) -> Result<(), LensFileError> {
        // The line of a key, for messages about its value.
        let line_of = |key: &str| text.lines().position(|l| l.trim_start().starts_with(key)).map_or(0, |i| i + 1);
        let at = |key: &str, message: String| {
            Err(LensFileError::Parse { path: path.to_path_buf(), line: line_of(key), message })
        };
        let h = &t.image_height_mm;
        if h.is_empty() || h[0] < 0.0 || h.iter().any(|v| !v.is_finite()) {
            return at("image_height_mm", "tables.image_height_mm must be finite heights from 0 up".into());
        }
        if let Some(i) = (1..h.len()).find(|&i| h[i] <= h[i - 1]) {
            return at(
                "image_height_mm",
                format!(
                    "tables.image_height_mm is not increasing: {} then {} (entries {} and {})",
                    h[i - 1],
                    h[i],
                    i,
                    i + 1
                ),
            );
        }
        // What each table may hold: distortion in percent; lengths on the film within a
        // tenth of the focal length, as for longitudinal colour; blur lengths not negative;
        // relative illumination as [[tables.vignetting]] takes it.
        let tenth_mm = 0.1 * self.focal_length_mm;
        for (key, table) in t.columns() {
            if let Some(v) = table {
                if v.len() != h.len() {
                    return at(key, format!("tables.{key} has {} values but image_height_mm has {}", v.len(), h.len()));
                }
                let (ok, allowed): (Box<dyn Fn(f64) -> bool>, String) = match key {
                    "relative_illumination" => (Box::new(|x| x > 0.0 && x <= 2.0), "in (0, 2]".into()),
                    "tangential_blur_mm" | "sagittal_blur_mm" => (
                        Box::new(move |x| (0.0..tenth_mm).contains(&x)),
                        format!("from 0 to {} mm, a tenth of the focal length", Num(tenth_mm)),
                    ),
                    "field_curvature_mm" | "coma_mm" => (
                        Box::new(move |x| x.abs() < tenth_mm),
                        format!("-{0}..{0} mm, a tenth of the focal length", Num(tenth_mm)),
                    ),
                    _ => (Box::new(|x| x.abs() < 50.0), "-50..50 percent".into()),
                };
                if let Some(x) = v.iter().find(|x| !(x.is_finite() && ok(**x))) {
                    return at(key, format!("tables.{key} value {} is out of range ({allowed})", Num(*x)));
                }
            }
        }
        if t.relative_illumination.is_some() && !t.vignetting.is_empty() {
            return at(
                "[[tables.vignetting]]",
                "give either tables.relative_illumination or [[tables.vignetting]] entries, not both".into(),
            );
        }
        for (i, e) in t.vignetting.iter().enumerate() {
            let line = header_line(text, "[[tables.vignetting]]", i);
            let err = |message: String| Err(LensFileError::Parse { path: path.to_path_buf(), line, message });
            if !(e.f_number.is_finite() && e.f_number > 0.0) {
                return err(format!("tables.vignetting f_number = {} must be a positive number", e.f_number));
            }
            if i > 0 && e.f_number <= t.vignetting[i - 1].f_number {
                return err(format!(
                    "tables.vignetting entries must have increasing f-numbers: f/{} after f/{}",
                    e.f_number,
                    t.vignetting[i - 1].f_number
                ));
            }
            if e.relative_illumination.len() != h.len() {
                return err(format!(
                    "tables.vignetting at f/{} has {} values but image_height_mm has {}",
                    e.f_number,
                    e.relative_illumination.len(),
                    h.len()
                ));
            }
            if let Some(x) = e.relative_illumination.iter().find(|x| !(x.is_finite() && **x > 0.0 && **x <= 2.0)) {
                return err(format!(
                    "tables.vignetting at f/{}: relative illumination {x} is not in (0, 2]",
                    e.f_number
                ));
            }
        }
        if let Some(n0) = t.at_f_number.filter(|&n0| !self.is_own_f_number(n0)) {
            return at(
                "at_f_number",
                format!("tables.at_f_number = {} must be an f-number of the lens ({})", Num(n0), self.f_number_range()),
            );
        }
        Ok(())
    }
}
