//! Loading the color, depth and velocity passes of a rendered frame from OpenEXR files.
//!
//! Channel names are case-sensitive and tried in this order; the first complete match wins.
//! In a multi-part file each channel is known by `<part name>.<channel>` (unless the channel
//! name already starts with the part name) and also by its bare name when that is unique.
//!
//! | pass     | channels                                  | convention / conversion to (dx, dy), px per frame toward the NEXT frame, x right, y DOWN |
//! |----------|-------------------------------------------|------------------------------------------------------------------------|
//! | color    | `<Layer>.Combined.R,G,B[,A]`              | Blender multilayer (any layer name, e.g. `ViewLayer`)                   |
//! | color    | `R,G,B[,A]`                               | Nuke / common                                                           |
//! | color    | `rgba.red,green,blue[,alpha]`             |                                                                         |
//! | color    | `<prefix>.R,G,B[,A]`                      | only when exactly one such prefix exists (e.g. `beauty.R`)              |
//! | depth    | `<Layer>.Depth.Z`                         | Blender                                                                 |
//! | depth    | `Z`, `depth.Z`, `depth.R`, `depth`        | common, Nuke                                                            |
//! | depth    | the only channel of a one-channel file    | whatever its name (`Y`, `R`, ...)                                       |
//! | velocity | `<Layer>.Vector.X,Y,Z,W`, `X,Y,Z,W` (whole file) | Blender, y UP: next (-Z, +W), previous (X, -Y)              |
//! | velocity | `<Layer>.Vector.X,Y` (no Z,W)             | Blender: previous (X, -Y), next = -previous (constant velocity)         |
//! | velocity | `forward.u,v` [+ `backward.u,v`]          | Nuke, y UP: next (u, -v), previous (bu, -bv)                            |
//! | velocity | `motion.u,v` / `motion.x,y`               | Nuke single vector: next (u, -v)                                        |
//! | velocity | `motion_vector.R,G` (or `.X,Y`)           | Arnold raw, over the renderer's shutter: next (R, -G) / interval        |
//! | velocity | `velocity.X,Y`/`.R,G`, `VRayVelocity.R,G` | V-Ray, current to next frame, y UP: next (x, -y)                        |
//! | velocity | `vel.X,Y`                                 | RE:Vision single vector, y UP: next (x, -y)                             |
//!
//! With [`VelocityFormat::Auto`] the format comes from the names, and names of two formats in
//! one file are an error; a named format reads only its own names (`ndc` and `revision` also the
//! generic single-vector names, read as that format). `velocity_scale` and `velocity_flip_y`
//! apply after the conversion.
//!
//! Overrides ([`PassSources`]): color takes a layer prefix `P` (reads `P.R,P.G,P.B[,P.A]`) or an
//! explicit list `R,G,B[,A]`; depth takes one exact channel name; velocity takes 4 names
//! (Blender `X,Y,Z,W`) or 2 names `x,y`, read in the named format, or with `auto` as Blender
//! previous-frame vectors when the first contains `.Vector.`, else as px toward the next frame, y UP
//! (x, -y). The conventions used are written to [`ScenePasses::channel_report`].

use super::{Image, IoError, MemoryBudget, PassSources, ScenePasses, VelocityFormat};
use exr::image::FlatSamples;
use std::io::Read;
use std::path::{Path, PathBuf};

/// One channel of a decoded file.
struct Chan {
    /// Qualified name (`part.channel` in multi-part files).
    name: String,
    /// Name as stored in its part.
    bare: String,
    /// Data window size (px) and position (px) of its part.
    size: (usize, usize),
    origin: (i32, i32),
    samples: FlatSamples,
}

impl Chan {
    fn to_f32(&self) -> Vec<f32> {
        match &self.samples {
            FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
        }
    }

    fn type_name(&self) -> &'static str {
        match self.samples {
            FlatSamples::F16(_) => "half",
            FlatSamples::F32(_) => "float",
            FlatSamples::U32(_) => "uint",
        }
    }
}

/// A decoded EXR file: every channel of every part.
struct ExrFile {
    path: PathBuf,
    display_window: (i32, i32, u32, u32),
    chans: Vec<Chan>,
    /// The focal length (mm) its first part's header gives, with the attribute's name.
    focal_length_mm: Option<(f64, String)>,
    /// Its `chromaticities` attribute: the colour space of its RGB.
    chromaticities: Option<crate::optics::colour::Chromaticities>,
}

/// The focal length a renderer wrote in a header: OpenEXR's lens attributes (floats, mm), else
/// Blender's `Lens` stamp (a text such as "50.00 mm").
fn header_focal_length_mm(attributes: &exr::meta::header::LayerAttributes) -> Option<(f64, String)> {
    use exr::meta::attribute::{AttributeValue, Text};
    let positive = |v: f64| (v.is_finite() && v > 0.0).then_some(v);
    for name in ["pinholeFocalLength", "effectiveFocalLength", "nominalFocalLength"] {
        if let Some(AttributeValue::F32(v)) = attributes.other.get(&Text::from(name)) {
            if let Some(v) = positive(f64::from(*v)) {
                return Some((v, name.to_string()));
            }
        }
    }
    match attributes.other.get(&Text::from("Lens")) {
        Some(AttributeValue::Text(t)) => {
            let t = t.to_string();
            let mm = t.trim().strip_suffix("mm")?.trim().parse::<f64>().ok()?;
            Some((positive(mm)?, "Lens".to_string()))
        }
        _ => None,
    }
}

const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// How many times the exr crate panicked on a file and the panic became an error (the fuzzing
/// harness counts them: each is a decoder bug to report).
pub static DECODER_PANICS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Bytes per pixel that [`load_passes`] allocates beyond the decoded samples: the interleaved
/// colour (4 f32), depth (1) and velocity (2), and one channel converted to f32 at a time.
const LOADED_BYTES_PER_PX: u64 = 4 * (4 + 1 + 2 + 1);

