//! The parsed database, and finding a model in it.

use super::*;

/// The parsed database (every `<lens>` of every XML file).
#[derive(Clone, Debug, Default)]
pub struct Database {
    /// Where it came from, for messages.
    pub origin: String,
    pub lenses: Vec<LensEntry>,
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

/// Lower case, ',' as '.', whitespace collapsed to single spaces.
fn normalize(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ").to_lowercase().replace(',', ".")
}
