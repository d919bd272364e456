//! A `<lens>` element read into a [`LensEntry`], and the numbers a model name gives.

use super::*;

/// The line of a byte offset, by binary search over the line starts (roxmltree's
/// `text_pos_at` scans from the start of the text: quadratic over a 2 MB file).
pub(super) struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    pub(super) fn new(text: &str) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    /// 1-based line of byte `offset`.
    pub(super) fn line(&self, offset: usize) -> u32 {
        let line = self.starts.partition_point(|&s| s <= offset);
        u32::try_from(line).unwrap_or(u32::MAX)
    }
}

/// Where the elements of one XML file are (its path and line index), for locations and errors.
struct Reader<'a> {
    lines: &'a LineIndex,
    path: &'a Path,
}

type Node<'a, 'input> = roxmltree::Node<'a, 'input>;

impl Reader<'_> {
    fn line_of(&self, n: Node) -> u32 {
        self.lines.line(n.range().start)
    }

    fn at(&self, n: Node) -> Location {
        Location { path: self.path.to_path_buf(), line: self.line_of(n) }
    }

    fn xml_err(&self, n: Node, message: String) -> LensfunError {
        LensfunError::Xml { path: self.path.to_path_buf(), line: self.line_of(n), message }
    }

    /// `text`, the value `what` of element `n`, as a finite number.
    fn number(&self, n: Node, text: &str, what: &str) -> Result<f64, LensfunError> {
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.xml_err(n, format!("<{}> {what} = {text:?} is not a number", n.tag_name().name())))
    }

    /// The attribute `name` of `n` as a number; `default` when it is absent (None: an error).
    fn attr(&self, n: Node, name: &str, default: Option<f64>) -> Result<f64, LensfunError> {
        match n.attribute(name) {
            Some(v) => self.number(n, v, name),
            None => {
                default.ok_or_else(|| self.xml_err(n, format!("<{}> has no {name} attribute", n.tag_name().name())))
            }
        }
    }
}

/// The text of `n`, whitespace collapsed.
fn text_of(n: Node) -> String {
    n.text().unwrap_or("").split_whitespace().collect::<Vec<_>>().join(" ")
}

pub(super) fn parse_lens(lines: &LineIndex, lens: Node, path: &Path) -> Result<LensEntry, LensfunError> {
    let r = Reader { lines, path };
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
        at: r.at(lens),
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
                let c = r.number(n, &text_of(n), "value")?;
                if c <= 0.0 {
                    return Err(r.xml_err(n, format!("<cropfactor> {c} must be positive")));
                }
                entry.crop_factor = Some(c);
            }
            "aspect-ratio" => {
                entry.aspect_ratio = parse_aspect_ratio(&text_of(n)).ok_or_else(|| {
                    r.xml_err(n, format!("<aspect-ratio> {:?} is neither a ratio like 1.5 nor like 3:2", text_of(n)))
                })?
            }
            "focal" => {
                let (min, max) = match n.attribute("value") {
                    Some(v) => {
                        let v = r.number(n, v, "value")?;
                        (v, v)
                    }
                    None => {
                        let min = r.attr(n, "min", None)?;
                        (min, r.attr(n, "max", Some(min))?)
                    }
                };
                entry.focal_range_mm = Some((min, max));
            }
            "aperture" => {
                entry.f_number_min = n.attribute("min").map(|v| r.number(n, v, "min")).transpose()?;
                entry.f_number_max = n.attribute("max").map(|v| r.number(n, v, "max")).transpose()?;
            }
            "center" => entry.center = Some((r.attr(n, "x", Some(0.0))?, r.attr(n, "y", Some(0.0))?)),
            "calibration" => r.calibration(n, &mut entry)?,
            _ => {}
        }
    }
    if entry.model.is_empty() {
        return Err(r.xml_err(lens, "<lens> has no <model>".into()));
    }
    Ok(entry)
}

impl Reader<'_> {
    /// The calibrations and comments of a `<calibration>` element `n`, added to `entry`.
    fn calibration(&self, n: Node, entry: &mut LensEntry) -> Result<(), LensfunError> {
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
                "distortion" => entry.distortion.extend(self.distortion(c, model)?),
                "tca" => entry.tca.extend(self.tca(c, model)?),
                "vignetting" => entry.vignetting.extend(self.vignetting(c, model)?),
                // <real-focal-length>, <crop>, <field_of_view>: not used.
                _ => {}
            }
        }
        Ok(())
    }

    /// A `<distortion>` calibration; None for model `none`.
    fn distortion(&self, c: Node, model: String) -> Result<Option<Distortion>, LensfunError> {
        let m = match model.as_str() {
            "none" => return Ok(None),
            "poly3" => DistortionModel::Poly3 { k1: self.attr(c, "k1", Some(0.0))? },
            "poly5" => {
                DistortionModel::Poly5 { k1: self.attr(c, "k1", Some(0.0))?, k2: self.attr(c, "k2", Some(0.0))? }
            }
            "ptlens" => DistortionModel::Ptlens {
                a: self.attr(c, "a", Some(0.0))?,
                b: self.attr(c, "b", Some(0.0))?,
                c: self.attr(c, "c", Some(0.0))?,
            },
            _ => DistortionModel::Unknown(model),
        };
        Ok(Some(Distortion { focal_mm: self.attr(c, "focal", None)?, model: m, at: self.at(c) }))
    }

    /// A `<tca>` calibration; None for model `none`.
    fn tca(&self, c: Node, model: String) -> Result<Option<Tca>, LensfunError> {
        let m = match model.as_str() {
            "none" => return Ok(None),
            "linear" => TcaModel::Linear { kr: self.attr(c, "kr", Some(1.0))?, kb: self.attr(c, "kb", Some(1.0))? },
            "poly3" => TcaModel::Poly3 {
                vr: self.attr(c, "vr", Some(1.0))?,
                cr: self.attr(c, "cr", Some(0.0))?,
                br: self.attr(c, "br", Some(0.0))?,
                vb: self.attr(c, "vb", Some(1.0))?,
                cb: self.attr(c, "cb", Some(0.0))?,
                bb: self.attr(c, "bb", Some(0.0))?,
            },
            _ => TcaModel::Unknown(model),
        };
        Ok(Some(Tca { focal_mm: self.attr(c, "focal", None)?, model: m, at: self.at(c) }))
    }

    /// A `<vignetting>` calibration; None for model `none`.
    fn vignetting(&self, c: Node, model: String) -> Result<Option<Vignetting>, LensfunError> {
        if model == "none" {
            return Ok(None);
        }
        Ok(Some(Vignetting {
            focal_mm: self.attr(c, "focal", None)?,
            f_number: self.attr(c, "aperture", None)?,
            distance_m: self.attr(c, "distance", Some(1000.0))?,
            model,
            k1: self.attr(c, "k1", Some(0.0))?,
            k2: self.attr(c, "k2", Some(0.0))?,
            k3: self.attr(c, "k3", Some(0.0))?,
            at: self.at(c),
        }))
    }
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
