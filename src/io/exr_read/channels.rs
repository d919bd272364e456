//! Finding the colour and depth channels (by view layer, override or naming convention) and
//! interleaving channels into images.

use super::file::{Chan, ExrFile};
use super::{Image, IoError, PassSources};
use exr::image::FlatSamples;

/// Channels of one pass, with how they were chosen.
pub(super) struct Found<'a> {
    pub(super) chans: Vec<&'a Chan>,
    pub(super) rule: String,
}

pub(super) fn split_list(s: &str) -> Vec<&str> {
    s.split(',').map(str::trim).collect()
}

/// `P.R, P.G, P.B` and `P.A` when present.
pub(super) fn rgba_with_prefix<'a>(f: &'a ExrFile, p: &str) -> Option<Vec<&'a Chan>> {
    let names = ["R", "G", "B"].map(|c| format!("{p}.{c}"));
    let mut v = f.find_all(&names.each_ref().map(String::as_str))?;
    v.extend(f.find(&format!("{p}.A")));
    Some(v)
}

/// The Blender view layers of a file (`L` of `L.Combined.R`, `L.Depth.Z`, `L.Vector.X`), in
/// the file's order.
pub(super) fn view_layers(f: &ExrFile) -> Vec<&str> {
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
pub(super) fn choose_layer(f: &ExrFile, src: &PassSources) -> Result<(Option<String>, Option<String>), IoError> {
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
pub(super) fn in_layer<'a>(f: &ExrFile, layer: Option<&'a str>) -> impl Fn(&&Chan) -> bool + 'a {
    let prefix = layer.filter(|_| !view_layers(f).is_empty()).map(|l| format!("{l}."));
    move |c: &&Chan| prefix.as_ref().is_none_or(|p| c.name.starts_with(p.as_str()))
}

pub(super) fn find_color<'a>(f: &'a ExrFile, ovr: Option<&str>, layer: Option<&str>) -> Result<Found<'a>, IoError> {
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

pub(super) fn find_depth<'a>(f: &'a ExrFile, ovr: Option<&str>, layer: Option<&str>) -> Result<Found<'a>, IoError> {
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

/// Errors unless `b` has the size of `a`.
pub(super) fn same_size(a: &str, fa: &ExrFile, ca: &Chan, b: &str, fb: &ExrFile, cb: &Chan) -> Result<(), IoError> {
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
pub(super) fn interleave(chans: &[&Chan], channels: u32, fill: f32) -> Image {
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

pub(super) fn names(chans: &[&Chan]) -> String {
    chans.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ")
}

pub(super) fn color_image<'a>(
    f: &'a ExrFile,
    ovr: Option<&str>,
    layer: Option<&str>,
) -> Result<(Image, Found<'a>), IoError> {
    let found = find_color(f, ovr, layer)?;
    for c in &found.chans[1..] {
        same_size("color", f, found.chans[0], "color", f, c)?;
    }
    Ok((interleave(&found.chans, 4, 1.0), found))
}