impl ExrFile {
    fn open(path: &Path, what: &str, budget: &MemoryBudget) -> Result<ExrFile, IoError> {
        let read_err = |source: std::io::Error| {
            if source.kind() == std::io::ErrorKind::NotFound {
                IoError::NotFound { what: what.into(), path: path.into() }
            } else {
                IoError::Read { what: what.into(), path: path.into(), source }
            }
        };
        let mut magic = [0u8; 4];
        let mut file = std::fs::File::open(path).map_err(read_err)?;
        if file.metadata().map_err(read_err)?.is_dir() {
            return Err(read_err(std::io::Error::other("it is a directory")));
        }
        if file.read_exact(&mut magic).is_err() || magic != EXR_MAGIC {
            return Err(IoError::NotExr { what: what.into(), path: path.into() });
        }
        drop(file);
        let exr_err = |source| IoError::Exr { what: what.into(), path: path.into(), source };
        // The headers alone first: the declared sizes against the budget before any pixel
        // storage is allocated.
        let meta = exr::meta::MetaData::read_from_file(path, false).map_err(exr_err)?;
        let mut decoded_bytes = 0u64;
        let mut largest = (0u64, 0u64);
        for header in &meta.headers {
            let (w, h) = (header.layer_size.0 as u64, header.layer_size.1 as u64);
            let sample_bytes: u64 = header.channels.list.iter().map(|c| c.sample_type.bytes_per_sample() as u64).sum();
            decoded_bytes = decoded_bytes.saturating_add(w.saturating_mul(h).saturating_mul(sample_bytes));
            budget.check(what, path, w, h, 0)?;
            if w.saturating_mul(h) > largest.0.saturating_mul(largest.1) {
                largest = (w, h);
            }
        }
        let loaded = largest.0.saturating_mul(largest.1).saturating_mul(LOADED_BYTES_PER_PX);
        budget.check(what, path, largest.0, largest.1, decoded_bytes.saturating_add(loaded))?;
        drop(meta);
        // The decoder is not ours: should it panic on a malformed file, that is an error about
        // the file, not the end of the run.
        let decoded = std::panic::catch_unwind(|| exr::prelude::read_all_flat_layers_from_file(path));
        let image = match decoded {
            Ok(result) => result.map_err(exr_err)?,
            Err(panic) => {
                DECODER_PANICS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let message = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                return Err(exr_err(exr::error::Error::Invalid(format!("the decoder stopped: {message}").into())));
            }
        };
        let dw = image.attributes.display_window;
        let focal_length_mm = image.layer_data.first().and_then(|l| header_focal_length_mm(&l.attributes));
        let chromaticities = match image.attributes.chromaticities {
            None => None,
            Some(c) => {
                let xy = |v: exr::math::Vec2<f32>| [f64::from(v.0), f64::from(v.1)];
                let checked =
                    crate::optics::colour::Chromaticities::new(xy(c.red), xy(c.green), xy(c.blue), xy(c.white));
                Some(checked.map_err(|e| IoError::BadAttribute {
                    what: what.into(),
                    path: path.into(),
                    attribute: "chromaticities",
                    reason: e.to_string(),
                })?)
            }
        };
        let multi_part = image.layer_data.len() > 1;
        let mut chans = Vec::new();
        for layer in image.layer_data {
            let part = layer.attributes.layer_name.as_ref().map(|t| t.to_string());
            let pos = layer.attributes.layer_position;
            for ch in layer.channel_data.list {
                let bare = ch.name.to_string();
                let name = match &part {
                    Some(p) if multi_part && !bare.starts_with(&format!("{p}.")) => {
                        format!("{p}.{bare}")
                    }
                    _ => bare.clone(),
                };
                if ch.sampling != exr::math::Vec2(1, 1) {
                    return Err(IoError::Unsupported {
                        what: what.into(),
                        path: path.into(),
                        channel: name,
                        reason: format!("it is subsampled ({}x{} px per sample)", ch.sampling.0, ch.sampling.1),
                    });
                }
                chans.push(Chan {
                    name,
                    bare,
                    size: (layer.size.0, layer.size.1),
                    origin: (pos.0, pos.1),
                    samples: ch.sample_data,
                });
            }
        }
        Ok(ExrFile {
            path: path.into(),
            display_window: (dw.position.0, dw.position.1, dw.size.0 as u32, dw.size.1 as u32),
            chans,
            focal_length_mm,
            chromaticities,
        })
    }

    /// A channel by qualified name, else by bare name when that is unique.
    fn find(&self, name: &str) -> Option<&Chan> {
        if let Some(c) = self.chans.iter().find(|c| c.name == name) {
            return Some(c);
        }
        let mut it = self.chans.iter().filter(|c| c.bare == name);
        match (it.next(), it.next()) {
            (Some(c), None) => Some(c),
            _ => None,
        }
    }

    fn find_all(&self, names: &[&str]) -> Option<Vec<&Chan>> {
        names.iter().map(|n| self.find(n)).collect()
    }

    /// The channel names, for error messages.
    fn found(&self) -> String {
        const MAX: usize = 64;
        let mut s = self.chans.iter().take(MAX).map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ");
        if self.chans.is_empty() {
            s.push_str("(none)");
        } else if self.chans.len() > MAX {
            s.push_str(&format!(", ... ({} more)", self.chans.len() - MAX));
        }
        s
    }

    fn missing(&self, what: &str, looked_for: &str) -> IoError {
        IoError::MissingChannel {
            what: what.into(),
            path: self.path.clone(),
            looked_for: looked_for.into(),
            found: self.found(),
        }
    }

    /// All of `names`, or an error naming the first missing one.
    fn require(&self, what: &str, requested: &str, names: &[&str]) -> Result<Vec<&Chan>, IoError> {
        names
            .iter()
            .map(|n| {
                self.find(n).ok_or_else(|| IoError::OverrideNotFound {
                    what: what.into(),
                    path: self.path.clone(),
                    requested: requested.into(),
                    missing: (*n).into(),
                    found: self.found(),
                })
            })
            .collect()
    }
}

/// Channels of one pass, with how they were chosen.
struct Found<'a> {
    chans: Vec<&'a Chan>,
    rule: String,
}

fn split_list(s: &str) -> Vec<&str> {
    s.split(',').map(str::trim).collect()
}

/// `P.R, P.G, P.B` and `P.A` when present.
fn rgba_with_prefix<'a>(f: &'a ExrFile, p: &str) -> Option<Vec<&'a Chan>> {
    let names = ["R", "G", "B"].map(|c| format!("{p}.{c}"));
    let mut v = f.find_all(&names.each_ref().map(String::as_str))?;
    v.extend(f.find(&format!("{p}.A")));
    Some(v)
}

/// The Blender view layers of a file (`L` of `L.Combined.R`, `L.Depth.Z`, `L.Vector.X`), in
/// the file's order.
fn view_layers(f: &ExrFile) -> Vec<&str> {
    let mut layers: Vec<&str> = Vec::new();
    for c in &f.chans {
        let layer = [".Combined.R", ".Depth.Z", ".Vector.X"].iter().find_map(|suffix| c.name.strip_suffix(suffix));
        if let Some(l) = layer.filter(|l| !layers.contains(l)) {
            layers.push(l);
        }
    }
    layers
}

/// The view layer every pass is taken from, and the line of the report that says why: the
/// one asked for, else the one the colour override names, else the first of several.
fn choose_layer(f: &ExrFile, src: &PassSources) -> Result<(Option<String>, Option<String>), IoError> {
    let layers = view_layers(f);
    let list = layers.join(", ");
    let override_layer = src
        .color_channels
        .as_deref()
        .filter(|o| !o.contains(','))
        .and_then(|o| layers.iter().find(|l| o.starts_with(&format!("{l}."))).copied());
    let chosen = match (src.layer.as_deref(), override_layer) {
        (Some(asked), Some(other)) if asked != other => {
            return Err(IoError::Layer {
                path: f.path.clone(),
                reason: format!(
                    "the layer {asked} was asked for but the colour override \"{}\" is of layer {other}; passes of two layers are never mixed",
                    src.color_channels.as_deref().unwrap_or_default()
                ),
            })
        }
        (Some(asked), _) if !layers.contains(&asked) => {
            let found = if layers.is_empty() { "none".to_string() } else { list.clone() };
            return Err(IoError::Layer { path: f.path.clone(), reason: format!("no view layer {asked} (layers: {found})") });
        }
        (Some(asked), _) => Some((asked, "asked for")),
        (None, Some(other)) => Some((other, "the colour override's")),
        (None, None) if layers.len() > 1 => Some((layers[0], "the first; choose another with a layer option")),
        (None, None) => layers.first().map(|&l| (l, "the only one")),
    };
    Ok(match chosen {
        None => (None, None),
        Some((layer, why)) => {
            let line = format!("view layer: {layer} ({why}; layers in \"{}\": {list})", f.path.display());
            if layers.len() > 1 && src.layer.is_none() && override_layer.is_none() {
                log::warn!(
                    "{} has {} view layers ({list}); every pass is taken from {layer}",
                    f.path.display(),
                    layers.len()
                );
            }
            (Some(layer.to_string()), Some(line))
        }
    })
}

/// Whether a channel of `f` is of view layer `layer`: a filter over its channels, true for
/// all when no layer is chosen or `f` has none.
fn in_layer<'a>(f: &ExrFile, layer: Option<&'a str>) -> impl Fn(&&Chan) -> bool + 'a {
    let prefix = layer.filter(|_| !view_layers(f).is_empty()).map(|l| format!("{l}."));
    move |c: &&Chan| prefix.as_ref().is_none_or(|p| c.name.starts_with(p.as_str()))
}

