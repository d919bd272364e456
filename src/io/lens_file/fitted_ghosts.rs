//! `[[fitted_ghost]]`: a lens's ghosts as Walch's measured-ghost primitives (seed 004 ch. 6),
//! each parameter a polynomial of the constellation angle (eq 8.1; ch. 8), as `realcam`'s fit
//! writes them:
//!
//! ```toml
//! [[fitted_ghost]]
//! ghost = "3/1"              # a label: the surfaces of its reflections
//! channel = 1                # 0 red, 1 green, 2 blue
//! frame_px = [1280, 720]     # the frame the pixels are of
//! angles_deg = [1.0, 8.0]    # the fitted range of the constellation angle
//! centre_x_px = [640.0, -12.5, 0.03]   # c0 + c1 a + c2 a^2, a in degrees
//! # ... one array for each of src/optics/bezier_ghost.rs's PARAM_NAMES
//! ```
//!
//! Positions are frame pixels with the light towards +x of the centre (eq 8.2's roll turns
//! the whole flare about the centre to the light's own direction).

use super::write::LensFileWriter;
use super::LensFileError;
use crate::optics::bezier_ghost::{GhostPolynomials, PARAMS, PARAM_NAMES};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;
use toml_edit::{Array, ArrayOfTables, Item, Table, Value};

/// One `[[fitted_ghost]]` (unknown keys land among the coefficients, and `validate` names
/// them: serde's deny_unknown_fields does not work beside a flattened map).
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct FittedGhostSpec {
    pub ghost: String,
    pub channel: u32,
    pub frame_px: [u32; 2],
    pub angles_deg: [f64; 2],
    /// Each parameter's coefficients, by name ([`PARAM_NAMES`]).
    #[serde(flatten)]
    pub coefficients: BTreeMap<String, Vec<f64>>,
}

impl FittedGhostSpec {
    pub fn new(ghost: &str, channel: u32, frame_px: [u32; 2], polynomials: &GhostPolynomials) -> FittedGhostSpec {
        FittedGhostSpec {
            ghost: ghost.to_string(),
            channel,
            frame_px,
            angles_deg: polynomials.angles_deg,
            coefficients: PARAM_NAMES
                .iter()
                .zip(&polynomials.coefficients)
                .map(|(n, c)| (n.to_string(), c.clone()))
                .collect(),
        }
    }

    /// The polynomials (the spec is validated).
    pub fn polynomials(&self) -> GhostPolynomials {
        GhostPolynomials {
            angles_deg: self.angles_deg,
            coefficients: PARAM_NAMES.iter().map(|n| self.coefficients.get(*n).cloned().unwrap_or_default()).collect(),
        }
    }

    /// Every parameter present once with 1..=4 finite coefficients, no unknown one, a known
    /// channel, a range of angles; errors name the line of the entry's header.
    pub fn validate(specs: &[FittedGhostSpec], path: &Path, text: &str) -> Result<(), LensFileError> {
        for (i, g) in specs.iter().enumerate() {
            let line = super::header_line(text, "[[fitted_ghost]]", i);
            let err = |message: String| Err(LensFileError::Parse { path: path.to_path_buf(), line, message });
            if g.channel > 2 {
                return err(format!(
                    "fitted_ghost {:?}: channel = {} must be 0 (red), 1 (green) or 2 (blue)",
                    g.ghost, g.channel
                ));
            }
            let [a, b] = g.angles_deg;
            if !(a.is_finite() && b.is_finite() && a <= b) {
                return err(format!(
                    "fitted_ghost {:?}: angles_deg = [{a}, {b}] must be a range from low to high",
                    g.ghost
                ));
            }
            if let Some(k) = g.coefficients.keys().find(|k| !PARAM_NAMES.contains(&k.as_str())) {
                return err(format!(
                    "fitted_ghost {:?}: unknown key {k:?} (the parameters are {})",
                    g.ghost,
                    PARAM_NAMES.join(", ")
                ));
            }
            for name in PARAM_NAMES {
                match g.coefficients.get(name) {
                    None => return err(format!("fitted_ghost {:?}: {name} is missing", g.ghost)),
                    Some(c) if c.is_empty() || c.len() > 4 || c.iter().any(|v| !v.is_finite()) => {
                        return err(format!(
                            "fitted_ghost {:?}: {name} must be 1 to 4 finite polynomial coefficients",
                            g.ghost
                        ))
                    }
                    Some(_) => {}
                }
            }
        }
        debug_assert_eq!(PARAM_NAMES.len(), PARAMS);
        Ok(())
    }
}

