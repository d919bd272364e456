//! The one writer of lens files, on `toml_edit`: a new file (a lensfun import, a lens file
//! derived from a bare prescription) or an existing one edited in place, where everything the
//! writer does not set (other keys, tables, the user's comments) is kept.
//!
//! Numbers are rounded to a fixed number of decimals and written in their shortest form
//! ("0.0", "-1.06689", "22.0"), so that a traced value does not carry 17 digits: heights in the
//! tables 4 decimals, the tables' values 5, `at_f_number` 4, a vignetting entry's f-number 3,
//! focus shifts in mm 6, the cat's eye and its height 4; the settings at the top level take
//! their decimals from the caller. Comments (where a number comes from, `ASSUMED` for what a
//! source does not give, units) go on the lines above the key or table they are about.

use toml_edit::{Array, ArrayOfTables, DocumentMut, Item, Table, TableLike, TomlError, Value};

use super::{LensTables, LongitudinalColorSpec, LsaSpec};
use crate::optics::prescription::{DerivedTables, LensAnalysis, LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM};

/// Decimals of `tables.image_height_mm`.
const HEIGHT_DECIMALS: u32 = 4;
/// Decimals of the values of the tables (percent, mm, relative illumination).
const TABLE_DECIMALS: u32 = 5;
/// Decimals of `tables.at_f_number` and `longitudinal_spherical_aberration.at_f_number`.
const AT_F_NUMBER_DECIMALS: u32 = 4;
/// Decimals of the f-number of a `[[tables.vignetting]]` entry.
const VIGNETTING_F_NUMBER_DECIMALS: u32 = 3;
/// Decimals of focus shifts in mm (`longitudinal_color`, `longitudinal_spherical_aberration`).
const FOCUS_SHIFT_DECIMALS: u32 = 6;
/// Decimals of `aperture.cats_eye` and `aperture.cats_eye_at_mm`.
const CATS_EYE_DECIMALS: u32 = 4;

/// `x` rounded to `decimals` places, halves away from zero; -0 becomes 0.
pub fn rounded(x: f64, decimals: u32) -> f64 {
    let scale = 10f64.powi(decimals as i32);
    (x * scale).round() / scale + 0.0
}

/// `x` rounded to `decimals` places and written as the writer writes numbers, for comments.
pub fn number_text(x: f64, decimals: u32) -> String {
    Value::from(rounded(x, decimals)).to_string()
}

/// `text` as TOML comment lines ("# " before each line, "#" alone for an empty one).
fn comment_lines(text: &str) -> String {
    text.lines().map(|l| if l.is_empty() { "#\n".to_string() } else { format!("# {l}\n") }).collect()
}

fn numbers(values: &[f64], decimals: u32) -> Value {
    Value::Array(values.iter().map(|v| rounded(*v, decimals)).collect::<Array>())
}

/// A lens file being written. Keys are set with [`string`](Self::string),
/// [`number`](Self::number) and [`integer`](Self::integer), by name at the top level or as
/// `table.key` (`aperture.blades`); a section ([`tables`](Self::tables),
/// [`longitudinal_color`](Self::longitudinal_color), ...) replaces the one the file had and goes
/// after everything else, in the order written.
pub struct LensFileWriter {
    doc: DocumentMut,
    /// The sections this writer appended: the file's trailing comments go before the first.
    appended: Vec<&'static str>,
}

impl LensFileWriter {
    /// A new lens file that starts with the comment `header` (plain text; each line becomes a
    /// comment line).
    pub fn new(header: &str) -> LensFileWriter {
        let mut doc = DocumentMut::new();
        doc.decor_mut().set_prefix(comment_lines(header));
        LensFileWriter { doc, appended: Vec::new() }
    }

    /// An existing lens file (or prescription) to edit.
    pub fn edit(text: &str) -> Result<LensFileWriter, TomlError> {
        Ok(LensFileWriter { doc: text.parse()?, appended: Vec::new() })
    }

    /// Sets the string `path` (`key` or `table.key`); `note`, if given, becomes the comment
    /// above it.
    pub fn string(&mut self, path: &str, value: &str, note: Option<&str>) -> &mut Self {
        self.set(path, Value::from(value), note)
    }

    /// Sets the number `path` to `value` rounded to `decimals` places.
    pub fn number(&mut self, path: &str, value: f64, decimals: u32, note: Option<&str>) -> &mut Self {
        self.set(path, Value::from(rounded(value, decimals)), note)
    }