fn find_color<'a>(f: &'a ExrFile, ovr: Option<&str>, layer: Option<&str>) -> Result<Found<'a>, IoError> {
    const WHAT: &str = "color";
    if let Some(o) = ovr {
        let rule = format!("override \"{o}\"");
        if o.contains(',') {
            let names = split_list(o);
            if !(3..=4).contains(&names.len()) {
                return Err(IoError::BadOverride {
                    what: WHAT.into(),
                    requested: o.into(),
                    reason: format!("expected 3 or 4 channel names, got {}", names.len()),
                });
            }
            let chans = f.require(WHAT, o, &names)?;
            return Ok(Found { chans, rule });
        }
        let mut chans =
            f.require(WHAT, o, &["R", "G", "B"].map(|c| format!("{o}.{c}")).each_ref().map(String::as_str))?;
        chans.extend(f.find(&format!("{o}.A")));
        return Ok(Found { chans, rule });
    }
    for c in f.chans.iter().filter(in_layer(f, layer)) {
        if let Some(layer) = c.name.strip_suffix(".Combined.R") {
            if let Some(chans) = rgba_with_prefix(f, &format!("{layer}.Combined")) {
                let rule = format!("Blender multilayer {layer}.Combined");
                return Ok(Found { chans, rule });
            }
        }
    }
    if let Some(mut chans) = f.find_all(&["R", "G", "B"]) {
        chans.extend(f.find("A"));
        return Ok(Found { chans, rule: "R,G,B[,A]".into() });
    }
    if let Some(mut chans) = f.find_all(&["rgba.red", "rgba.green", "rgba.blue"]) {
        chans.extend(f.find("rgba.alpha"));
        return Ok(Found { chans, rule: "rgba.red/green/blue[/alpha]".into() });
    }
    let mut prefixes: Vec<&str> =
        f.chans.iter().filter_map(|c| c.name.strip_suffix(".R")).filter(|p| rgba_with_prefix(f, p).is_some()).collect();
    prefixes.dedup();
    match prefixes[..] {
        [p] => {
            Ok(Found { chans: rgba_with_prefix(f, p).unwrap_or_default(), rule: format!("single layer {p}.R,G,B[,A]") })
        }
        [] => {
            Err(f
                .missing(WHAT, "<layer>.Combined.R/G/B[/A], R,G,B[,A], rgba.red/green/blue[/alpha], <layer>.R/G/B[/A]"))
        }
        _ => {
            Err(IoError::AmbiguousChannels { what: WHAT.into(), path: f.path.clone(), candidates: prefixes.join(", ") })
        }
    }
}

fn find_depth<'a>(f: &'a ExrFile, ovr: Option<&str>, layer: Option<&str>) -> Result<Found<'a>, IoError> {
    if let Some(o) = ovr {
        let chans = f.require("depth", o, &[o])?;
        let rule = format!("override \"{o}\"");
        return Ok(Found { chans, rule });
    }
    let found = |c: &'a Chan, rule: &str| Ok(Found { chans: vec![c], rule: rule.into() });
    if let Some(c) = f.chans.iter().filter(in_layer(f, layer)).find(|c| c.name.ends_with(".Depth.Z")) {
        return found(c, "Blender <layer>.Depth.Z");
    }
    for n in ["Z", "depth.Z", "depth.R", "depth"] {
        if let Some(c) = f.find(n) {
            return found(c, n);
        }
    }
    if let [c] = &f.chans[..] {
        return found(c, "the only channel of a one-channel file");
    }
    Err(f.missing("depth", "<layer>.Depth.Z, Z, depth.Z, depth.R, depth, or the only channel of a one-channel file"))
}

/// Two channels of a velocity pass and their conversion: (dx, dy) = (sx * x, sy * y) px per
/// frame, x right, y down.
struct Vector<'a> {
    x: &'a Chan,
    y: &'a Chan,
    sx: f32,
    sy: f32,
}

/// The velocity channels found: toward the next frame and, when present, toward the previous.
struct Velocity<'a> {
    next: Option<Vector<'a>>,
    prev: Option<Vector<'a>>,
    format: VelocityFormat,
    rule: String,
}

const BLENDER_XYZW: &str =
    "Blender Vector, x right/y up: X,Y = p[f-1]-p[f] -> previous (X, -Y); Z,W = p[f]-p[f+1] -> next (-Z, +W) px/frame";
const BLENDER_XY: &str =
    "Blender Vector X,Y = p[f-1]-p[f], x right/y up: previous (X, -Y) px/frame, constant velocity assumed";
const NEXT_Y_UP: &str = "px toward the next frame, x right/y up: next (x, -y) px/frame";
const VELOCITY_LOOKED_FOR: &str = "<layer>.Vector.X/Y[/Z/W], X,Y,Z,W (whole file), forward.u/v [+ backward.u/v], motion.u/v, motion.x/y, motion_vector.R/G, velocity.X/Y, velocity.R/G, VRayVelocity.R/G, vel.X/Y";

/// Single-vector channel pairs, by the format their names stand for.
const SINGLE_VECTORS: [(&str, &str, VelocityFormat); 10] = [
    ("motion.u", "motion.v", VelocityFormat::Nuke),
    ("motion.x", "motion.y", VelocityFormat::Nuke),
    ("motion_vector.R", "motion_vector.G", VelocityFormat::Arnold),
    ("motion_vector.X", "motion_vector.Y", VelocityFormat::Arnold),
    ("velocity.X", "velocity.Y", VelocityFormat::Vray),
    ("velocity.R", "velocity.G", VelocityFormat::Vray),
    ("VRayVelocity.R", "VRayVelocity.G", VelocityFormat::Vray),
    ("VRayVelocity.X", "VRayVelocity.Y", VelocityFormat::Vray),
    ("vel.X", "vel.Y", VelocityFormat::Revision),
    ("vel.x", "vel.y", VelocityFormat::Revision),
];

/// What a single forward vector of `format` means, in words.
fn single_rule(format: VelocityFormat) -> &'static str {
    match format {
        VelocityFormat::Arnold => "Arnold raw motion_vector: px over the renderer's shutter interval, forward, x right/y up: next (x, -y) / interval",
        VelocityFormat::Vray => "V-Ray velocity: px from the current to the next frame, x right/y up: next (x, -y) px/frame",
        VelocityFormat::Revision => "RE:Vision single vector: px per frame, forward, +y up: next (x, -y) px/frame",
        VelocityFormat::Ndc => "NDC: a frame width (height) of 2 per frame, forward, y up: next (x W/2, -y H/2) px/frame",
        _ => NEXT_Y_UP,
    }
}

fn forward<'a>(x: &'a Chan, y: &'a Chan) -> Option<Vector<'a>> {
    Some(Vector { x, y, sx: 1.0, sy: -1.0 })
}

