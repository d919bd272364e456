//! Writing OpenEXR files (one part, ZIP compression, half or float32 samples).

use super::{Image, IoError};
use exr::image::{AnyChannel, AnyChannels, Encoding, FlatSamples, Layer};
use exr::math::Vec2;
use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::meta::header::{ImageAttributes, LayerAttributes};
use exr::prelude::WritableImage;
use std::path::Path;

/// Largest finite half-float value.
const HALF_MAX: f32 = 65504.0;

#[derive(Clone, Debug, Default)]
pub struct ExrWriteOptions {
    /// Write float32 samples; half (16-bit float) by default.
    pub float32: bool,
    /// x, y, width, height (px) of the display window; `None`: the data window.
    pub display_window: Option<(i32, i32, u32, u32)>,
    /// Position (px) of pixel (0,0) in the display window's coordinate space (EXR data
    /// window minimum).
    pub data_origin: (i32, i32),
    /// Text attributes, e.g. ("realcam/focal_length_mm", "50").
    pub attributes: Vec<(String, String)>,
}

/// Writes a 4-channel image as channels R, G, B, A.
pub fn write_exr_rgba(path: &Path, image: &Image, opts: &ExrWriteOptions) -> Result<(), IoError> {
    super::output::write_file("output", path, &encode_exr_rgba(path, image, opts)?)
}

/// [`write_exr_rgba`]'s bytes (`path` for messages): the same for the same image and options.
pub fn encode_exr_rgba(path: &Path, image: &Image, opts: &ExrWriteOptions) -> Result<Vec<u8>, IoError> {
    if image.channels != 4 {
        return Err(IoError::WrongChannelCount { path: path.into(), expected: "4 (RGBA)".into(), got: image.channels });
    }
    if image.data.len() != image.width as usize * image.height as usize * 4 {
        return Err(IoError::DataLength {
            path: path.into(),
            channel: "R,G,B,A (interleaved)".into(),
            expected: image.width as usize * image.height as usize * 4,
            got: image.data.len(),
        });
    }
    let planes: Vec<Vec<f32>> = (0..4).map(|c| image.data.iter().skip(c).step_by(4).copied().collect()).collect();
    let channels: Vec<(&str, &[f32])> =
        ["R", "G", "B", "A"].into_iter().zip(planes.iter().map(Vec::as_slice)).collect();
    encode_exr_channels(path, image.width, image.height, &channels, opts)
}

/// An EXR text; names (`allow_empty` false) must not be empty.
fn text(path: &Path, what: &str, s: &str, allow_empty: bool) -> Result<Text, IoError> {
    Text::new_or_none(s).filter(|_| allow_empty || !s.is_empty()).ok_or_else(|| IoError::InvalidImage {
        path: path.into(),
        reason: format!("{what} \"{s}\" is empty or has characters outside Latin-1"),
    })
}

/// Writes planar channels, each `width * height` values, row-major, top row first.
pub fn write_exr_channels(
    path: &Path,
    width: u32,
    height: u32,
    channels: &[(&str, &[f32])],
    opts: &ExrWriteOptions,
) -> Result<(), IoError> {
    super::output::write_file("output", path, &encode_exr_channels(path, width, height, channels, opts)?)
}

/// Puts the attributes of a single-part EXR header in the order of their names. The exr crate
/// writes them in the order of a hash map, which differs from run to run; EXR leaves the order
/// free, and a permutation keeps the header's length, so the offset table stays valid. Two
/// runs with the same inputs then write the same bytes. Anything else is left as it is.
fn sort_header_attributes(bytes: &mut [u8]) {
    const MULTIPART: u8 = 0x10; // bit 12 of the version field: byte 5, bit 4
    if bytes.len() < 8 || bytes[5] & MULTIPART != 0 {
        return;
    }
    let mut attributes: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
    let mut pos = 8;
    let nul = |from: usize| bytes.get(from..).and_then(|b| b.iter().position(|&c| c == 0)).map(|i| from + i);
    while bytes.get(pos).is_some_and(|&b| b != 0) {
        let Some(name_end) = nul(pos) else { return };
        let Some(type_end) = nul(name_end + 1) else { return };
        let Some(size) = bytes.get(type_end + 1..type_end + 5) else { return };
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let Some(end) = usize::try_from(size).ok().and_then(|s| (type_end + 5).checked_add(s)) else { return };
        let Some(attribute) = bytes.get(pos..end) else { return };
        attributes.push((bytes[pos..name_end].to_vec(), attribute.to_vec()));
        pos = end;
    }
    attributes.sort();
    let mut at = 8;
    for (_, attribute) in attributes {
        bytes[at..at + attribute.len()].copy_from_slice(&attribute);
        at += attribute.len();
    }
}