    /// Sets the integer `path`.
    pub fn integer(&mut self, path: &str, value: i64, note: Option<&str>) -> &mut Self {
        self.set(path, Value::from(value), note)
    }

    /// Sets `path` to `value`. A value already there keeps its comments (above the key and
    /// after the value) unless `note` replaces those above. The `table` of `table.key` is made
    /// if missing (after everything else), and replaced if it is not a table.
    fn set(&mut self, path: &str, mut value: Value, note: Option<&str>) -> &mut Self {
        let (table, key, inline, dotted): (&mut dyn TableLike, &str, bool, bool) = match path.split_once('.') {
            None => (self.doc.as_table_mut(), path, false, false),
            Some((name, key)) => {
                let item = self.doc.entry(name).or_insert(Item::Table(Table::new()));
                if !item.is_table_like() {
                    *item = Item::Table(Table::new());
                }
                let (inline, dotted) = (item.is_inline_table(), item.as_table().is_some_and(Table::is_dotted));
                let Some(table) = item.as_table_like_mut() else {
                    return self;
                };
                (table, key, inline, dotted)
            }
        };
        // Inside `name = { ... }` the old value's spacing belongs to its place in the braces.
        if let Some(old) = table.get(key).and_then(Item::as_value).filter(|_| !inline) {
            *value.decor_mut() = old.decor().clone();
        }
        // Comment lines fit above a key of a [table], not inside `name = { ... }` or before the
        // last part of a dotted key `name.key = ...`.
        let comments_fit = !inline && !dotted;
        table.insert(key, Item::Value(value));
        if let (Some(note), true, Some(mut key)) = (note, comments_fit, table.key_mut(key)) {
            key.leaf_decor_mut().set_prefix(comment_lines(note));
        }
        self
    }

    /// Replaces the section `name` by `table`, after everything else; `note` above its header.
    fn section(&mut self, name: &'static str, mut table: Table, note: Option<&str>) -> &mut Self {
        self.doc.remove(name);
        table.decor_mut().set_prefix(format!("\n{}", note.map(comment_lines).unwrap_or_default()));
        self.doc.insert(name, Item::Table(table));
        self.appended.push(name);
        self
    }

    /// Replaces the array of tables `name` by `entries`, after everything else.
    pub(super) fn array_section(&mut self, name: &'static str, entries: ArrayOfTables) -> &mut Self {
        self.doc.remove(name);
        self.doc.insert(name, Item::ArrayOfTables(entries));
        self.appended.push(name);
        self
    }

    /// `[tables]`, with its `[[tables.vignetting]]` entries.
    pub fn tables(&mut self, tables: &LensTables, note: Option<&str>) -> &mut Self {
        let mut table = Table::new();
        if let Some(n) = tables.at_f_number {
            table.insert("at_f_number", Item::Value(Value::from(rounded(n, AT_F_NUMBER_DECIMALS))));
        }
        table.insert("image_height_mm", Item::Value(numbers(&tables.image_height_mm, HEIGHT_DECIMALS)));
        for (key, values) in tables.columns() {
            if let Some(values) = values {
                table.insert(key, Item::Value(numbers(values, TABLE_DECIMALS)));
            }
        }
        if !tables.vignetting.is_empty() {
            let mut entries = ArrayOfTables::new();
            for e in &tables.vignetting {
                let mut entry = Table::new();
                entry.insert("f_number", Item::Value(Value::from(rounded(e.f_number, VIGNETTING_F_NUMBER_DECIMALS))));
                entry.insert("relative_illumination", Item::Value(numbers(&e.relative_illumination, TABLE_DECIMALS)));
                entries.push(entry);
            }
            table.insert("vignetting", Item::ArrayOfTables(entries));
        }
        self.section("tables", table, note)
    }

    /// `[longitudinal_color]`.
    pub fn longitudinal_color(&mut self, color: &LongitudinalColorSpec, note: Option<&str>) -> &mut Self {
        let mut table = Table::new();
        table.insert("red_mm", Item::Value(Value::from(rounded(color.red_mm, FOCUS_SHIFT_DECIMALS))));
        table.insert("blue_mm", Item::Value(Value::from(rounded(color.blue_mm, FOCUS_SHIFT_DECIMALS))));
        self.section("longitudinal_color", table, note)
    }