/// Every velocity format whose channel names the file has, in the order tried.
fn velocity_candidates<'a>(f: &'a ExrFile, layer: Option<&str>) -> Vec<Velocity<'a>> {
    let mut found = Vec::new();
    let blender = |next, prev, rule: &str| Velocity { next, prev, format: VelocityFormat::Blender, rule: rule.into() };
    for c in f.chans.iter().filter(in_layer(f, layer)) {
        if let Some(layer) = c.name.strip_suffix(".Vector.X") {
            let n = |s: &str| f.find(&format!("{layer}.Vector.{s}"));
            match (n("Y"), n("Z"), n("W")) {
                (Some(y), Some(z), Some(w)) => {
                    let next = Some(Vector { x: z, y: w, sx: -1.0, sy: 1.0 });
                    let prev = Some(Vector { x: c, y, sx: 1.0, sy: -1.0 });
                    found.push(blender(next, prev, BLENDER_XYZW));
                }
                (Some(y), _, _) => found.push(blender(None, Some(Vector { x: c, y, sx: 1.0, sy: -1.0 }), BLENDER_XY)),
                _ => {}
            }
        }
    }
    if f.chans.len() == 4 {
        if let Some(c) = f.find_all(&["X", "Y", "Z", "W"]) {
            let next = Some(Vector { x: c[2], y: c[3], sx: -1.0, sy: 1.0 });
            found.push(blender(next, Some(Vector { x: c[0], y: c[1], sx: 1.0, sy: -1.0 }), BLENDER_XYZW));
        }
    }
    if let (Some(u), Some(v)) = (f.find("forward.u"), f.find("forward.v")) {
        let prev = match (f.find("backward.u"), f.find("backward.v")) {
            (Some(bu), Some(bv)) => forward(bu, bv),
            _ => None,
        };
        let rule = if prev.is_some() {
            "Nuke forward/backward: px toward the next/previous frame, x right/y up: next (u, -v), previous (bu, -bv) px/frame"
        } else {
            "Nuke forward: px toward the next frame, x right/y up: next (u, -v) px/frame, constant velocity assumed"
        };
        found.push(Velocity { next: forward(u, v), prev, format: VelocityFormat::Nuke, rule: rule.into() });
    }
    for (x, y, format) in SINGLE_VECTORS {
        if let (Some(cx), Some(cy)) = (f.find(x), f.find(y)) {
            found.push(Velocity { next: forward(cx, cy), prev: None, format, rule: single_rule(format).into() });
        }
    }
    found
}

fn find_velocity<'a>(
    f: &'a ExrFile,
    ovr: Option<&str>,
    format: VelocityFormat,
    layer: Option<&str>,
) -> Result<Option<Velocity<'a>>, IoError> {
    if let Some(o) = ovr {
        let names = split_list(o);
        let c = match names.len() {
            2 | 4 => f.require("velocity", o, &names)?,
            n => {
                return Err(IoError::BadOverride {
                    what: "velocity".into(),
                    requested: o.into(),
                    reason: format!("expected 2 or 4 channel names, got {n}"),
                })
            }
        };
        let blender_like = format == VelocityFormat::Blender
            || (format == VelocityFormat::Auto && (c.len() == 4 || names[0].contains(".Vector.")));
        return Ok(Some(if c.len() == 4 {
            if !matches!(format, VelocityFormat::Auto | VelocityFormat::Blender) {
                return Err(IoError::BadOverride {
                    what: "velocity".into(),
                    requested: o.into(),
                    reason: format!("4 channels are Blender's X,Y,Z,W; the {} format has 2", format.name()),
                });
            }
            Velocity {
                next: Some(Vector { x: c[2], y: c[3], sx: -1.0, sy: 1.0 }),
                prev: Some(Vector { x: c[0], y: c[1], sx: 1.0, sy: -1.0 }),
                format: VelocityFormat::Blender,
                rule: format!("override \"{o}\" as {BLENDER_XYZW}"),
            }
        } else if blender_like {
            Velocity {
                next: None,
                prev: Some(Vector { x: c[0], y: c[1], sx: 1.0, sy: -1.0 }),
                format: VelocityFormat::Blender,
                rule: format!("override \"{o}\" as {BLENDER_XY}"),
            }
        } else {
            let format = if format == VelocityFormat::Auto { VelocityFormat::Nuke } else { format };
            Velocity {
                next: forward(c[0], c[1]),
                prev: None,
                format,
                rule: format!("override \"{o}\" as {}", single_rule(format)),
            }
        }));
    }
    let mut candidates = velocity_candidates(f, layer);
    match format {
        VelocityFormat::Auto => {
            let mut formats: Vec<&str> = candidates.iter().map(|v| v.format.name()).collect();
            formats.dedup();
            if formats.len() > 1 {
                return Err(IoError::AmbiguousChannels {
                    what: "velocity".into(),
                    path: f.path.clone(),
                    candidates: format!("formats {}; choose one with --velocity-format", formats.join(", ")),
                });
            }
            Ok(candidates.into_iter().next())
        }
        // Channels named for no format in particular, read as the format the user named.
        VelocityFormat::Ndc | VelocityFormat::Revision => {
            let format_of = |mut v: Velocity<'a>| {
                v.format = format;
                v.rule = single_rule(format).into();
                v
            };
            let single = |v: &Velocity| v.prev.is_none() && v.next.is_some();
            let own = candidates.iter().position(|v| v.format == format && single(v));
            let index = own.or_else(|| candidates.iter().position(single));
            Ok(index.map(|i| format_of(candidates.swap_remove(i))))
        }
        _ => {
            candidates.retain(|v| v.format == format);
            Ok(candidates.into_iter().next())
        }
    }
}

/// A velocity vector image (2 channels, px per frame, x right, y down) from its channels, with
/// the format's extra factor and the user's scale and flip; NaN/Inf become 0 (counted).
fn vector_image(v: &Vector, factor: [f32; 2], scale: f32, flip_y: bool, nonfinite: &mut u64) -> Image {
    let mut im = interleave(&[v.x, v.y], 2, 0.0);
    let flip = if flip_y { -1.0 } else { 1.0 };
    let s = [v.sx * factor[0] * scale, v.sy * factor[1] * scale * flip];
    for (px, s) in im.data.iter_mut().zip(s.iter().cycle()) {
        *px = if px.is_finite() {
            // `+ 0.0` turns -0 into +0.
            *px * s + 0.0
        } else {
            *nonfinite += 1;
            0.0
        };
    }
    im
}

/// -v of a 2-channel vector image (the other half of a constant motion).
fn negated(im: &Image) -> Image {
    Image { data: im.data.iter().map(|v| -v + 0.0).collect(), ..im.clone() }
}

/// Errors unless `b` has the size of `a`.
fn same_size(a: &str, fa: &ExrFile, ca: &Chan, b: &str, fb: &ExrFile, cb: &Chan) -> Result<(), IoError> {
    if ca.size == cb.size {
        return Ok(());
    }
    Err(IoError::SizeMismatch {
        a: format!("{a} (channel {})", ca.name),
        a_path: fa.path.clone(),
        a_size: (ca.size.0 as u32, ca.size.1 as u32),
        b: format!("{b} (channel {})", cb.name),
        b_path: fb.path.clone(),
        b_size: (cb.size.0 as u32, cb.size.1 as u32),
    })
}

/// Interleaves `chans` (all of one size) into an image with `channels` values per pixel;
/// channels beyond `chans.len()` are filled with `fill`.
///
/// Block by block: each channel's samples of the block are converted to f32 together (half
/// floats through `half`'s slice conversion, which uses the CPU's F16C instructions, 8 at a
/// time), then placed in their pixels. The output is written once, in order, and no whole-frame
/// temporary is made: scene A's colour (1280x720, half RGBA) took 14 ms through a vector per
/// channel converted one value at a time, 5-9 ms this way with the NaN scan after it.
fn interleave(chans: &[&Chan], channels: u32, fill: f32) -> Image {
    use half::slice::HalfFloatSliceExt;
    const BLOCK_PX: usize = 4096;
    let (w, h) = chans[0].size;
    let n = channels as usize;
    let mut im = Image::new(w as u32, h as u32, channels);
    let mut converted = vec![0f32; BLOCK_PX];
    for (block, out) in im.data.chunks_mut(BLOCK_PX * n).enumerate() {
        let (start, len) = (block * BLOCK_PX, out.len() / n);
        for c in 0..n {
            let values = &mut converted[..len];
            match chans.get(c).map(|ch| &ch.samples) {
                Some(FlatSamples::F16(v)) => v[start..start + len].convert_to_f32_slice(values),
                Some(FlatSamples::F32(v)) => values.copy_from_slice(&v[start..start + len]),
                Some(FlatSamples::U32(v)) => {
                    values.iter_mut().zip(&v[start..start + len]).for_each(|(o, &u)| *o = u as f32)
                }
                None => values.fill(fill),
            }
            for (px, &v) in out.chunks_exact_mut(n).zip(values.iter()) {
                px[c] = v;
            }
        }
    }
    im
}

