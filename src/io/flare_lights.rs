//! Explicit flare lights from a JSON file a renderer can write (`--flare-lights`): a list of
//! objects, each with its position in the image's pixels and its energy (the sum of the scene
//! values of the pixels it covers), white or per channel, and optionally its visible area:
//!
//! ```json
//! [
//!   {"x": 812.5, "y": 140.0, "energy": 2.5e6},
//!   {"x": -40, "y": 300, "rgb": [1.2e6, 1.0e6, 0.7e6], "area_px": 12}
//! ]
//! ```
//!
//! Positions may lie outside the frame (a light just out of view still flares). Every error
//! names the file and the line or the light.

use crate::optics::flare::FlareLight;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum FlareLightsError {
    #[error("flare lights {}: cannot read it: {source}", .path.display())]
    Read { path: PathBuf, source: std::io::Error },
    #[error("flare lights {}, line {line}: {message}", .path.display())]
    Syntax { path: PathBuf, line: usize, message: String },
    #[error("flare lights {}, light {index} (line {line}): {message}", .path.display())]
    Light { path: PathBuf, index: usize, line: usize, message: String },
}

/// A JSON value, with the line it starts on.
#[derive(Clone, Debug, PartialEq)]
enum Json {
    Null,
    Bool(bool),
    Number(f64),
    Text(String),
    List(Vec<(usize, Json)>),
    Object(Vec<(String, usize, Json)>),
}

/// The deepest nesting of lists and objects read (a list of lights needs 3): deeper input is
/// refused before the recursion could overflow the stack (issue 34: 30,000 nested lists).
const MAX_DEPTH: usize = 64;

struct Reader<'a> {
    text: &'a [u8],
    at: usize,
    line: usize,
    /// Lists and objects open around the value being read.
    depth: usize,
}

impl Reader<'_> {
    fn skip_space(&mut self) {
        while let Some(&c) = self.text.get(self.at) {
            match c {
                b'\n' => self.line += 1,
                b' ' | b'\t' | b'\r' => {}
                _ => return,
            }
            self.at += 1;
        }
    }

    fn expect(&mut self, c: u8) -> Result<(), String> {
        self.skip_space();
        match self.text.get(self.at) {
            Some(&got) if got == c => {
                self.at += 1;
                Ok(())
            }
            Some(&got) => Err(format!("expected '{}', found '{}'", c as char, got as char)),
            None => Err(format!("expected '{}', found the end of the file", c as char)),
        }
    }

    fn value(&mut self) -> Result<(usize, Json), String> {
        self.skip_space();
        let line = self.line;
        let Some(&c) = self.text.get(self.at) else { return Err("expected a value, found the end of the file".into()) };
        if matches!(c, b'[' | b'{') {
            if self.depth >= MAX_DEPTH {
                return Err(format!("lists and objects nested more than {MAX_DEPTH} deep (a list of lights needs 3)"));
            }
            self.depth += 1;
        }
        let value = match c {
            b'[' => {
                self.at += 1;
                let mut items = Vec::new();
                self.skip_space();
                if self.text.get(self.at) == Some(&b']') {
                    self.at += 1;
                } else {
                    loop {
                        items.push(self.value()?);
                        self.skip_space();
                        match self.text.get(self.at) {
                            Some(b',') => self.at += 1,
                            Some(b']') => {
                                self.at += 1;
                                break;
                            }
                            _ => return Err("expected ',' or ']' in a list".into()),
                        }
                    }
                }
                self.depth -= 1;
                Json::List(items)
            }
            b'{' => {
                self.at += 1;
                let mut fields = Vec::new();
                self.skip_space();
                if self.text.get(self.at) == Some(&b'}') {
                    self.at += 1;
                } else {
                    loop {
                        self.skip_space();
                        let key_line = self.line;
                        let Json::Text(key) = self.value()?.1 else { return Err("expected a key (a string)".into()) };
                        self.expect(b':')?;
                        fields.push((key, key_line, self.value()?.1));
                        self.skip_space();
                        match self.text.get(self.at) {
                            Some(b',') => self.at += 1,
                            Some(b'}') => {
                                self.at += 1;
                                break;
                            }
                            _ => return Err("expected ',' or '}' in an object".into()),
                        }
                    }
                }
                self.depth -= 1;
                Json::Object(fields)
            }
            b'"' => {
                self.at += 1;
                let mut s = Vec::new();
                loop {
                    match self.text.get(self.at) {
                        None | Some(b'\n') => return Err("a string does not end on its line".into()),
                        Some(b'"') => break,
                        Some(b'\\') => {
                            self.at += 1;
                            match self.text.get(self.at) {
                                Some(&e @ (b'"' | b'\\' | b'/')) => s.push(e),
                                Some(b'n') => s.push(b'\n'),
                                Some(b't') => s.push(b'\t'),
                                _ => return Err("an escape other than \\\" \\\\ \\/ \\n \\t in a string".into()),
                            }
                        }
                        Some(&b) => s.push(b),
                    }
                    self.at += 1;
                }
                self.at += 1;
                Json::Text(String::from_utf8(s).map_err(|_| "a string is not UTF-8".to_string())?)
            }
            b't' | b'f' | b'n' => {
                let word: &[u8] = &self.text[self.at..];
                let (value, len) = if word.starts_with(b"true") {
                    (Json::Bool(true), 4)
                } else if word.starts_with(b"false") {
                    (Json::Bool(false), 5)
                } else if word.starts_with(b"null") {
                    (Json::Null, 4)
                } else {
                    return Err("expected a value".into());
                };
                self.at += len;
                value
            }
            _ => {
                let start = self.at;
                while self.text.get(self.at).is_some_and(|c| c.is_ascii_digit() || b"+-.eE".contains(c)) {
                    self.at += 1;
                }
                let word = std::str::from_utf8(&self.text[start..self.at]).unwrap_or("");
                match word.parse::<f64>() {
                    Ok(v) if !word.is_empty() => Json::Number(v),
                    _ => return Err(format!("expected a value, found '{}'", c as char)),
                }
            }
        };
        Ok((line, value))
    }
}