    /// `[longitudinal_spherical_aberration]`.
    pub fn longitudinal_spherical_aberration(&mut self, lsa: &LsaSpec, note: Option<&str>) -> &mut Self {
        let mut table = Table::new();
        table.insert("rim_mm", Item::Value(Value::from(rounded(lsa.rim_mm, FOCUS_SHIFT_DECIMALS))));
        table.insert("at_f_number", Item::Value(Value::from(rounded(lsa.at_f_number, AT_F_NUMBER_DECIMALS))));
        self.section("longitudinal_spherical_aberration", table, note)
    }

    /// The `[[surface]]` tables of the prescription `text` as written there (comments and the
    /// numbers' spelling kept), after everything else.
    pub fn surfaces_from(&mut self, text: &str) -> Result<&mut Self, TomlError> {
        let prescription: DocumentMut = text.parse()?;
        if let Some(surfaces) = prescription.get("surface") {
            self.doc.remove("surface");
            self.doc.insert("surface", surfaces.clone());
            // Comments after the last surface stay after it.
            let trailing = prescription.trailing().as_str().unwrap_or_default();
            if !trailing.trim().is_empty() {
                self.doc.set_trailing(trailing);
            }
        }
        Ok(self)
    }

    /// What `realcam lens analyze --write-tables` derives from a trace
    /// ([`LensAnalysis::derived_tables`]): the cat's eye in `[aperture]`, `[longitudinal_color]`,
    /// `[longitudinal_spherical_aberration]` and `[tables]`; `source` names the prescription.
    pub fn derived_tables(&mut self, derived: &DerivedTables, source: &str) -> &mut Self {
        let d = derived;
        self.number("aperture.cats_eye", d.cats_eye, CATS_EYE_DECIMALS, None);
        self.number("aperture.cats_eye_at_mm", d.cats_eye_at_mm, CATS_EYE_DECIMALS, None);
        let note = format!(
            "Derived by realcam lens analyze from {source} at f/{:.3}:\n\
             real ray tracing in f64, d line ({LAMBDA_D_NM} nm) with C ({LAMBDA_C_NM}) and F ({LAMBDA_F_NM} nm) for colour.",
            d.f_number
        );
        let color = LongitudinalColorSpec { red_mm: d.longitudinal_color_mm[0], blue_mm: d.longitudinal_color_mm[1] };
        self.longitudinal_color(&color, Some(&note));
        let lsa = LsaSpec { rim_mm: d.lsa_rim_mm, at_f_number: d.f_number };
        self.longitudinal_spherical_aberration(&lsa, Some("fit LSA = k h^2 over the traced zones, at the rim"));
        let tables = LensTables {
            image_height_mm: d.image_height_mm.clone(),
            distortion_percent: Some(d.distortion_percent.clone()),
            lateral_color_red_percent: Some(d.lateral_color_red_percent.clone()),
            lateral_color_blue_percent: Some(d.lateral_color_blue_percent.clone()),
            relative_illumination: Some(d.relative_illumination.clone()),
            tangential_blur_mm: Some(d.tangential_blur_mm.clone()),
            sagittal_blur_mm: Some(d.sagittal_blur_mm.clone()),
            field_curvature_mm: Some(d.field_curvature_mm.clone()),
            coma_mm: Some(d.coma_mm.clone()),
            at_f_number: Some(d.f_number),
            vignetting: Vec::new(),
        };
        self.tables(&tables, None)
    }

    /// The file's text. Comments that ended the file before the writer appended sections stay
    /// where they were, before those sections.
    pub fn finish(mut self) -> String {
        let trailing = self.doc.trailing().as_str().unwrap_or_default().trim_end().to_string();
        let first = self.doc.iter().map(|(k, _)| k).find(|k| self.appended.contains(k)).map(str::to_string);
        if let Some(first) = first {
            self.doc.set_trailing("");
            if let Some(table) = self.doc.get_mut(&first).and_then(Item::as_table_mut) {
                if !trailing.trim().is_empty() {
                    let prefix = table.decor().prefix().and_then(|p| p.as_str()).unwrap_or_default().to_string();
                    table.decor_mut().set_prefix(format!("{trailing}\n{prefix}"));
                }
            }
        }
        self.doc.to_string()
    }
}