fn names(chans: &[&Chan]) -> String {
    chans.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ")
}

fn color_image<'a>(f: &'a ExrFile, ovr: Option<&str>, layer: Option<&str>) -> Result<(Image, Found<'a>), IoError> {
    let found = find_color(f, ovr, layer)?;
    for c in &found.chans[1..] {
        same_size("color", f, found.chans[0], "color", f, c)?;
    }
    Ok((interleave(&found.chans, 4, 1.0), found))
}

/// Reads the color of an EXR file as RGBA (alpha = 1 when absent) using the same channel
/// discovery as [`load_passes`]. Values are returned as stored (NaN/Inf kept).
pub fn read_exr_rgba(path: &Path) -> Result<Image, IoError> {
    read_exr_rgba_within(path, &MemoryBudget::system())
}

/// [`read_exr_rgba`] within `budget`.
pub fn read_exr_rgba_within(path: &Path, budget: &MemoryBudget) -> Result<Image, IoError> {
    let f = ExrFile::open(path, "color", budget)?;
    Ok(color_image(&f, None, None)?.0)
}

/// Reads one channel, by exact (qualified) name, as a 1-channel image, values as stored.
pub fn read_exr_channel(path: &Path, channel: &str) -> Result<Image, IoError> {
    let f = ExrFile::open(path, "channel", &MemoryBudget::system())?;
    let c = f.require("channel", channel, &[channel])?;
    Ok(interleave(&c, 1, 0.0))
}

/// Opens `path` unless it is `None` or `same`: then the caller reuses its open file.
fn open_other(
    path: &Option<PathBuf>,
    same: &Path,
    what: &str,
    budget: &MemoryBudget,
) -> Result<Option<ExrFile>, IoError> {
    match path {
        Some(p) if p != same => ExrFile::open(p, what, budget).map(Some),
        _ => Ok(None),
    }
}