/// The lights of `text` (`path` names the file in messages).
pub fn parse_flare_lights(text: &str, path: &Path) -> Result<Vec<FlareLight>, FlareLightsError> {
    let mut reader = Reader { text: text.as_bytes(), at: 0, line: 1, depth: 0 };
    let syntax = |line: usize, message: String| FlareLightsError::Syntax { path: path.to_path_buf(), line, message };
    let parsed = reader.value();
    let (line, value) = parsed.map_err(|m| syntax(reader.line, m))?;
    reader.skip_space();
    if reader.at < text.len() {
        return Err(syntax(reader.line, "text after the list of lights".into()));
    }
    let Json::List(items) = value else {
        return Err(syntax(line, "the file must hold a list of lights: [ {...}, ... ]".into()));
    };
    let mut lights = Vec::with_capacity(items.len());
    for (index, (line, item)) in items.into_iter().enumerate() {
        let bad = |message: String| FlareLightsError::Light { path: path.to_path_buf(), index, line, message };
        let Json::Object(fields) = item else {
            return Err(bad("a light must be an object {\"x\": .., \"y\": .., \"energy\": ..}".into()));
        };
        let mut light = FlareLight { x_px: f64::NAN, y_px: f64::NAN, energy: [f64::NAN; 3], area_px: 1.0 };
        for (key, _, v) in &fields {
            let number = |v: &Json| match v {
                Json::Number(n) if n.is_finite() => Ok(*n),
                _ => Err(bad(format!("\"{key}\" must be a finite number"))),
            };
            match key.as_str() {
                "x" => light.x_px = number(v)?,
                "y" => light.y_px = number(v)?,
                "energy" => light.energy = [number(v)?; 3],
                "rgb" => match v {
                    Json::List(rgb) if rgb.len() == 3 => {
                        for (c, (_, x)) in rgb.iter().enumerate() {
                            light.energy[c] = number(x)?;
                        }
                    }
                    _ => return Err(bad("\"rgb\" must be a list of 3 numbers".into())),
                },
                "area_px" => light.area_px = number(v)?,
                other => return Err(bad(format!("unknown key \"{other}\" (x, y, energy or rgb, area_px)"))),
            }
        }
        for (key, value) in [("x", light.x_px), ("y", light.y_px), ("energy or rgb", light.energy[0])] {
            if value.is_nan() {
                return Err(bad(format!("it has no \"{key}\"")));
            }
        }
        if light.energy.iter().any(|&e| e < 0.0) || light.area_px < 0.0 {
            return Err(bad("its energy and area must be at least 0".into()));
        }
        lights.push(light);
    }
    Ok(lights)
}

