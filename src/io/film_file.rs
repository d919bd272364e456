//! Film files (TOML, in films/): a characteristic curve (Kyaw 2013 sec 4.5: response against
//! log exposure with a toe, a straight part and a shoulder), either parametric (the fields of
//! [`FilmCurve`], starting from a built-in preset) or as a table measured from a data sheet.
//! Errors name the file and the line.
//!
//! ```toml
//! name = "..."
//! source = "where the numbers come from"
//! [curve]                  # parametric: any FilmCurve field, the rest from `base`
//! base = "neutral"         # neutral | contrast | soft
//! contrast = 1.4
//! # or
//! [table]                  # log10 sensor value (1 = saturation) against the response:
//! log10_sensor_value = [-4, -3, ...]   # increasing
//! log10_output = [-3, -2.6, ...]       # increasing: output = 10^value
//! # density = [...]                    # or densities of a reversal (slide) film, decreasing:
//! #                                      output = 10^-(density - min density)
//! ```

use crate::optics::film::{FilmCurve, FilmTable};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum FilmFileError {
    #[error("film file {path}: cannot read it: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("film file {path}, line {line}: {message}")]
    Parse { path: PathBuf, line: usize, message: String },
}

/// What a film file describes.
#[derive(Clone, Debug, PartialEq)]
pub enum FilmResponse {
    Curve(FilmCurve),
    Table(FilmTable),
}