impl LensFileWriter {
    /// `[[fitted_ghost]]` entries, replacing the file's; the numbers as f64 writes them (a
    /// polynomial's higher coefficients are small, and rounding them would move the ghost).
    pub fn fitted_ghosts(&mut self, specs: &[FittedGhostSpec], note: Option<&str>) -> &mut Self {
        let mut entries = ArrayOfTables::new();
        for (i, g) in specs.iter().enumerate() {
            let mut t = Table::new();
            t.insert("ghost", Item::Value(Value::from(g.ghost.as_str())));
            t.insert("channel", Item::Value(Value::from(g.channel as i64)));
            t.insert("frame_px", Item::Value(Value::Array(g.frame_px.iter().map(|&v| v as i64).collect::<Array>())));
            t.insert("angles_deg", Item::Value(Value::Array(g.angles_deg.iter().copied().collect::<Array>())));
            for name in PARAM_NAMES {
                if let Some(c) = g.coefficients.get(name) {
                    t.insert(name, Item::Value(Value::Array(c.iter().copied().collect::<Array>())));
                }
            }
            if i == 0 {
                if let Some(note) = note {
                    let lines: String = note.lines().map(|l| format!("# {l}\n")).collect();
                    t.decor_mut().set_prefix(format!("\n{lines}"));
                }
            }
            entries.push(t);
        }
        self.array_section("fitted_ghost", entries)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::lens_file::LensFile;

    const TESSAR: &str = include_str!("../../../lenses/tessar-walch-lens.toml");

    fn spec() -> FittedGhostSpec {
        let coefficients: Vec<Vec<f64>> =
            (0..PARAMS).map(|k| vec![1.0 + k as f64 / 3.0, -0.1 * k as f64, 1.0e-4 / (k as f64 + 7.0)]).collect();
        let p = GhostPolynomials { angles_deg: [1.0, 8.0], coefficients };
        FittedGhostSpec::new("3/1", 1, [1280, 720], &p)
    }

    #[test]
    fn the_fitted_ghost_section_round_trips() {
        let mut w = LensFileWriter::edit(TESSAR).unwrap();
        let specs = vec![spec(), FittedGhostSpec { ghost: "5/2".into(), channel: 2, ..spec() }];
        w.fitted_ghosts(&specs, Some("Fitted by realcam to the traced ghosts."));
        let text = w.finish();
        let lens = LensFile::parse(&text, Path::new("round-trip.toml")).unwrap();
        assert_eq!(lens.fitted_ghosts, specs);
        // Every coefficient back bit for bit, and the polynomials the same.
        assert_eq!(lens.fitted_ghosts[0].polynomials(), specs[0].polynomials());
        assert!(text.contains("# Fitted by realcam to the traced ghosts.\n[[fitted_ghost]]"));
        // The rest of the lens is unchanged.
        let original = LensFile::parse(TESSAR, Path::new("tessar.toml")).unwrap();
        assert_eq!(LensFile { fitted_ghosts: Vec::new(), ..lens }, original);
        // Written again: the same text.
        let mut again = LensFileWriter::edit(&text).unwrap();
        again.fitted_ghosts(&specs, Some("Fitted by realcam to the traced ghosts."));
        assert_eq!(again.finish(), text);
    }

    #[test]
    fn a_bad_fitted_ghost_names_the_line_and_the_key() {
        let mut w = LensFileWriter::edit(TESSAR).unwrap();
        let mut bad = spec();
        bad.coefficients.remove("height_px");
        w.fitted_ghosts(&[spec(), bad], None);
        let text = w.finish();
        let e = LensFile::parse(&text, Path::new("bad.toml")).unwrap_err().to_string();
        let line = text.lines().enumerate().filter(|(_, l)| l.starts_with("[[fitted_ghost]]")).nth(1).unwrap().0 + 1;
        assert_eq!(e, format!("lens file bad.toml, line {line}: fitted_ghost \"3/1\": height_px is missing"));
        let text = text.replace("channel = 2", "channel = 5").replace("channel = 1", "channel = 3");
        let e = LensFile::parse(&text, Path::new("bad.toml")).unwrap_err().to_string();
        assert!(e.contains("channel = 3 must be 0 (red), 1 (green) or 2 (blue)"), "{e}");
    }
}