/// The lights of the file at `path`.
pub fn load_flare_lights(path: &Path) -> Result<Vec<FlareLight>, FlareLightsError> {
    let text =
        std::fs::read_to_string(path).map_err(|source| FlareLightsError::Read { path: path.to_path_buf(), source })?;
    parse_flare_lights(&text, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<FlareLight>, String> {
        parse_flare_lights(text, Path::new("l.json")).map_err(|e| e.to_string())
    }

    #[test]
    fn lights_white_and_coloured_inside_and_outside_the_frame() {
        let lights = parse(
            "[\n  {\"x\": 812.5, \"y\": 140.0, \"energy\": 2.5e6},\n  {\"x\": -40, \"y\": 300, \"rgb\": [1.2e6, 1e6, 7E5], \"area_px\": 12}\n]\n",
        )
        .unwrap();
        assert_eq!(lights[0], FlareLight::white(812.5, 140.0, 2.5e6));
        assert_eq!(lights[1], FlareLight { x_px: -40.0, y_px: 300.0, energy: [1.2e6, 1e6, 7e5], area_px: 12.0 });
        assert_eq!(parse("[]").unwrap(), Vec::new());
    }

    #[test]
    fn errors_name_the_file_the_line_and_the_light() {
        assert_eq!(
            parse("[\n{\"x\": 1, \"y\": 2, \"energy\": 3},\n{\"x\": 1, \"energy\": 3}\n]").unwrap_err(),
            "flare lights l.json, light 1 (line 3): it has no \"y\""
        );
        assert_eq!(
            parse("[\n{\"x\": 1, \"y\": 2,\n \"energy\": -3}]").unwrap_err(),
            "flare lights l.json, light 0 (line 2): its energy and area must be at least 0"
        );
        assert_eq!(
            parse("[{\"x\": 1, \"y\": 2, \"power\": 3}]").unwrap_err(),
            "flare lights l.json, light 0 (line 1): unknown key \"power\" (x, y, energy or rgb, area_px)"
        );
        assert_eq!(
            parse("[{\"x\": 1, \"y\": 2, \"rgb\": [1, 2]}]").unwrap_err(),
            "flare lights l.json, light 0 (line 1): \"rgb\" must be a list of 3 numbers"
        );
        assert_eq!(
            parse("[\n{\"x\": 1,\n \"y\": 2 \"energy\": 3}]").unwrap_err(),
            "flare lights l.json, line 3: expected ',' or '}' in an object"
        );
        assert_eq!(
            parse("{\"x\": 1}").unwrap_err(),
            "flare lights l.json, line 1: the file must hold a list of lights: [ {...}, ... ]"
        );
        assert_eq!(
            parse("[{\"x\": \"left\", \"y\": 2, \"energy\": 3}]").unwrap_err(),
            "flare lights l.json, light 0 (line 1): \"x\" must be a finite number"
        );
        assert!(parse("[1, 2] x").unwrap_err().contains("text after the list"));
        let missing = load_flare_lights(Path::new("/nonexistent/l.json")).unwrap_err().to_string();
        assert!(missing.starts_with("flare lights /nonexistent/l.json: cannot read it"), "{missing}");
    }
}
