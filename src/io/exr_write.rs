//! Writing OpenEXR files (one part, ZIP compression, half or float32 samples).

use super::{write_file_atomically, Image, IoError};
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
    write_exr_channels(path, image.width, image.height, &channels, opts)
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
    write_file_atomically(path, bytes.get_ref())
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
        assert!(err.to_string().contains(&format!("cannot write \"{}\"", nowhere.display())), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
