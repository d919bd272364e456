//! Writing 8-bit PNG previews of display-encoded values (the sRGB curve or an OpenColorIO
//! view is applied before: [`crate::pipeline::render::preview_rgba`]).

use super::{Image, IoError};
use image::ImageEncoder;
use std::path::Path;

/// A display-encoded value as an 8-bit code value: clamped to [0, 1], NaN -> 0, rounded.
fn to_code8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (v * 255.0 + 0.5) as u8
}

/// Writes an image of display-encoded values (3 or 4 channels; alpha ignored) as an 8-bit RGB
/// PNG.
pub fn write_png(path: &Path, image: &Image) -> Result<(), IoError> {
    super::output::write_file("png", path, &encode_png(path, image)?)
}

/// [`write_png`]'s bytes (`path` for messages).
pub fn encode_png(path: &Path, image: &Image) -> Result<Vec<u8>, IoError> {
    let n = image.channels as usize;
    if n != 3 && n != 4 {
        return Err(IoError::WrongChannelCount {
            path: path.into(),
            expected: "3 (RGB) or 4 (RGBA)".into(),
            got: image.channels,
        });
    }
    let expected = image.width as usize * image.height as usize * n;
    if image.data.len() != expected || expected == 0 {
        return Err(IoError::DataLength {
            path: path.into(),
            channel: "RGB[A] (interleaved)".into(),
            expected,
            got: image.data.len(),
        });
    }
    let rgb: Vec<u8> = image.data.chunks_exact(n).flat_map(|px| [px[0], px[1], px[2]].map(to_code8)).collect();
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(&rgb, image.width, image.height, image::ExtendedColorType::Rgb8)
        .map_err(|source| IoError::PngEncode { path: path.into(), source })?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_dir;

    #[test]
    fn srgb_encoding_clamps_and_zeroes_nan() {
        let dir = test_dir("png");
        let path = dir.join("a.png");
        let mut im = Image::new(2, 2, 4);
        let linear = [0.0, 0.5, 1.0, 1.0, f32::NAN, 2.0, -1.0, 0.0, 0.001, 0.18, 0.214, 1.0, 1e9, 0.0, 0.0, 1.0];
        im.data = linear.map(crate::optics::colour::srgb_oetf).to_vec();
        write_png(&path, &im).unwrap();
        let back = image::open(&path).unwrap();
        assert_eq!(back.color(), image::ColorType::Rgb8);
        let expected = [0, 188, 255, 0, 255, 0, 3, 118, 127, 255, 0, 0];
        assert_eq!(back.to_rgb8().into_raw(), expected);
        // A failed write keeps the existing file.
        let before = std::fs::read(&path).unwrap();
        let err = write_png(&path, &Image::new(2, 2, 2)).unwrap_err();
        assert!(err.to_string().contains("expected 3 (RGB) or 4 (RGBA)"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), before);
        // Display values are quantised as they are: no second curve.
        im.data = [0.5, 0.3491874, 1.0 / 255.0, 1.0].repeat(4);
        write_png(&path, &im).unwrap();
        assert_eq!(image::open(&path).unwrap().to_rgb8().into_raw()[..3], [128, 89, 1]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