/// A lens file's text with the `[tables]`, `[longitudinal_color]`,
/// `[longitudinal_spherical_aberration]` and cat's eye a prescription implies.
///
/// `text` is a lens file (`is_lens_file`; its other settings and comments are kept, those
/// sections replaced) or a bare prescription (then the settings are derived from the trace:
/// focal length = EFL, widest aperture = the analysed f-number, P from the pupils; closest
/// focus and blades are not in a prescription and are marked as assumptions).
pub fn with_derived_tables(
    text: &str,
    is_lens_file: bool,
    analysis: &LensAnalysis,
    derived: &DerivedTables,
    source: &str,
) -> Result<String, TomlError> {
    let mut writer = if is_lens_file {
        LensFileWriter::edit(text)?
    } else {
        let p = &analysis.paraxial;
        let efl = p.efl_mm;
        let mut w = LensFileWriter::new(&format!(
            "Lens file derived by realcam lens analyze from the prescription {source}.\n\
             focus_min_m (10 focal lengths) and the circular aperture are assumptions: a\n\
             prescription does not give them. Everything else is traced."
        ));
        w.string("name", &analysis.name, None)
            .string("source", &format!("realcam lens analyze of {source}"), None)
            .number("focal_length_mm", efl, 3, None)
            .number("f_number_min", analysis.f_number, 3, None)
            .number("f_number_max", 22.0, 3, None)
            .number("focus_min_m", 10.0 * efl / 1000.0, 3, None)
            .number("pupil_magnification", p.pupil_magnification, 4, None)
            .integer("aperture.blades", 0, None);
        w.surfaces_from(text)?;
        w
    };
    writer.derived_tables(derived, source);
    Ok(writer.finish())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::lens_file::{IlluminationAt, LensFile};
    use crate::optics::prescription::Prescription;
    use std::path::Path;

    /// Numbers with more digits than any of the writer's precisions.
    fn thirds(n: usize, scale: f64) -> Vec<f64> {
        (0..n).map(|i| scale * i as f64 / 3.0).collect()
    }

    fn rounded_all(values: &[f64], decimals: u32) -> Vec<f64> {
        values.iter().map(|v| rounded(*v, decimals)).collect()
    }

    #[test]
    fn numbers_are_rounded_and_written_short() {
        assert_eq!(rounded(0.123_456, 5), 0.12346);
        assert_eq!(rounded(-0.125, 2), -0.13);
        assert_eq!(number_text(1.0 / 3.0, 4), "0.3333");
        assert_eq!(number_text(1.082_04, 4), "1.082");
        assert_eq!(number_text(22.0, 3), "22.0");
        // no "-0.0" for a tiny negative value
        assert_eq!(number_text(-1e-9, 5), "0.0");
        assert_eq!(number_text(-1.066_891, 5), "-1.06689");
    }

    #[test]
    fn a_new_file_round_trips_through_the_parser() {
        let heights_mm = thirds(5, 10.0);
        let tables = LensTables {
            image_height_mm: heights_mm.clone(),
            distortion_percent: Some(thirds(5, -0.7)),
            lateral_color_red_percent: Some(thirds(5, 0.01)),
            lateral_color_blue_percent: Some(thirds(5, -0.01)),
            relative_illumination: None,
            tangential_blur_mm: Some(thirds(5, 0.002)),
            sagittal_blur_mm: Some(thirds(5, 0.001)),
            field_curvature_mm: Some(thirds(5, 0.03)),
            coma_mm: Some(thirds(5, 0.004)),
            at_f_number: Some(2.0 / 0.7),
            vignetting: vec![
                IlluminationAt { f_number: 1.4136, relative_illumination: vec![1.0, 0.9, 0.8, 0.7, 0.6] },
                IlluminationAt { f_number: 4.0, relative_illumination: vec![1.0, 0.98, 0.95, 2.0 / 3.0, 0.6] },
            ],
        };
        let mut w = LensFileWriter::new("A test lens.\n\nIts second paragraph.");
        w.string("name", "Test \"quoted\" 50mm", None)
            .string("source", "made up", Some("where it comes from"))
            .number("focal_length_mm", 50.0 + 1.0 / 3.0, 4, None)
            .number("f_number_min", 1.4136, 3, None)
            .number("f_number_max", 16.0, 3, Some("ASSUMED: f/16"))
            .number("focus_min_m", 0.456_789, 4, None)
            .integer("aperture.blades", 9, Some("nine"))
            .number("aperture.cats_eye", 0.123_456, 4, None)
            .tables(&tables, Some("against image height"))
            .longitudinal_color(&LongitudinalColorSpec { red_mm: 0.1 / 3.0, blue_mm: -0.2 / 3.0 }, None)
            .longitudinal_spherical_aberration(&LsaSpec { rim_mm: -0.05 / 3.0, at_f_number: 2.0 / 0.7 }, None);
        let text = w.finish();
        let lens = LensFile::parse(&text, Path::new("new.toml")).unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert!(text.starts_with("# A test lens.\n#\n# Its second paragraph.\nname = "), "{text}");
        for comment in ["# where it comes from\nsource", "# ASSUMED: f/16\nf_number_max", "# nine\nblades = 9"] {
            assert!(text.contains(comment), "{comment:?} in\n{text}");
        }
        assert!(text.contains("# against image height\n[tables]"), "{text}");
        assert_eq!(lens.name, "Test \"quoted\" 50mm");
        assert_eq!(lens.focal_length_mm, 50.3333);
        assert_eq!((lens.f_number_min, lens.f_number_max, lens.focus_min_m), (1.414, 16.0, 0.4568));
        assert_eq!((lens.aperture.blades, lens.aperture.cats_eye), (9, 0.1235));
        let t = lens.tables.as_ref().unwrap();
        assert_eq!(t.image_height_mm, rounded_all(&heights_mm, 4));
        assert_eq!(t.image_height_mm[1], 3.3333);
        for ((key, read), (_, written)) in t.columns().into_iter().zip(tables.columns()) {
            assert_eq!(read, &written.as_ref().map(|w| rounded_all(w, 5)), "{key}");
        }
        assert_eq!(t.at_f_number, Some(2.8571));
        assert_eq!(t.vignetting.len(), 2);
        assert_eq!(t.vignetting[0].f_number, 1.414);
        assert_eq!(t.vignetting[1].relative_illumination, [1.0, 0.98, 0.95, 0.66667, 0.6]);
        let lc = lens.longitudinal_color.unwrap();
        assert_eq!((lc.red_mm, lc.blue_mm), (0.033333, -0.066667));
        let lsa = lens.longitudinal_spherical_aberration.unwrap();
        assert_eq!((lsa.rim_mm, lsa.at_f_number), (-0.016667, 2.8571));
    }

    const EXISTING: &str = "# My lens, measured by hand.\n\
        name = \"mine\"\n\
        source = \"my bench\"\n\
        # from the box\n\
        focal_length_mm = 50\n\
        f_number_min = 2\n\
        f_number_max = 16\n\
        focus_min_m = 0.5\n\n\
        [aperture]\n\
        blades = 6 # hexagonal\n\
        cats_eye = 0.3 # a guess\n\n\
        [longitudinal_color]\n\
        red_mm = 0.5\n\
        blue_mm = -0.5\n\n\
        # old tables, to be replaced\n\
        [tables]\n\
        image_height_mm = [0, 10]\n\
        distortion_percent = [0, -9]\n\n\
        [[surface]] # front\n\
        radius_mm = 50\n\
        thickness_mm = 5\n\
        n_d = 1.5 # crown\n\
        semi_diameter_mm = 10\n\
        stop = true\n\n\
        [[surface]]\n\
        radius_mm = -50\n\
        thickness_mm = 48\n\
        semi_diameter_mm = 10\n\
        # the end of my file\n";

    #[test]
    fn editing_keeps_the_rest_and_its_comments() {
        let tables = LensTables {
            image_height_mm: vec![0.0, 5.0, 10.0],
            distortion_percent: Some(vec![0.0, -0.1, -0.4]),
            lateral_color_red_percent: None,
            lateral_color_blue_percent: None,
            relative_illumination: Some(vec![1.0, 0.9, 0.8]),
            tangential_blur_mm: None,
            sagittal_blur_mm: None,
            field_curvature_mm: None,
            coma_mm: None,
            at_f_number: None,
            vignetting: vec![],
        };
        let mut w = LensFileWriter::edit(EXISTING).unwrap();
        w.number("aperture.cats_eye", 0.45678, 4, None)
            .number("aperture.cats_eye_at_mm", 20.0, 4, None)
            .longitudinal_color(&LongitudinalColorSpec { red_mm: 0.06, blue_mm: -0.1 }, Some("traced"))
            .tables(&tables, None);
        let text = w.finish();
        let lens = LensFile::parse(&text, Path::new("edited.toml")).unwrap_or_else(|e| panic!("{e}\n{text}"));
        // Everything but the replaced sections is as it was, comments and spelling included.
        let (head, _) = EXISTING.split_once("[longitudinal_color]").unwrap();
        let head = head.replace("cats_eye = 0.3 # a guess", "cats_eye = 0.4568 # a guess\ncats_eye_at_mm = 20.0");
        assert!(text.starts_with(&head), "{text}");
        let (_, surfaces) = EXISTING.split_once("[[surface]] # front").unwrap();
        let surfaces = surfaces.trim_end_matches("# the end of my file\n");
        assert!(text.contains(&format!("[[surface]] # front{surfaces}")), "{text}");
        // The comments that ended the file stay before the new sections, which follow in order.
        let at = |s: &str| text.find(s).unwrap_or_else(|| panic!("{s:?} not in\n{text}"));
        assert!(at("# the end of my file") < at("# traced\n[longitudinal_color]"));
        assert!(at("[longitudinal_color]") < at("[tables]"));
        assert!(!text.contains("old tables") && !text.contains("-9"), "{text}");
        assert_eq!(text.matches("[tables]").count(), 1);
        assert_eq!(
            (lens.aperture.blades, lens.aperture.cats_eye, lens.aperture.cats_eye_at_mm),
            (6, 0.4568, Some(20.0))
        );
        assert_eq!(lens.longitudinal_color.unwrap().red_mm, 0.06);
        assert_eq!(lens.tables.unwrap().relative_illumination, Some(vec![1.0, 0.9, 0.8]));
        assert_eq!(lens.surfaces.len(), 2);
    }

    #[test]
    fn derived_tables_of_a_prescription_then_of_its_lens_file() {
        let text = include_str!("../../../lenses/tessar-walch.toml");
        let path = "lenses/tessar-walch.toml";
        let prescription = Prescription::parse_toml(text, path).unwrap();
        let analysis = prescription.analyze(2.8, &[0.0, 8.0, 16.0]);
        let derived = analysis.derived_tables().unwrap();
        let written = with_derived_tables(text, false, &analysis, &derived, path).unwrap();
        let lens = LensFile::parse(&written, Path::new("derived.toml")).unwrap_or_else(|e| panic!("{e}\n{written}"));
        // The surfaces as the prescription writes them, comments included.
        assert_eq!(lens.prescription(Path::new("derived.toml"), &written).unwrap().surfaces, prescription.surfaces);
        assert!(written.contains("n_d = 1.69100 # LAK9") && written.contains("[[surface]] # aperture stop"));
        assert!(written.contains("# focus_min_m (10 focal lengths) and the circular aperture are assumptions"));
        assert!(written.contains("# Derived by realcam lens analyze from lenses/tessar-walch.toml at f/2.800:"));
        assert_eq!(lens.focal_length_mm, rounded(analysis.paraxial.efl_mm, 3));
        assert_eq!(lens.aperture.cats_eye, rounded(derived.cats_eye, 4));
        let t = lens.tables.as_ref().unwrap();
        assert_eq!(t.image_height_mm, rounded_all(&derived.image_height_mm, 4));
        assert_eq!(t.coma_mm.as_ref().unwrap(), &rounded_all(&derived.coma_mm, 5));
        assert_eq!(t.at_f_number, Some(2.8));
        assert_eq!(lens.longitudinal_spherical_aberration.unwrap().rim_mm, rounded(derived.lsa_rim_mm, 6));
        // Again from the lens file at another f-number: its sections are replaced, not added.
        let analysis = prescription.analyze(4.0, &[0.0, 8.0, 16.0]);
        let derived = analysis.derived_tables().unwrap();
        let again = with_derived_tables(&written, true, &analysis, &derived, "derived.toml").unwrap();
        let lens = LensFile::parse(&again, Path::new("again.toml")).unwrap_or_else(|e| panic!("{e}\n{again}"));
        assert_eq!(lens.tables.unwrap().at_f_number, Some(4.0));
        assert_eq!(again.matches("[tables]").count(), 1);
        assert_eq!(again.matches("# Derived by").count(), 1);
        assert!(again.contains("n_d = 1.69100 # LAK9"));
        let (head, _) = written.split_once("cats_eye =").unwrap();
        assert!(again.starts_with(head), "{again}");
    }
}
