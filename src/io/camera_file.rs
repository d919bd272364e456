//! Camera files (TOML): a shot's camera settings keyframed over its frames (a rack focus, an
//! iris pull, a zoom), one table per setting, named as [`CameraRequest`]'s fields; frame
//! numbers as in the sequence (`--frames`). Errors name the file, the line and the setting.
//!
//! ```toml
//! [focus_distance_m]            # a rack focus from 1 m to 3 m over frames 1001-1024
//! interpolation = "smooth"      # smooth (the default) | linear | constant
//! keys = [[1001, 1.0], [1024, 3.0]]   # [frame, value], any order
//!
//! [f_number]
//! value = 2.8                   # or one value for the whole shot
//! ```
//!
//! The settings: `focal_length_mm`, `f_number`, `focus_distance_m`, `shutter_s` or
//! `shutter_angle_deg`, `iso`, `nits_per_unit`, `blades`, `blade_rotation_deg`,
//! `blade_curvature`, `spherical_aberration`, `cats_eye`, `grain`.
//!
//! [`CameraRequest`]: crate::model::camera::CameraRequest

use crate::model::camera::keys::{CameraKeys, Interpolation, Track, ANIMATED};
use crate::model::camera::CameraField;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum CameraFileError {
    #[error("camera file \"{}\": cannot read it: {source}", .path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("camera file \"{}\", line {line}: {message}", .path.display())]
    Parse { path: PathBuf, line: usize, message: String },
}

/// The settings' names in a camera file, for messages.
fn setting_names() -> String {
    ANIMATED.iter().map(|f| f.name()).collect::<Vec<_>>().join(", ")
}

/// Reads the camera file at `path`.
pub fn load_camera_file(path: &Path) -> Result<CameraKeys, CameraFileError> {
    let text =
        std::fs::read_to_string(path).map_err(|source| CameraFileError::Read { path: path.to_path_buf(), source })?;
    parse_camera_file(&text, path)
}

/// A camera file's `text`; `path` names it in messages.
pub fn parse_camera_file(text: &str, path: &Path) -> Result<CameraKeys, CameraFileError> {
    let parse_err = |line: usize, message: String| CameraFileError::Parse { path: path.to_path_buf(), line, message };
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let (line, message) = crate::optics::prescription::toml_error(text, &e);
        parse_err(line, message)
    })?;
    // The line of a setting's table header, for messages about it.
    let line_of = |name: &str| {
        text.lines()
            .position(|l| l.trim_start().trim_start_matches('[').trim_start().starts_with(name))
            .map_or(0, |i| i + 1)
    };
    let mut tracks = Vec::new();
    for (name, value) in &table {
        let err = |message: String| parse_err(line_of(name), format!("{name}: {message}"));
        let Some(&field) = ANIMATED.iter().find(|f| f.name() == name) else {
            return Err(parse_err(
                line_of(name),
                format!("{name:?} is not a setting a camera file keys (one of: {})", setting_names()),
            ));
        };
        let Some(setting) = value.as_table() else {
            return Err(err("a table: [setting] with keys = [[frame, value], ...] or value = ...".into()));
        };
        if let Some(unknown) = setting.keys().find(|k| !["keys", "value", "interpolation"].contains(&k.as_str())) {
            return Err(err(format!("unknown key {unknown:?} (keys, value, interpolation)")));
        }
        let interpolation = match setting.get("interpolation") {
            None => Interpolation::default(),
            Some(v) => v
                .as_str()
                .and_then(Interpolation::parse)
                .ok_or_else(|| err(format!("interpolation is smooth, linear or constant, not {v}")))?,
        };
        let number = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
        let track = match (setting.get("keys"), setting.get("value")) {
            (Some(_), Some(_)) => return Err(err("keys or value, not both".into())),
            (None, None) => return Err(err("no keys = [[frame, value], ...] and no value = ...".into())),
            (None, Some(v)) => Track::constant(number(v).ok_or_else(|| err(format!("value is a number, not {v}")))?),
            (Some(keys), None) => {
                let pairs = keys.as_array().ok_or_else(|| err("keys is a list of [frame, value]".into()))?;
                let mut keys = Vec::new();
                for (i, pair) in pairs.iter().enumerate() {
                    let pair = pair.as_array().map(|p| p.iter().map(number).collect::<Vec<_>>());
                    match pair.as_deref() {
                        Some(&[Some(frame), Some(value)]) => keys.push((frame, value)),
                        _ => return Err(err(format!("key {} is not [frame, value] of two numbers", i + 1))),
                    }
                }
                Track::new(keys, interpolation).map_err(|e| err(format!("the keys: {e}")))?
            }
        };
        tracks.push((field, track));
    }
    let has = |f: CameraField| tracks.iter().any(|(t, _)| *t == f);
    if has(CameraField::ShutterS) && has(CameraField::ShutterAngleDeg) {
        return Err(parse_err(
            line_of("shutter_angle_deg"),
            "shutter_s and shutter_angle_deg both set the shutter: keep one".into(),
        ));
    }
    // In the order of ANIMATED, whatever the file's.
    tracks.sort_by_key(|(f, _)| ANIMATED.iter().position(|a| a == f));
    Ok(CameraKeys { tracks, origin: format!("the camera file \"{}\"", path.display()) })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<CameraKeys, String> {
        parse_camera_file(text, Path::new("shot.toml")).map_err(|e| e.to_string())
    }

    #[test]
    fn a_rack_focus_and_a_fixed_iris() {
        let keys = parse(
            "[focus_distance_m]\ninterpolation = \"linear\"\nkeys = [[1024, 3], [1001, 1.0]]\n\n[f_number]\nvalue = 2.8\n",
        )
        .unwrap();
        let focus = keys.track(CameraField::FocusDistanceM).unwrap();
        assert_eq!(focus.keys(), &[(1001.0, 1.0), (1024.0, 3.0)]);
        assert!((focus.at(1012.5) - 2.0).abs() < 1e-12);
        assert_eq!(keys.track(CameraField::FNumber).unwrap().at(5000.0), 2.8);
        assert!(keys.is_animated());
        assert_eq!(keys.origin, "the camera file \"shot.toml\"");
    }

    #[test]
    fn errors_name_the_line_and_the_setting() {
        assert_eq!(
            parse("[f_number]\nvalue = 2\n\n[focus]\nvalue = 3\n").unwrap_err(),
            format!(
                "camera file \"shot.toml\", line 4: \"focus\" is not a setting a camera file keys (one of: {})",
                setting_names()
            )
        );
        assert_eq!(
            parse("[iso]\nkeys = [[1, 100], [2]]\n").unwrap_err(),
            "camera file \"shot.toml\", line 1: iso: key 2 is not [frame, value] of two numbers"
        );
        assert_eq!(
            parse("[iso]\nkeys = [[1, 100], [1, 200]]\n").unwrap_err(),
            "camera file \"shot.toml\", line 1: iso: the keys: has two keys at frame 1"
        );
        assert_eq!(
            parse("[grain]\nvalue = 1\ninterpolation = \"cubic\"\n").unwrap_err(),
            "camera file \"shot.toml\", line 1: grain: interpolation is smooth, linear or constant, not \"cubic\""
        );
        assert!(parse("[shutter_s]\nvalue = 0.01\n[shutter_angle_deg]\nvalue = 180\n")
            .unwrap_err()
            .ends_with("shutter_s and shutter_angle_deg both set the shutter: keep one"));
    }
}