/// [`write_exr_channels`]'s bytes (`path` for messages): the same for the same channels and
/// options.
pub fn encode_exr_channels(
    path: &Path,
    width: u32,
    height: u32,
    channels: &[(&str, &[f32])],
    opts: &ExrWriteOptions,
) -> Result<Vec<u8>, IoError> {
    let invalid = |reason: String| IoError::InvalidImage { path: path.into(), reason };
    if width == 0 || height == 0 || channels.is_empty() {
        return Err(invalid(format!("nothing to write ({width}x{height} px, {} channel(s))", channels.len())));
    }
    let n = width as usize * height as usize;
    let mut list = exr::prelude::SmallVec::new();
    let mut clamped = 0usize;
    for (i, (name, data)) in channels.iter().enumerate() {
        if data.len() != n {
            return Err(IoError::DataLength {
                path: path.into(),
                channel: (*name).into(),
                expected: n,
                got: data.len(),
            });
        }
        if channels[..i].iter().any(|(other, _)| other == name) {
            return Err(invalid(format!("channel {name} is given twice")));
        }
        let samples = if opts.float32 {
            FlatSamples::F32(data.to_vec())
        } else {
            let to_half = |&v: &f32| {
                if v.is_finite() && v.abs() > HALF_MAX {
                    clamped += 1;
                    half::f16::from_f32(v.clamp(-HALF_MAX, HALF_MAX))
                } else {
                    half::f16::from_f32(v)
                }
            };
            FlatSamples::F16(data.iter().map(to_half).collect())
        };
        list.push(AnyChannel::new(text(path, "channel name", name, false)?, samples));
    }
    if clamped > 0 {
        log::warn!(
            "\"{}\": {clamped} finite value(s) beyond the half-float range (+-65504) clamped; \
             write float32 to keep them",
            path.display()
        );
    }
    let mut attrs = LayerAttributes {
        layer_position: Vec2(opts.data_origin.0, opts.data_origin.1),
        software_name: Some(Text::from("realcam")),
        ..LayerAttributes::default()
    };
    for (k, v) in &opts.attributes {
        let value = AttributeValue::Text(text(path, "attribute value", v, true)?);
        attrs.other.insert(text(path, "attribute name", k, false)?, value);
    }
    let size = Vec2(width as usize, height as usize);
    let display = match opts.display_window {
        Some((_, _, 0, _)) | Some((_, _, _, 0)) => {
            return Err(invalid("the display window is empty (0 px wide or high)".into()))
        }
        Some((x, y, w, h)) => IntegerBounds::new(Vec2(x, y), Vec2(w as usize, h as usize)),
        None => IntegerBounds::new(attrs.layer_position, size),
    };
    let layer = Layer::new(size, attrs, Encoding::SMALL_LOSSLESS, AnyChannels::sort(list));
    let image = exr::image::Image::new(ImageAttributes::new(display), layer);
    let mut bytes = std::io::Cursor::new(Vec::new());
    image.write().to_buffered(&mut bytes).map_err(|source| IoError::ExrEncode { path: path.into(), source })?;
    let mut bytes = bytes.into_inner();
    sort_header_attributes(&mut bytes);
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{read_exr_rgba, test_dir};
    use exr::prelude::read_all_flat_layers_from_file;

    fn ramp(w: u32, h: u32) -> Image {
        let mut im = Image::new(w, h, 4);
        for (i, v) in im.data.iter_mut().enumerate() {
            *v = (i as f32 - 10.0) * 0.37;
        }
        im.data[5] = 1.0e5; // beyond the half range
        im
    }

    #[test]
    fn round_trip_half_and_float_with_attributes_and_origin() {
        let dir = test_dir("write-roundtrip");
        let im = ramp(5, 3);
        for float32 in [false, true] {
            let path = dir.join(format!("rt_{float32}.exr"));
            let opts = ExrWriteOptions {
                float32,
                display_window: Some((0, 0, 20, 10)),
                data_origin: (7, -3),
                attributes: vec![("realcam/focal_length_mm".into(), "50".into())],
            };
            write_exr_rgba(&path, &im, &opts).unwrap();
            let back = read_exr_rgba(&path).unwrap();
            let expected: Vec<f32> = if float32 {
                im.data.clone()
            } else {
                im.data.iter().map(|&v| half::f16::from_f32(v.min(HALF_MAX)).to_f32()).collect()
            };
            assert_eq!(back.data, expected);
            assert_eq!(back.data[5], if float32 { 1.0e5 } else { HALF_MAX });
            let file = read_all_flat_layers_from_file(&path).unwrap();
            let layer = &file.layer_data[0];
            assert_eq!(file.attributes.display_window, IntegerBounds::new(Vec2(0, 0), Vec2(20, 10)));
            assert_eq!(layer.attributes.layer_position, Vec2(7, -3));
            let value = layer.attributes.other.get(&Text::from("realcam/focal_length_mm"));
            assert_eq!(value, Some(&AttributeValue::Text(Text::from("50"))));
            let is_f32 = matches!(layer.channel_data.list[0].sample_data, FlatSamples::F32(_));
            assert_eq!(is_f32, float32);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The header's attributes in file order.
    fn attribute_names(bytes: &[u8]) -> Vec<String> {
        let mut names = Vec::new();
        let mut pos = 8;
        while bytes[pos] != 0 {
            let name_end = pos + bytes[pos..].iter().position(|&c| c == 0).unwrap();
            let type_end = name_end + 1 + bytes[name_end + 1..].iter().position(|&c| c == 0).unwrap();
            let size = i32::from_le_bytes(bytes[type_end + 1..type_end + 5].try_into().unwrap()) as usize;
            names.push(String::from_utf8_lossy(&bytes[pos..name_end]).into_owned());
            pos = type_end + 5 + size;
        }
        names
    }

    #[test]
    fn the_same_image_gives_the_same_bytes() {
        let dir = test_dir("write-deterministic");
        let attributes: Vec<(String, String)> = (0..12).map(|i| (format!("realcam/k{i}"), format!("{i}"))).collect();
        let opts = ExrWriteOptions { attributes, float32: true, ..Default::default() };
        let path = dir.join("d.exr");
        // Each encoding hashes its attributes with a new random state: without the sorting
        // the order differs between any two of them (12! orders).
        let first = encode_exr_rgba(&path, &ramp(5, 3), &opts).unwrap();
        for _ in 0..4 {
            assert_eq!(encode_exr_rgba(&path, &ramp(5, 3), &opts).unwrap(), first);
        }
        let names = attribute_names(&first);
        let mut sorted = names.clone();
        sorted.sort();
        assert_eq!(names, sorted);
        assert!(names.contains(&"realcam/k11".to_string()) && names.contains(&"dataWindow".to_string()), "{names:?}");
        // Still a valid file with every attribute.
        std::fs::write(&path, &first).unwrap();
        let file = read_all_flat_layers_from_file(&path).unwrap();
        assert_eq!(file.layer_data[0].attributes.other.len(), 12);
        assert_eq!(read_exr_rgba(&path).unwrap(), ramp(5, 3));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn failed_writes_leave_the_target_untouched() {
        let dir = test_dir("write-fail");
        let target = dir.join("out.exr");
        write_exr_rgba(&target, &ramp(4, 2), &ExrWriteOptions::default()).unwrap();
        let before = std::fs::read(&target).unwrap();
        let opts = ExrWriteOptions::default();

        let err = write_exr_rgba(&target, &Image::new(4, 2, 3), &opts).unwrap_err();
        assert!(err.to_string().contains("has 3 channel(s) per pixel, expected 4 (RGBA)"), "{err}");
        let err = write_exr_channels(&target, 4, 2, &[("Z", &[0.0; 7])], &opts).unwrap_err();
        assert!(err.to_string().contains("channel Z holds 7 values, expected 8"), "{err}");
        let reserved = ExrWriteOptions { attributes: vec![("channels".into(), "x".into())], ..Default::default() };
        let err = write_exr_rgba(&target, &ramp(4, 2), &reserved).unwrap_err();
        assert!(err.to_string().starts_with("cannot encode OpenEXR file"), "{err}");
        assert_eq!(std::fs::read(&target).unwrap(), before);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "temporary files left behind");

        let nowhere = dir.join("no_such_dir").join("out.exr");
        let err = write_exr_rgba(&nowhere, &ramp(4, 2), &opts).unwrap_err();
        let folder = dir.join("no_such_dir");
        assert_eq!(
            err.to_string(),
            format!("output \"{}\": the folder \"{}\" does not exist", nowhere.display(), folder.display())
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