#[derive(Clone, Debug, PartialEq)]
pub struct FilmFile {
    pub name: String,
    pub source: String,
    pub response: FilmResponse,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFilm {
    name: String,
    source: String,
    #[serde(default)]
    curve: Option<RawCurve>,
    #[serde(default)]
    table: Option<RawTable>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCurve {
    #[serde(default)]
    base: Option<String>,
    middle_grey_in: Option<f64>,
    middle_grey_out: Option<f64>,
    contrast: Option<f64>,
    toe_softness_decades: Option<f64>,
    shoulder_softness_decades: Option<f64>,
    black_out: Option<f64>,
    white_out: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTable {
    log10_sensor_value: Vec<f64>,
    #[serde(default)]
    log10_output: Option<Vec<f64>>,
    #[serde(default)]
    density: Option<Vec<f64>>,
}

impl FilmFile {
    pub fn load(path: &Path) -> Result<FilmFile, FilmFileError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| FilmFileError::Read { path: path.to_path_buf(), source })?;
        Self::parse(&text, path)
    }

    pub fn parse(text: &str, path: &Path) -> Result<FilmFile, FilmFileError> {
        let raw: RawFilm = toml::from_str(text).map_err(|e| {
            let (line, message) = crate::optics::prescription::toml_error(text, &e);
            FilmFileError::Parse { path: path.to_path_buf(), line, message }
        })?;
        let line_of = |key: &str| text.lines().position(|l| l.trim_start().starts_with(key)).map_or(0, |i| i + 1);
        let err =
            |key: &str, message: String| FilmFileError::Parse { path: path.to_path_buf(), line: line_of(key), message };
        let response = match (raw.curve, raw.table) {
            (Some(_), Some(_)) => return Err(err("[table]", "give either [curve] or [table], not both".into())),
            (None, None) => return Err(err("name", "the film file needs a [curve] or a [table]".into())),
            (Some(c), None) => {
                let base_name = c.base.as_deref().unwrap_or("neutral");
                let base = FilmCurve::preset(base_name).ok_or_else(|| {
                    err("base", format!("curve.base = {base_name:?} is not a preset (neutral, contrast, soft)"))
                })?;
                let curve = FilmCurve {
                    middle_grey_in: c.middle_grey_in.unwrap_or(base.middle_grey_in),
                    middle_grey_out: c.middle_grey_out.unwrap_or(base.middle_grey_out),
                    contrast: c.contrast.unwrap_or(base.contrast),
                    toe_softness_decades: c.toe_softness_decades.unwrap_or(base.toe_softness_decades),
                    shoulder_softness_decades: c.shoulder_softness_decades.unwrap_or(base.shoulder_softness_decades),
                    black_out: c.black_out.unwrap_or(base.black_out),
                    white_out: c.white_out.unwrap_or(base.white_out),
                };
                let curve = curve.validate().map_err(|e| match e {
                    crate::optics::OpticsError::InvalidFilmCurve { name, value, requirement } => {
                        err(name, format!("curve.{name} = {value} {requirement}"))
                    }
                    other => err("[curve]", other.to_string()),
                })?;
                FilmResponse::Curve(curve)
            }
            (None, Some(t)) => {
                let xs = t.log10_sensor_value;
                let ys = match (t.log10_output, t.density) {
                    (Some(_), Some(_)) => {
                        return Err(err("density", "give either table.log10_output or table.density, not both".into()))
                    }
                    (None, None) => {
                        return Err(err("[table]", "the table needs log10_output or density".into()));
                    }
                    (Some(y), None) => {
                        if y.len() != xs.len() {
                            return Err(err(
                                "log10_output",
                                format!(
                                    "table.log10_output has {} values but log10_sensor_value has {}",
                                    y.len(),
                                    xs.len()
                                ),
                            ));
                        }
                        if let Some(i) = (1..y.len()).find(|&i| y[i] < y[i - 1]) {
                            return Err(err(
                                "log10_output",
                                format!("table.log10_output decreases at entry {}: {} then {}", i + 1, y[i - 1], y[i]),
                            ));
                        }
                        y
                    }
                    (None, Some(d)) => {
                        if d.len() != xs.len() {
                            return Err(err(
                                "density",
                                format!("table.density has {} values but log10_sensor_value has {}", d.len(), xs.len()),
                            ));
                        }
                        if let Some(i) = (1..d.len()).find(|&i| d[i] > d[i - 1]) {
                            return Err(err(
                                "density",
                                format!(
                                    "table.density of a reversal film must fall with exposure; it rises at entry {}: {} then {}",
                                    i + 1,
                                    d[i - 1],
                                    d[i]
                                ),
                            ));
                        }
                        // Transmittance 10^-D relative to the clearest part (the base + fog).
                        let d_min = d.iter().copied().fold(f64::INFINITY, f64::min);
                        d.iter().map(|v| -(v - d_min)).collect()
                    }
                };
                if xs.len() < 2 || xs.iter().chain(&ys).any(|v| !v.is_finite()) {
                    return Err(err("log10_sensor_value", "the table needs at least 2 finite entries".into()));
                }
                if let Some(i) = (1..xs.len()).find(|&i| xs[i] <= xs[i - 1]) {
                    return Err(err(
                        "log10_sensor_value",
                        format!(
                            "table.log10_sensor_value is not increasing at entry {}: {} then {}",
                            i + 1,
                            xs[i - 1],
                            xs[i]
                        ),
                    ));
                }
                FilmResponse::Table(FilmTable { log10_sensor_value: xs, log10_output: ys })
            }
        };
        Ok(FilmFile { name: raw.name, source: raw.source, response })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curve_starts_from_its_base_preset() {
        let text = "name = \"n\"\nsource = \"s\"\n[curve]\nbase = \"contrast\"\nwhite_out = 0.9\n";
        let f = FilmFile::parse(text, Path::new("f.toml")).unwrap();
        let contrast = FilmCurve::preset("contrast").unwrap();
        assert_eq!(f.response, FilmResponse::Curve(FilmCurve { white_out: 0.9, ..contrast }));
    }

    #[test]
    fn bad_film_files_name_the_line() {
        let head = "name = \"n\"\nsource = \"s\"\n";
        let cases = [
            (format!("{head}[curve]\ncontrast = -1\n"), "film file f.toml, line 4: curve.contrast = -1 must be positive"),
            (format!("{head}[curve]\nbase = \"vivid\"\n"), "film file f.toml, line 4: curve.base = \"vivid\" is not a preset (neutral, contrast, soft)"),
            (format!("{head}[table]\nlog10_sensor_value = [0, 1, 1]\nlog10_output = [0, 1, 2]\n"), "film file f.toml, line 4: table.log10_sensor_value is not increasing at entry 3: 1 then 1"),
            (format!("{head}[table]\nlog10_sensor_value = [0, 1]\nlog10_output = [0]\n"), "film file f.toml, line 5: table.log10_output has 1 values but log10_sensor_value has 2"),
            (format!("{head}[table]\nlog10_sensor_value = [0, 1]\ndensity = [0.1, 2.0]\n"), "film file f.toml, line 5: table.density of a reversal film must fall with exposure; it rises at entry 2: 0.1 then 2"),
            (head.to_string(), "film file f.toml, line 1: the film file needs a [curve] or a [table]"),
        ];
        for (text, expected) in cases {
            let got = FilmFile::parse(&text, Path::new("f.toml")).unwrap_err().to_string();
            assert_eq!(got, expected);
        }
    }

    #[test]
    fn density_table_becomes_transmittance_above_the_base() {
        let text = "name = \"n\"\nsource = \"s\"\n[table]\nlog10_sensor_value = [-3, 0]\ndensity = [3.2, 0.2]\n";
        let FilmResponse::Table(t) = FilmFile::parse(text, Path::new("f.toml")).unwrap().response else {
            panic!("not a table")
        };
        // Clearest (D = 0.2, the base) transmits 1; D = 3.2 transmits 10^-3; halfway in log
        // exposure the density is 1.7 -> 10^-1.5.
        assert!((t.apply(1.0) - 1.0).abs() < 1e-12);
        assert!((t.apply(1e-3) - 1e-3).abs() < 1e-15);
        assert!((t.apply(10f64.powf(-1.5)) - 10f64.powf(-1.5)).abs() < 1e-12);
        assert_eq!(t.apply(f64::NAN), 1e-3);
    }
}