/// Loads color, depth and (when present or required) velocity; see the module docs for
/// the channel names and conventions.
pub fn load_passes(src: &PassSources) -> Result<ScenePasses, IoError> {
    let unit_m = src.depth_unit_m;
    if !(unit_m.is_finite() && unit_m > 0.0) {
        return Err(IoError::InvalidArgument {
            field: "depth_unit_m",
            value: unit_m,
            allowed: "a positive number of metres per depth unit",
        });
    }
    // The depth and velocity files decode on threads of their own beside the colour's (scene A:
    // the three reads 31-41 ms one after another, 17-36 ms side by side); the colour's error,
    // if any, is the one reported first.
    let (cf, df_own, vf_own) = std::thread::scope(|scope| {
        let depth = scope.spawn(|| open_other(&src.depth_path, &src.color_path, "depth", &src.budget));
        let velocity = scope.spawn(|| open_other(&src.velocity_path, &src.color_path, "velocity", &src.budget));
        let cf = ExrFile::open(&src.color_path, "color", &src.budget);
        // The decoder's own panics are caught in ExrFile::open; any other is a bug, passed on.
        let joined =
            |t: std::thread::ScopedJoinHandle<'_, _>| t.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        (cf, joined(depth), joined(velocity))
    });
    let (cf, df_own, vf_own) = (cf?, df_own?, vf_own?);
    let df = df_own.as_ref().unwrap_or(&cf);
    let vf = vf_own.as_ref().unwrap_or(&cf);
    let mut report = Vec::new();

    // The view layer, chosen once for every pass.
    let (layer, layer_line) = choose_layer(&cf, src)?;
    let layer = layer.as_deref();
    report.extend(layer_line);

    // Color.
    let (mut color, cfound) = color_image(&cf, src.color_channels.as_deref(), layer)?;
    let c0 = cfound.chans[0];
    let mut color_nan_count = 0u64;
    for v in color.data.iter_mut().filter(|v| !v.is_finite()) {
        *v = 0.0;
        color_nan_count += 1;
    }
    if color_nan_count > 0 {
        log::warn!("color: {color_nan_count} NaN/Inf value(s) in \"{}\" replaced by 0", cf.path.display());
    }
    report.push(format!(
        "color: \"{}\" channels {} ({}), {}{}{}",
        cf.path.display(),
        names(&cfound.chans),
        cfound.rule,
        c0.type_name(),
        if cfound.chans.len() == 3 { ", alpha = 1 (none in file)" } else { "" },
        if color_nan_count > 0 { format!(", {color_nan_count} NaN/Inf value(s) replaced by 0") } else { String::new() }
    ));

    // Depth.
    let dfound = find_depth(df, src.depth_channel.as_deref(), layer)?;
    let dc = dfound.chans[0];
    same_size("color", &cf, c0, "depth", df, dc)?;
    let mut depth_m = interleave(&dfound.chans, 1, 0.0);
    let mut bad: Option<(usize, f32)> = None;
    let mut bad_count = 0u64;
    for (i, v) in depth_m.data.iter_mut().enumerate() {
        *v = (*v as f64 * unit_m) as f32;
        if v.is_nan() || *v < 0.0 {
            bad_count += 1;
            bad.get_or_insert((i, *v));
        }
    }
    if let Some((i, value_m)) = bad {
        return Err(IoError::InvalidDepth {
            path: df.path.clone(),
            channel: dc.name.clone(),
            x: i % dc.size.0,
            y: i / dc.size.0,
            value_m,
            count: bad_count,
        });
    }
    report.push(format!(
        "depth: \"{}\" channel {} ({}), {}, {unit_m} m per unit, used as stored (no planar/ray conversion)",
        df.path.display(),
        dc.name,
        dfound.rule,
        dc.type_name()
    ));

    // Velocity.
    let explicit = src.velocity_path.is_some() || src.velocity_channels.is_some();
    let mut origins = vec![("depth", dc.origin)];
    if !(src.velocity_scale.is_finite() && src.velocity_scale != 0.0) {
        return Err(IoError::InvalidArgument {
            field: "velocity_scale",
            value: src.velocity_scale,
            allowed: "a finite, non-zero factor",
        });
    }
    let (velocity_px, velocity_prev_px, velocity_format) = match find_velocity(
        vf,
        src.velocity_channels.as_deref(),
        src.velocity_format,
        layer,
    )? {
        Some(v) => {
            let first = v.next.as_ref().or(v.prev.as_ref()).map(|c| c.x).unwrap_or(c0);
            let mut chans = Vec::new();
            for c in v.next.iter().chain(&v.prev) {
                same_size("color", &cf, c0, "velocity", vf, c.x)?;
                same_size("velocity", vf, c.x, "velocity", vf, c.y)?;
                chans.extend([c.x, c.y]);
            }
            origins.push(("velocity", first.origin));
            // Per-frame pixels from the format's own unit.
            let factor = match v.format {
                    VelocityFormat::Ndc => [0.5 * c0.size.0 as f32, 0.5 * c0.size.1 as f32],
                    VelocityFormat::Arnold => match src.velocity_interval_frames {
                        Some(i) if i.is_finite() && i > 0.0 => [1.0 / i as f32; 2],
                        Some(i) => {
                            return Err(IoError::InvalidArgument {
                                field: "velocity_interval_frames",
                                value: i,
                                allowed: "a positive number of frames",
                            })
                        }
                        None => {
                            return Err(IoError::MissingSetting {
                                field: "velocity_interval_frames",
                                path: vf.path.clone(),
                                why: format!(
                                    "holds Arnold motion vectors ({}), which span the renderer's shutter interval; the file does not say how long it was",
                                    names(&chans)
                                ),
                            })
                        }
                    },
                    _ => [1.0, 1.0],
                };
            let (scale, flip) = (src.velocity_scale as f32, src.velocity_flip_y);
            let mut nonfinite = 0u64;
            let next = v.next.as_ref().map(|c| vector_image(c, factor, scale, flip, &mut nonfinite));
            let prev = v.prev.as_ref().map(|c| vector_image(c, factor, scale, flip, &mut nonfinite));
            if nonfinite > 0 {
                log::warn!("velocity: {nonfinite} NaN/Inf value(s) in \"{}\" replaced by 0", vf.path.display());
            }
            let mut adjust = String::new();
            if scale != 1.0 {
                adjust += &format!(", scaled by {scale}");
            }
            if flip {
                adjust += ", y flipped";
            }
            report.push(format!(
                "velocity: \"{}\" channels {} ({}{adjust}), {}{}",
                vf.path.display(),
                names(&chans),
                v.rule,
                first.type_name(),
                if nonfinite > 0 { format!(", {nonfinite} NaN/Inf value(s) replaced by 0") } else { String::new() }
            ));
            // Only the previous-frame vector: constant velocity gives the next one.
            let next = match (next, &prev) {
                (Some(n), _) => n,
                (None, Some(p)) => negated(p),
                (None, None) => return Err(vf.missing("velocity", VELOCITY_LOOKED_FOR)),
            };
            let prev = if v.next.is_some() { prev } else { None };
            (Some(next), prev, Some(v.format))
        }
        None if explicit || src.require_velocity => {
            let looked_for = match src.velocity_format {
                VelocityFormat::Auto => VELOCITY_LOOKED_FOR.to_string(),
                f => format!("{} (the {} format)", VELOCITY_LOOKED_FOR, f.name()),
            };
            return Err(vf.missing("velocity", &looked_for));
        }
        None => {
            report.push(format!("velocity: none (no velocity channels in \"{}\")", vf.path.display()));
            (None, None, None)
        }
    };

    for (what, o) in origins.into_iter().filter(|(_, o)| *o != c0.origin) {
        let msg = format!(
            "{what}: data window origin ({}, {}) px differs from color's ({}, {}) px; pixels are paired by index",
            o.0, o.1, c0.origin.0, c0.origin.1
        );
        log::warn!("{msg}");
        report.push(msg);
    }
    let dw = cf.display_window;
    report.push(format!(
        "data window: origin ({}, {}) px, {}x{} px; display window: origin ({}, {}) px, {}x{} px",
        c0.origin.0, c0.origin.1, c0.size.0, c0.size.1, dw.0, dw.1, dw.2, dw.3
    ));

    // The other channels, for the output.
    let mut kept_channels: Vec<(String, Vec<f32>)> = Vec::new();
    if src.keep_layers {
        let used: Vec<&str> = cfound.chans.iter().map(|c| c.name.as_str()).collect();
        let files = [("color", Some(&cf)), ("depth", df_own.as_ref()), ("velocity", vf_own.as_ref())];
        let mut left_out = Vec::new();
        for (what, file) in files.into_iter().filter_map(|(w, f)| Some((w, f?))) {
            for c in &file.chans {
                if std::ptr::eq(file, &cf) && used.contains(&c.name.as_str()) {
                    continue;
                }
                if c.size != c0.size {
                    left_out.push(format!(
                        "{} ({}x{} px, not the frame's {}x{})",
                        c.name, c.size.0, c.size.1, c0.size.0, c0.size.1
                    ));
                    continue;
                }
                let taken = |n: &str| ["R", "G", "B", "A"].contains(&n) || kept_channels.iter().any(|(k, _)| k == n);
                let name = if taken(&c.name) { format!("{what}.{}", c.name) } else { c.name.clone() };
                if taken(&name) {
                    left_out.push(format!("{} (its name is taken)", c.name));
                    continue;
                }
                kept_channels.push((name, c.to_f32()));
            }
        }
        let mut line = format!(
            "kept for the output: {} channel(s){}",
            kept_channels.len(),
            if kept_channels.is_empty() {
                String::new()
            } else {
                format!(" ({})", kept_channels.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", "))
            }
        );
        if !left_out.is_empty() {
            line += &format!("; left out: {}", left_out.join(", "));
            log::warn!("--keep-layers: channel(s) left out of the output: {}", left_out.join(", "));
        }
        report.push(line);
    }

    Ok(ScenePasses {
        color,
        depth_m,
        velocity_px,
        velocity_prev_px,
        velocity_format,
        display_window: dw,
        data_origin: c0.origin,
        channel_report: report.join("\n"),
        color_nan_count,
        kept_channels,
        render_focal_length_mm: cf.focal_length_mm.clone(),
        chromaticities: cf.chromaticities,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{test_dir, write_exr_channels, ExrWriteOptions};

    const W: u32 = 4;
    const H: u32 = 3;

    /// Writes `W`x`H` channels, each filled with a constant.
    fn write(path: &Path, chans: &[(&str, f32)], float32: bool) {
        let planes: Vec<Vec<f32>> = chans.iter().map(|&(_, v)| vec![v; (W * H) as usize]).collect();
        let list: Vec<(&str, &[f32])> = chans.iter().zip(&planes).map(|(c, p)| (c.0, p.as_slice())).collect();
        let opts = ExrWriteOptions { float32, ..Default::default() };
        write_exr_channels(path, W, H, &list, &opts).unwrap();
    }

    fn sources(color: &Path) -> PassSources {
        PassSources::new(color)
    }

    fn assert_const(im: &Image, expected: &[f32]) {
        assert_eq!((im.width, im.height, im.channels as usize), (W, H, expected.len()));
        for px in im.data.chunks_exact(expected.len()) {
            assert_eq!(px, expected);
        }
    }

    #[test]
    fn blender_multilayer() {
        let dir = test_dir("read-blender");
        let path = dir.join("passes.exr");
        // Constant motion v = (3, 2) px/frame, x right / y up: X,Y = Z,W = -v.
        let (vx, vy) = (3.0, 2.0);
        let mut chans = vec![
            ("ViewLayer.Combined.R", 0.5),
            ("ViewLayer.Combined.G", 0.25),
            ("ViewLayer.Combined.B", 2.0),
            ("ViewLayer.Combined.A", 1.0),
            ("ViewLayer.Depth.Z", 1.0e10),
            ("ViewLayer.Vector.X", -vx),
            ("ViewLayer.Vector.Y", -vy),
        ];
        write(&path, &chans, true);
        // Two-channel vectors (previous frame only), constant velocity assumed.
        let p = load_passes(&sources(&path)).unwrap();
        assert_const(p.velocity_px.as_ref().unwrap(), &[vx, -vy]);
        assert!(p.channel_report.contains("ViewLayer.Vector.X, ViewLayer.Vector.Y"), "{}", p.channel_report);
        chans.extend([("ViewLayer.Vector.Z", -vx), ("ViewLayer.Vector.W", -vy)]);
        write(&path, &chans, true);
        let p = load_passes(&sources(&path)).unwrap();
        assert_const(&p.color, &[0.5, 0.25, 2.0, 1.0]);
        assert_const(&p.depth_m, &[1.0e10]);
        assert_const(p.velocity_px.as_ref().unwrap(), &[vx, -vy]);
        assert_eq!((p.display_window, p.data_origin, p.color_nan_count), ((0, 0, W, H), (0, 0), 0));
        let r = &p.channel_report;
        assert!(r.contains("Blender multilayer ViewLayer.Combined"), "{r}");
        assert!(r.contains("ViewLayer.Depth.Z"), "{r}");
        assert!(r.contains("ViewLayer.Vector.Z, ViewLayer.Vector.W") && r.contains("next (-Z, +W)"), "{r}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn view_layers_are_taken_whole_and_said() {
        let dir = test_dir("read-layers");
        let path = dir.join("layers.exr");
        let mut chans = Vec::new();
        for (layer, colour, depth) in [("Alpha", 0.25, 1.0), ("Beta", 0.75, 5.0)] {
            for c in ["R", "G", "B"] {
                chans.push((format!("{layer}.Combined.{c}"), colour));
            }
            chans.push((format!("{layer}.Depth.Z"), depth));
        }
        let chans: Vec<(&str, f32)> = chans.iter().map(|(n, v)| (n.as_str(), *v)).collect();
        write(&path, &chans, true);
        let load = |src: PassSources| load_passes(&src);
        // None asked: the first, said.
        let p = load(sources(&path)).unwrap();
        assert_const(&p.color, &[0.25, 0.25, 0.25, 1.0]);
        assert_const(&p.depth_m, &[1.0]);
        let expected = format!(
            "view layer: Alpha (the first; choose another with a layer option; layers in \"{}\": Alpha, Beta)",
            path.display()
        );
        assert!(p.channel_report.starts_with(&expected), "{}", p.channel_report);
        // The colour override's layer gives the depth too.
        let p = load(PassSources { color_channels: Some("Beta.Combined".into()), ..sources(&path) }).unwrap();
        assert_const(&p.color, &[0.75, 0.75, 0.75, 1.0]);
        assert_const(&p.depth_m, &[5.0]);
        assert!(
            p.channel_report.contains("depth: ") && p.channel_report.contains("Beta.Depth.Z"),
            "{}",
            p.channel_report
        );
        // Asked for.
        let p = load(PassSources { layer: Some("Beta".into()), ..sources(&path) }).unwrap();
        assert_const(&p.depth_m, &[5.0]);
        assert!(p.channel_report.starts_with("view layer: Beta (asked for;"), "{}", p.channel_report);
        // Never mixed, never a layer that is not there.
        let err = load(PassSources {
            layer: Some("Alpha".into()),
            color_channels: Some("Beta.Combined".into()),
            ..sources(&path)
        })
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "layer: \"{}\": the layer Alpha was asked for but the colour override \"Beta.Combined\" is of layer Beta; passes of two layers are never mixed",
                path.display()
            )
        );
        let err = load(PassSources { layer: Some("Gamma".into()), ..sources(&path) }).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!("layer: \"{}\": no view layer Gamma (layers: Alpha, Beta)", path.display())
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn nuke_naming_and_nan_color() {
        let dir = test_dir("read-nuke");
        let path = dir.join("nuke.exr");
        let chans = [("R", f32::NAN), ("G", 0.5), ("B", f32::INFINITY), ("A", 0.5), ("Z", 0.0)];
        write(&path, &chans, true);
        let no_velocity = load_passes(&sources(&path)).unwrap();
        assert!(no_velocity.velocity_px.is_none());
        assert_eq!(no_velocity.color_nan_count, 2 * (W * H) as u64);
        assert_const(&no_velocity.color, &[0.0, 0.5, 0.0, 0.5]);
        assert_const(&no_velocity.depth_m, &[0.0]);
        write(&path, &[&chans[..], &[("forward.u", 3.0), ("forward.v", 2.0)]].concat(), true);
        let p = load_passes(&sources(&path)).unwrap();
        assert_const(p.velocity_px.as_ref().unwrap(), &[3.0, -2.0]);
        assert!(p.channel_report.contains("channels forward.u, forward.v (Nuke forward: px toward the next frame"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn separate_files_units_and_half() {
        let dir = test_dir("read-separate");
        let (c, d, v) = (dir.join("c.exr"), dir.join("d.exr"), dir.join("v.exr"));
        write(&c, &[("beauty.R", 1.0), ("beauty.G", 2.0), ("beauty.B", 3.0)], false);
        write(&d, &[("Y", 250.0)], false);
        write(&v, &[("X", -1.0), ("Y", -1.0), ("Z", -4.0), ("W", 5.0)], true);
        let src = PassSources {
            depth_path: Some(d.clone()),
            velocity_path: Some(v.clone()),
            depth_unit_m: 0.01,
            ..sources(&c)
        };
        let p = load_passes(&src).unwrap();
        assert_const(&p.color, &[1.0, 2.0, 3.0, 1.0]);
        assert_const(&p.depth_m, &[2.5]);
        assert_const(p.velocity_px.as_ref().unwrap(), &[4.0, 5.0]);
        assert!(p.channel_report.contains("the only channel of a one-channel file"));
        // Overrides.
        write(&c, &[("a", 1.0), ("b", 2.0), ("c", 3.0), ("d", 4.0), ("mv.x", 1.0), ("mv.y", 2.0)], false);
        let src = PassSources {
            color_channels: Some("c, b, a".into()),
            depth_channel: Some("d".into()),
            velocity_channels: Some("mv.x,mv.y".into()),
            ..sources(&c)
        };
        let p = load_passes(&src).unwrap();
        assert_const(&p.color, &[3.0, 2.0, 1.0, 1.0]);
        assert_const(&p.depth_m, &[4.0]);
        assert_const(p.velocity_px.as_ref().unwrap(), &[1.0, -2.0]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn multi_part_file_with_offset_data_window() {
        use exr::prelude::*;
        let dir = test_dir("read-multipart");
        let path = dir.join("parts.exr");
        let part = |name: &str, chans: &[&str], v: f32| {
            let list = chans.iter().map(|c| AnyChannel::new(*c, FlatSamples::F32(vec![v; 12]))).collect();
            let mut attrs = LayerAttributes::named(name);
            attrs.layer_position = Vec2(10, -2);
            Layer::new((4, 3), attrs, Encoding::UNCOMPRESSED, AnyChannels::sort(list))
        };
        let layers = vec![part("ViewLayer.Combined", &["R", "G", "B", "A"], 0.5), part("ViewLayer.Depth", &["Z"], 7.0)];
        let bounds = IntegerBounds::new(Vec2(0, 0), Vec2(20, 10));
        Image::from_layers(ImageAttributes::new(bounds), layers).write().to_file(&path).unwrap();
        let p = load_passes(&sources(&path)).unwrap();
        assert_const(&p.color, &[0.5; 4]);
        assert_const(&p.depth_m, &[7.0]);
        assert_eq!((p.display_window, p.data_origin), ((0, 0, 20, 10), (10, -2)));
        assert!(p.channel_report.contains("ViewLayer.Depth.Z"), "{}", p.channel_report);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn error_messages() {
        let dir = test_dir("read-errors");
        let (c, d) = (dir.join("c.exr"), dir.join("d.exr"));
        let err = |src: &PassSources| load_passes(src).unwrap_err().to_string();

        let missing = dir.join("nope.exr");
        assert_eq!(err(&sources(&missing)), format!("color: file \"{}\" does not exist", missing.display()));
        std::fs::write(&d, "not an image").unwrap();
        let msg = err(&sources(&d));
        assert!(msg.contains(&format!("\"{}\" is not an OpenEXR file", d.display())), "{msg}");

        write(&c, &[("R", 1.0), ("G", 1.0), ("B", 1.0)], false);
        let msg = err(&sources(&c));
        assert!(
            msg.starts_with(&format!("depth: no depth channel in \"{}\" (looked for <layer>.Depth.Z, Z,", c.display())),
            "{msg}"
        );
        assert!(msg.ends_with("; channels found: B, G, R"), "{msg}");

        let src = PassSources { color_channels: Some("beauty".into()), ..sources(&c) };
        let msg = err(&src);
        assert!(msg.contains("channel \"beauty.R\" (from the override \"beauty\") not found"), "{msg}");
        assert!(msg.ends_with("channels found: B, G, R"), "{msg}");

        // Size mismatch: color 4x3 px, depth 2x2 px.
        write_exr_channels(&d, 2, 2, &[("Z", &[1.0; 4])], &ExrWriteOptions::default()).unwrap();
        let src = PassSources { depth_path: Some(d.clone()), ..sources(&c) };
        let msg = err(&src);
        assert!(
            msg.contains(&format!(
                "color (channel R) \"{}\" is 4x3 px but depth (channel Z) \"{}\" is 2x2 px",
                c.display(),
                d.display()
            )),
            "{msg}"
        );

        // NaN and negative depth.
        let mut z = vec![1.0; 12];
        z[4 + 2] = f32::NAN; // (x=2, y=1)
        z[2 * 4 + 3] = -1.0; // (x=3, y=2)
        write_exr_channels(&d, 4, 3, &[("Z", &z)], &ExrWriteOptions::default()).unwrap();
        let msg = err(&src);
        assert!(msg.contains(&format!("channel Z in \"{}\" has 2 invalid pixel(s)", d.display())), "{msg}");
        assert!(msg.contains("the first is pixel (x=2, y=1) of the data window with NaN m"), "{msg}");
        z[4 + 2] = 1.0;
        write_exr_channels(&d, 4, 3, &[("Z", &z)], &ExrWriteOptions::default()).unwrap();
        assert!(err(&src).contains("(x=3, y=2) of the data window with -1 m"));

        // Required velocity that is absent.
        let src = PassSources { require_velocity: true, depth_channel: Some("R".into()), ..sources(&c) };
        let msg = err(&src);
        assert!(msg.starts_with(&format!("velocity: no velocity channel in \"{}\"", c.display())), "{msg}");
        assert!(msg.ends_with("channels found: B, G, R"), "{msg}");
        for unit_m in [-1.0, 0.0, f64::NAN] {
            let src = PassSources { depth_unit_m: unit_m, ..sources(&c) };
            let e = load_passes(&src).unwrap_err();
            assert_eq!(e.field(), Some("depth_unit_m"));
            assert_eq!(
                e.to_string(),
                format!("depth_unit_m must be a positive number of metres per depth unit, got {unit_m}")
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn velocity_formats_that_need_a_setting_or_a_choice_say_so() {
        let dir = test_dir("read-velocity-formats");
        let path = dir.join("v.exr");
        let base = [("R", 1.0), ("G", 1.0), ("B", 1.0), ("Z", 2.0)];
        // Arnold's raw vectors span the renderer's shutter: without it, an error naming the file,
        // the channels and the setting; with it, px per frame.
        write(&path, &[&base[..], &[("motion_vector.R", 3.0), ("motion_vector.G", 1.0)]].concat(), true);
        let e = load_passes(&sources(&path)).unwrap_err();
        assert_eq!(e.field(), Some("velocity_interval_frames"));
        assert_eq!(
            e.to_string(),
            format!(
                "velocity: \"{}\" holds Arnold motion vectors (motion_vector.R, motion_vector.G), which span the renderer's shutter interval; the file does not say how long it was; give velocity_interval_frames",
                path.display()
            )
        );
        let src = PassSources { velocity_interval_frames: Some(0.5), ..sources(&path) };
        let p = load_passes(&src).unwrap();
        assert_const(p.velocity_px.as_ref().unwrap(), &[6.0, -2.0]);
        assert_eq!(p.velocity_format, Some(VelocityFormat::Arnold));
        // Scale and flip apply after the format's conversion.
        let src = PassSources { velocity_scale: 2.0, velocity_flip_y: true, ..src };
        assert_const(load_passes(&src).unwrap().velocity_px.as_ref().unwrap(), &[12.0, 4.0]);
        // Two formats' names in one file: auto refuses to guess; a named format reads its own.
        write(
            &path,
            &[&base[..], &[("forward.u", 3.0), ("forward.v", 1.0), ("vel.X", 5.0), ("vel.Y", 5.0)]].concat(),
            true,
        );
        let e = load_passes(&sources(&path)).unwrap_err().to_string();
        assert!(e.contains("formats nuke, revision; choose one with --velocity-format"), "{e}");
        let src = PassSources { velocity_format: VelocityFormat::Revision, ..sources(&path) };
        assert_const(load_passes(&src).unwrap().velocity_px.as_ref().unwrap(), &[5.0, -5.0]);
        // NDC: a frame width of 2 per frame (W = 4 px, H = 3 px).
        let src = PassSources {
            velocity_format: VelocityFormat::Ndc,
            velocity_channels: Some("vel.X,vel.Y".into()),
            ..sources(&path)
        };
        assert_const(load_passes(&src).unwrap().velocity_px.as_ref().unwrap(), &[10.0, -7.5]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The real Blender scene, when this machine has it: multilayer and separate files
    /// must load identically, and the Mover cube (centre at 3.5 m, expected centre motion
    /// (+76.19, -10.16) px/frame) moves at that motion scaled by 3.5 m / depth of the visible
    /// front face.
    #[test]
    fn half_channels_interleave_in_order_across_blocks() {
        // 97 x 61 = 5917 px crosses interleave's block of 4096 px. Each channel holds its own
        // ramp (every value exact in half); R, G, B without A read back in their pixels, in
        // order, with alpha 1; a fourth channel beyond the three stays the fill.
        let (w, h) = (97u32, 61u32);
        let n = (w * h) as usize;
        let ramp = |c: usize| -> Vec<f32> { (0..n).map(|i| ((i * 3 + c) % 2048) as f32 * 0.5).collect() };
        let planes = [ramp(0), ramp(1), ramp(2)];
        let dir = test_dir("read-interleave-blocks");
        let path = dir.join("rgb-half.exr");
        let list: Vec<(&str, &[f32])> = ["R", "G", "B"].into_iter().zip(planes.iter().map(Vec::as_slice)).collect();
        write_exr_channels(&path, w, h, &list, &ExrWriteOptions::default()).unwrap();
        let im = read_exr_rgba(&path).unwrap();
        assert_eq!((im.width, im.height, im.channels), (w, h, 4));
        for (i, px) in im.data.chunks_exact(4).enumerate() {
            assert_eq!(px, [planes[0][i], planes[1][i], planes[2][i], 1.0], "pixel {i}");
        }
    }

    #[test]
    fn blender_scene_a_if_present() {
        let dir = Path::new("/work/shared/data/sceneA");
        if !dir.join("passes.exr").exists() {
            eprintln!("note: {} not present; skipping the Blender scene A check", dir.display());
            return;
        }
        let multi = load_passes(&PassSources { require_velocity: true, ..sources(&dir.join("passes.exr")) }).unwrap();
        let separate = load_passes(&PassSources {
            depth_path: Some(dir.join("depth.exr")),
            velocity_path: Some(dir.join("velocity.exr")),
            ..sources(&dir.join("color.exr"))
        })
        .unwrap();
        eprintln!("{}\n{}", multi.channel_report, separate.channel_report);
        assert_eq!(multi.color, separate.color);
        assert_eq!(multi.depth_m, separate.depth_m);
        assert_eq!(multi.velocity_px, separate.velocity_px);
        let v = multi.velocity_px.unwrap();
        let (dx, dy, z) = (v.get(360, 604, 0), v.get(360, 604, 1), multi.depth_m.get(360, 604, 0));
        eprintln!("Mover at (360, 604): velocity ({dx}, {dy}) px/frame, depth {z} m");
        let scale = 3.5 / z;
        assert!((dx - 76.19 * scale).abs() < 0.5 && (dy + 10.16 * scale).abs() < 0.5, "({dx}, {dy})");
        assert_eq!(v.get(5, 5, 0), 0.0);
        assert_eq!(multi.depth_m.get(5, 5, 0), 1.0e10);
    }
}
