//! Writing OpenEXR files (one part, ZIP compression or another lossless codec, half or float32
//! samples).

use super::{Image, IoError};
use exr::image::{AnyChannel, AnyChannels, Encoding, FlatSamples, Layer};
use exr::math::Vec2;
use exr::meta::attribute::{AttributeValue, Chromaticities, IntegerBounds, Text};
use exr::meta::header::{ImageAttributes, LayerAttributes};
use exr::prelude::WritableImage;
use std::borrow::Cow;
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
    /// Typed header attributes, e.g. ("aperture", F32(2.8)) or ("realcam/lens", Text(..)).
    /// OpenEXR's standard names (`aperture`, `expTime`, `focus`, `isoSpeed`, `chromaticities`,
    /// `framesPerSecond`, ...) must have their standard type; [`encode_exr_channels`] refuses
    /// another.
    pub attributes: Vec<(String, ExrAttribute)>,
    /// Channels written as float32 even when `float32` is false (kept input channels such as
    /// a depth of 1e10, beyond half's range).
    pub float32_channels: Vec<String>,
    /// The codec of the pixel data.
    pub compression: ExrCompression,
    /// An input's header attributes, any of OpenEXR's types, written as they are
    /// ([`ScenePasses::header_attributes`](super::ScenePasses::header_attributes)). One whose
    /// name realcam writes itself (an entry of `attributes`, `software`, a `realcam/` name)
    /// is written under `input/<name>` (`input/input/<name>` where that is taken too) unless
    /// its value is realcam's; so is a standard name of another type than OpenEXR's.
    pub input_attributes: Vec<(String, AttributeValue)>,
}

/// The `software` attribute of every output: realcam and its version.
pub const SOFTWARE: &str = concat!("realcam ", env!("CARGO_PKG_VERSION"));

/// OpenEXR's lossless codecs, as compositors choose them (Nuke's and Blender's names).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExrCompression {
    /// ZIP, blocks of 16 scanlines: small files, the slowest to write (zlib).
    #[default]
    Zip,
    /// ZIP, one scanline per block.
    Zips,
    /// Wavelet and Huffman, blocks of 32 scanlines: good on noisy (rendered) images.
    Piz,
    /// Run-length: fast, small only where runs of equal values are.
    Rle,
    /// No compression: the fastest to write and read, the largest files.
    None,
}

impl ExrCompression {
    fn encoding(self) -> Encoding {
        use exr::compression::Compression;
        let compression = match self {
            ExrCompression::Zip => Compression::ZIP16,
            ExrCompression::Zips => Compression::ZIP1,
            ExrCompression::Piz => Compression::PIZ,
            ExrCompression::Rle => Compression::RLE,
            ExrCompression::None => Compression::Uncompressed,
        };
        Encoding { compression, ..Encoding::SMALL_LOSSLESS }
    }
}

/// A typed EXR attribute value (OpenEXR's types `string`, `float`, `int`, `v2f`,
/// `chromaticities`, `rational`).
#[derive(Clone, Debug, PartialEq)]
pub enum ExrAttribute {
    Text(String),
    F32(f32),
    I32(i32),
    V2f([f32; 2]),
    /// Red, green, blue and white CIE xy.
    Chromaticities([[f32; 2]; 4]),
    /// numerator / denominator.
    Rational(i32, u32),
}

impl ExrAttribute {
    /// OpenEXR's name of the type.
    pub fn type_name(&self) -> &'static str {
        match self {
            ExrAttribute::Text(_) => "string",
            ExrAttribute::F32(_) => "float",
            ExrAttribute::I32(_) => "int",
            ExrAttribute::V2f(_) => "v2f",
            ExrAttribute::Chromaticities(_) => "chromaticities",
            ExrAttribute::Rational(..) => "rational",
        }
    }
}

/// OpenEXR's standard attributes that realcam writes, with their types (OpenEXR's
/// ImfStandardAttributes.h; the lens and camera ones since OpenEXR 3.2).
const STANDARD_TYPES: [(&str, &str); 12] = [
    ("aperture", "float"),
    ("expTime", "float"),
    ("focus", "float"),
    ("isoSpeed", "float"),
    ("chromaticities", "chromaticities"),
    ("framesPerSecond", "rational"),
    ("lensModel", "string"),
    ("nominalFocalLength", "float"),
    ("effectiveFocalLength", "float"),
    ("sensorOverallDimensions", "v2f"),
    ("sensorPhotositePitch", "float"),
    ("shutterAngle", "float"),
];

/// Puts `value` in the header under `name`: in the exr crate's field for OpenEXR's standard
/// attributes of their standard type, else among the custom ones. Gives the value back where
/// `name` is reserved (a standard name of another type, or one of the file's structure:
/// `channels`, `dataWindow`, ...), which the exr crate refuses among the custom ones.
fn place_attribute(
    layer: &mut LayerAttributes,
    shared: &mut ImageAttributes,
    name: Text,
    value: AttributeValue,
) -> Option<AttributeValue> {
    use AttributeValue as V;
    match (name.to_string().as_str(), value) {
        ("whiteLuminance", V::F32(v)) => layer.white_luminance = Some(v),
        ("adoptedNeutral", V::FloatVec2(v)) => layer.adopted_neutral = Some(v),
        ("renderingTransform", V::Text(v)) => layer.rendering_transform_name = Some(v),
        ("lookModTransform", V::Text(v)) => layer.look_modification_transform_name = Some(v),
        ("xDensity", V::F32(v)) => layer.horizontal_density = Some(v),
        ("owner", V::Text(v)) => layer.owner = Some(v),
        ("comments", V::Text(v)) => layer.comments = Some(v),
        ("capDate", V::Text(v)) => layer.capture_date = Some(v),
        ("utcOffset", V::F32(v)) => layer.utc_offset = Some(v),
        ("longitude", V::F32(v)) => layer.longitude = Some(v),
        ("latitude", V::F32(v)) => layer.latitude = Some(v),
        ("altitude", V::F32(v)) => layer.altitude = Some(v),
        ("focus", V::F32(v)) => layer.focus = Some(v),
        ("expTime", V::F32(v)) => layer.exposure = Some(v),
        ("aperture", V::F32(v)) => layer.aperture = Some(v),
        ("isoSpeed", V::F32(v)) => layer.iso_speed = Some(v),
        ("envmap", V::EnvironmentMap(v)) => layer.environment_map = Some(v),
        ("keyCode", V::KeyCode(v)) => layer.film_key_code = Some(v),
        ("wrapmodes", V::Text(v)) => layer.wrap_mode_name = Some(v),
        ("framesPerSecond", V::Rational(v)) => layer.frames_per_second = Some(v),
        ("multiView", V::TextVector(v)) => layer.multi_view_names = Some(v),
        ("worldToCamera", V::Matrix4x4(v)) => layer.world_to_camera = Some(v),
        ("worldToNDC", V::Matrix4x4(v)) => layer.world_to_normalized_device = Some(v),
        ("deepImageState", V::Rational(v)) => layer.deep_image_state = Some(v),
        ("originalDataWindow", V::IntegerBounds(v)) => layer.original_data_window = Some(v),
        ("preview", V::Preview(v)) => layer.preview = Some(v),
        ("view", V::Text(v)) => layer.view_name = Some(v),
        ("software", V::Text(v)) => layer.software_name = Some(v),
        ("near", V::F32(v)) => layer.near_clip_plane = Some(v),
        ("far", V::F32(v)) => layer.far_clip_plane = Some(v),
        ("fieldOfViewHorizontal", V::F32(v)) => layer.horizontal_field_of_view = Some(v),
        ("fieldOfViewVertical", V::F32(v)) => layer.vertical_field_of_view = Some(v),
        ("chromaticities", V::Chromaticities(v)) => shared.chromaticities = Some(v),
        ("timeCode", V::TimeCode(v)) => shared.time_code = Some(v),
        (_, value) => {
            let reserved = exr::meta::header::standard_names::ALL.iter().any(|n| *n == name.as_slice());
            if reserved {
                return Some(value);
            }
            // The exr crate keeps these two types among the attributes of all parts.
            if matches!(value, V::Chromaticities(_) | V::TimeCode(_)) {
                shared.other.insert(name, value);
            } else {
                layer.other.insert(name, value);
            }
        }
    }
    None
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
    encode_exr_planes(path, image.width, image.height, rgba_planes(image), opts)
}

/// The channels R, G, B and A of a 4-channel image, each its own vector.
pub fn rgba_planes(image: &Image) -> Vec<(&'static str, Cow<'static, [f32]>)> {
    let planes = (0..4).map(|c| Cow::Owned(image.data.iter().skip(c).step_by(4).copied().collect()));
    ["R", "G", "B", "A"].into_iter().zip(planes).collect()
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
/// `bytes` is the file or its start: false when the header runs past its end (nothing sorted).
fn sort_header_attributes(bytes: &mut [u8]) -> bool {
    const MULTIPART: u8 = 0x10; // bit 12 of the version field: byte 5, bit 4
    if bytes.len() < 8 || bytes[5] & MULTIPART != 0 {
        return bytes.len() >= 8;
    }
    let mut attributes: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
    let mut pos = 8;
    let nul = |from: usize| bytes.get(from..).and_then(|b| b.iter().position(|&c| c == 0)).map(|i| from + i);
    while bytes.get(pos).is_some_and(|&b| b != 0) {
        let Some(name_end) = nul(pos) else { return false };
        let Some(type_end) = nul(name_end + 1) else { return false };
        let Some(size) = bytes.get(type_end + 1..type_end + 5) else { return false };
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let Some(end) = usize::try_from(size).ok().and_then(|s| (type_end + 5).checked_add(s)) else { return false };
        let Some(attribute) = bytes.get(pos..end) else { return false };
        attributes.push((bytes[pos..name_end].to_vec(), attribute.to_vec()));
        pos = end;
    }
    if pos >= bytes.len() {
        return false;
    }
    attributes.sort();
    let mut at = 8;
    for (_, attribute) in attributes {
        bytes[at..at + attribute.len()].copy_from_slice(&attribute);
        at += attribute.len();
    }
    true
}

/// [`sort_header_attributes`] of an EXR already written to `file`: its start read back (the
/// whole file if the header is longer), sorted, written over itself.
fn sort_header_attributes_in_file(file: &mut std::fs::File) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom, Write};
    let len = file.seek(SeekFrom::End(0))?;
    let mut start = Vec::new();
    for bytes in [64u64 << 10, len] {
        file.seek(SeekFrom::Start(0))?;
        start.clear();
        Read::by_ref(file).take(bytes).read_to_end(&mut start)?;
        if sort_header_attributes(&mut start) {
            break;
        }
    }
    file.seek(SeekFrom::Start(0))?;
    file.write_all(&start)
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
    let planes = channels.iter().map(|&(name, data)| (name, Cow::Borrowed(data))).collect();
    encode_exr_planes(path, width, height, planes, opts)
}

/// [`encode_exr_channels`] of channels it may keep: a float32 channel given owned is written
/// from its own vector, not a copy (a 1280x720 frame's four channels are 15 MB).
pub fn encode_exr_planes(
    path: &Path,
    width: u32,
    height: u32,
    channels: Vec<(&str, Cow<'_, [f32]>)>,
    opts: &ExrWriteOptions,
) -> Result<Vec<u8>, IoError> {
    // Room for the samples uncompressed, the offset table and the header from the start:
    // grown by doubling instead, the buffer of a 1280x720 float frame passed through five
    // sizes up to 28 MB.
    let sample_bytes: usize = channels
        .iter()
        .map(|(name, _)| if opts.float32 || opts.float32_channels.iter().any(|c| c == name) { 4 } else { 2 })
        .sum();
    let capacity = width as usize * height as usize * sample_bytes + height as usize * 16 + (64 << 10);
    let mut bytes = std::io::Cursor::new(Vec::with_capacity(capacity));
    write_exr_planes_to(&mut bytes, path, width, height, channels, opts)?;
    let mut bytes = bytes.into_inner();
    sort_header_attributes(&mut bytes);
    Ok(bytes)
}

/// [`encode_exr_planes`] written into `file` as it is encoded (an empty file opened for reading
/// and writing; `path` for messages): the same bytes, without the whole file in memory first.
pub fn write_exr_planes_to_file(
    file: &mut std::fs::File,
    path: &Path,
    width: u32,
    height: u32,
    channels: Vec<(&str, Cow<'_, [f32]>)>,
    opts: &ExrWriteOptions,
) -> Result<(), IoError> {
    let mut buffered = std::io::BufWriter::with_capacity(1 << 20, &mut *file);
    write_exr_planes_to(&mut buffered, path, width, height, channels, opts)?;
    let written = buffered.into_inner().map_err(|e| e.into_error());
    written.and_then(sort_header_attributes_in_file).map_err(|source| IoError::Write { path: path.into(), source })
}

/// The EXR of `channels` written to `out`, attributes in the exr crate's order.
fn write_exr_planes_to(
    out: &mut (impl std::io::Write + std::io::Seek),
    path: &Path,
    width: u32,
    height: u32,
    channels: Vec<(&str, Cow<'_, [f32]>)>,
    opts: &ExrWriteOptions,
) -> Result<(), IoError> {
    let invalid = |reason: String| IoError::InvalidImage { path: path.into(), reason };
    if width == 0 || height == 0 || channels.is_empty() {
        return Err(invalid(format!("nothing to write ({width}x{height} px, {} channel(s))", channels.len())));
    }
    let n = width as usize * height as usize;
    let mut list = exr::prelude::SmallVec::new();
    let mut clamped = 0usize;
    let names: Vec<&str> = channels.iter().map(|(name, _)| *name).collect();
    for (i, (name, data)) in channels.into_iter().enumerate() {
        if data.len() != n {
            return Err(IoError::DataLength {
                path: path.into(),
                channel: (*name).into(),
                expected: n,
                got: data.len(),
            });
        }
        if names[..i].contains(&name) {
            return Err(invalid(format!("channel {name} is given twice")));
        }
        let samples = if opts.float32 || opts.float32_channels.iter().any(|c| c == name) {
            FlatSamples::F32(data.into_owned())
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
    let mut attrs =
        LayerAttributes { layer_position: Vec2(opts.data_origin.0, opts.data_origin.1), ..LayerAttributes::default() };
    // Its display window set below.
    let mut shared = ImageAttributes::new(IntegerBounds::new(Vec2(0, 0), Vec2(1, 1)));
    // realcam's own, by name: an input's attribute of the same name and another value is
    // written under input/<name>.
    let mut own: std::collections::BTreeMap<String, AttributeValue> = std::collections::BTreeMap::new();
    own.insert("software".into(), AttributeValue::Text(Text::from(SOFTWARE)));
    for (k, v) in &opts.attributes {
        if let Some((_, standard)) = STANDARD_TYPES.iter().find(|(name, _)| name == k) {
            if *standard != v.type_name() {
                return Err(invalid(format!("attribute {k} is OpenEXR's {standard}, not {}", v.type_name())));
            }
        }
        let value = match v {
            ExrAttribute::Text(t) => AttributeValue::Text(text(path, "attribute value", t, true)?),
            ExrAttribute::F32(f) => AttributeValue::F32(*f),
            ExrAttribute::I32(i) => AttributeValue::I32(*i),
            ExrAttribute::V2f([x, y]) => AttributeValue::FloatVec2(Vec2(*x, *y)),
            ExrAttribute::Rational(n, d) => AttributeValue::Rational((*n, *d)),
            ExrAttribute::Chromaticities([r, g, b, w]) => AttributeValue::Chromaticities(Chromaticities {
                red: Vec2(r[0], r[1]),
                green: Vec2(g[0], g[1]),
                blue: Vec2(b[0], b[1]),
                white: Vec2(w[0], w[1]),
            }),
        };
        own.insert(k.clone(), value);
    }
    for (k, value) in &own {
        // A reserved name that has no field (`channels`, ...): the exr crate refuses it.
        let name = text(path, "attribute name", k, false)?;
        if let Some(value) = place_attribute(&mut attrs, &mut shared, name.clone(), value.clone()) {
            attrs.other.insert(name, value);
        }
    }
    let mut taken: std::collections::BTreeSet<String> = own.keys().cloned().collect();
    let data_window = IntegerBounds::new(attrs.layer_position, Vec2(width as usize, height as usize));
    for (k, value) in &opts.input_attributes {
        if own.get(k) == Some(value) {
            continue;
        }
        // realcam's names, and input/ for the input's own input's attributes (a render of a
        // render): input/<name> is always the input's <name>.
        let realcams = |k: &str| own.contains_key(k) || k.starts_with("realcam/") || k.starts_with("input/");
        let mut name = if realcams(k) { format!("input/{k}") } else { k.clone() };
        while taken.contains(&name) {
            name = format!("input/{name}");
        }
        let mut value = value.clone();
        loop {
            let text_name = text(path, "input attribute name", &name, false)?;
            // One the exr crate would refuse (a name of 256 bytes or more, an empty text
            // vector, ...) is left out rather than the output.
            let mut long_names = false;
            let checked = exr::meta::attribute::validate(&text_name, &value, &mut long_names, true, data_window, true);
            if let Err(e) = checked {
                log::warn!("\"{}\": the input's attribute {k} is left out of the header: {e}", path.display());
                break;
            }
            // A standard name the input gives another type: kept beside, as a custom attribute.
            let Some(refused) = place_attribute(&mut attrs, &mut shared, text_name, value) else {
                taken.insert(name);
                break;
            };
            taken.insert(name.clone());
            while taken.contains(&name) {
                name = format!("input/{name}");
            }
            value = refused;
        }
    }
    let size = Vec2(width as usize, height as usize);
    let display = match opts.display_window {
        Some((_, _, 0, _)) | Some((_, _, _, 0)) => {
            return Err(invalid("the display window is empty (0 px wide or high)".into()))
        }
        Some((x, y, w, h)) => IntegerBounds::new(Vec2(x, y), Vec2(w as usize, h as usize)),
        None => IntegerBounds::new(attrs.layer_position, size),
    };
    let layer = Layer::new(size, attrs, opts.compression.encoding(), AnyChannels::sort(list));
    shared.display_window = display;
    let image = exr::image::Image::new(shared, layer);
    let written = match super::exr_zip::writes(opts.compression.encoding().compression) {
        true => super::exr_zip::write_image(out, &image),
        false => image.write().to_buffered(out),
    };
    written.map_err(|source| IoError::ExrEncode { path: path.into(), source })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{read_exr_rgba, test_dir};
    use exr::prelude::read_all_flat_layers_from_file;

    const REC709: [[f32; 2]; 4] = [[0.64, 0.33], [0.3, 0.6], [0.15, 0.06], [0.3127, 0.329]];

    fn ramp(w: u32, h: u32) -> Image {
        let mut im = Image::new(w, h, 4);
        for (i, v) in im.data.iter_mut().enumerate() {
            *v = (i as f32 - 10.0) * 0.37;
        }
        im.data[5] = 1.0e5; // beyond the half range
        im
    }

    #[test]
    fn a_file_written_as_it_is_encoded_holds_the_encoders_bytes() {
        // Streamed into a file, the header's attributes are sorted afterwards in the file: the
        // same bytes as the encoder's, also for a header longer than the part read back first
        // (a 100 kB text attribute) and with the attributes given in another order.
        let dir = test_dir("write-streamed");
        let im = ramp(13, 7);
        for long in [false, true] {
            let text = if long { "x".repeat(100_000) } else { "a 50".into() };
            let opts = ExrWriteOptions {
                attributes: vec![
                    ("realcam/zoom".into(), ExrAttribute::F32(2.0)),
                    ("realcam/lens".into(), ExrAttribute::Text(text)),
                ],
                ..ExrWriteOptions::default()
            };
            let path = dir.join(format!("streamed-{long}.exr"));
            let encoded = encode_exr_planes(&path, 13, 7, rgba_planes(&im), &opts).unwrap();
            let mut file =
                std::fs::OpenOptions::new().read(true).write(true).create(true).truncate(true).open(&path).unwrap();
            write_exr_planes_to_file(&mut file, &path, 13, 7, rgba_planes(&im), &opts).unwrap();
            drop(file);
            let written = std::fs::read(&path).unwrap();
            assert_eq!(written.len(), encoded.len(), "long header: {long}");
            assert!(written == encoded, "long header: {long}: the bytes differ");
            let mut reversed = opts.clone();
            reversed.attributes.reverse();
            assert!(encode_exr_planes(&path, 13, 7, rgba_planes(&im), &reversed).unwrap() == encoded);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn every_codec_is_lossless_and_says_its_name() {
        // Each codec gives back the float samples bit for bit (a noisy image, 1e5 included), and
        // the header names the codec a reader will decode.
        let dir = test_dir("write-codecs");
        let mut im = ramp(37, 35);
        for (i, v) in im.data.iter_mut().enumerate() {
            *v += ((i * 7919) % 101) as f32 * 1.0e-3;
        }
        let codecs = [
            (ExrCompression::Zip, "ZIP16"),
            (ExrCompression::Zips, "ZIP1"),
            (ExrCompression::Piz, "PIZ"),
            (ExrCompression::Rle, "RLE"),
            (ExrCompression::None, "Uncompressed"),
        ];
        let mut sizes = Vec::new();
        for (codec, name) in codecs {
            let path = dir.join(format!("{name}.exr"));
            let opts = ExrWriteOptions { float32: true, compression: codec, ..Default::default() };
            write_exr_rgba(&path, &im, &opts).unwrap();
            let back = read_exr_rgba(&path).unwrap();
            assert!(back.data.iter().zip(&im.data).all(|(a, b)| a.to_bits() == b.to_bits()), "{name} is not lossless");
            let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
            assert_eq!(format!("{:?}", meta.headers[0].compression), name);
            sizes.push(std::fs::metadata(&path).unwrap().len());
        }
        // Uncompressed is the largest: 37 x 35 x 4 samples of 4 bytes, plus the header.
        assert!(sizes[4] > 37 * 35 * 16 && sizes.iter().all(|&s| s <= sizes[4]), "{sizes:?}");
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
                float32_channels: Vec::new(),
                compression: ExrCompression::Zip,
                input_attributes: Vec::new(),
                attributes: vec![
                    ("realcam/lens".into(), ExrAttribute::Text("a 50".into())),
                    ("aperture".into(), ExrAttribute::F32(2.8)),
                    ("expTime".into(), ExrAttribute::F32(0.02)),
                    ("focus".into(), ExrAttribute::F32(3.5)),
                    ("isoSpeed".into(), ExrAttribute::F32(200.0)),
                    ("framesPerSecond".into(), ExrAttribute::Rational(24, 1)),
                    ("nominalFocalLength".into(), ExrAttribute::F32(50.0)),
                    ("sensorOverallDimensions".into(), ExrAttribute::V2f([36.0, 24.0])),
                    ("realcam/aperture_blades".into(), ExrAttribute::I32(9)),
                    ("chromaticities".into(), ExrAttribute::Chromaticities(REC709)),
                ],
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
            // Read back typed, the standard ones where the exr crate keeps them.
            let a = &layer.attributes;
            assert_eq!((a.aperture, a.exposure, a.focus, a.iso_speed), (Some(2.8), Some(0.02), Some(3.5), Some(200.0)));
            assert_eq!(a.frames_per_second, Some((24, 1)));
            let other = |k: &str| a.other.get(&Text::from(k)).cloned();
            assert_eq!(other("realcam/lens"), Some(AttributeValue::Text(Text::from("a 50"))));
            assert_eq!(other("nominalFocalLength"), Some(AttributeValue::F32(50.0)));
            assert_eq!(other("sensorOverallDimensions"), Some(AttributeValue::FloatVec2(Vec2(36.0, 24.0))));
            assert_eq!(other("realcam/aperture_blades"), Some(AttributeValue::I32(9)));
            let c = file.attributes.chromaticities.expect("chromaticities");
            assert_eq!([c.red, c.green, c.blue, c.white].map(|v| [v.0, v.1]), REC709);
            let is_f32 = matches!(layer.channel_data.list[0].sample_data, FlatSamples::F32(_));
            assert_eq!(is_f32, float32);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_inputs_attributes_are_written_as_they_are_and_realcams_win_a_clash() {
        // Any type, as given; a name realcam writes (focus, software, a realcam/ name) keeps
        // realcam's value and the input's goes under input/ unless the values are the same; an
        // input's own input/ name goes one level deeper; a standard name of another type is
        // kept under input/.
        let dir = test_dir("write-input-attributes");
        let path = dir.join("a.exr");
        let t = |s: &str| AttributeValue::Text(Text::from(s));
        let aces = Chromaticities {
            red: Vec2(0.713, 0.293),
            green: Vec2(0.165, 0.83),
            blue: Vec2(0.128, 0.044),
            white: Vec2(0.32168, 0.33767),
        };
        let input = vec![
            ("cryptomatte/abc1234/name".to_string(), t("CryptoObject")),
            ("Frame".into(), t("12")),
            ("samples".into(), AttributeValue::I32(128)),
            ("exposureBias".into(), AttributeValue::F32(0.5)),
            ("worldToCamera".into(), AttributeValue::Matrix4x4(std::array::from_fn(|i| i as f32 * 0.5))),
            ("owner".into(), t("studio")),
            ("focus".into(), AttributeValue::F32(7.5)),
            ("aperture".into(), AttributeValue::F32(2.8)),
            ("software".into(), t("Blender 3.4")),
            ("realcam/grain".into(), AttributeValue::F32(0.05)),
            ("input/focus".into(), AttributeValue::F32(1.0)),
            ("comments".into(), AttributeValue::I32(3)),
            ("chromaticities".into(), AttributeValue::Chromaticities(aces)),
            (format!("realcam/{}", "x".repeat(245)), AttributeValue::I32(1)),
            ("timeCode".into(), AttributeValue::TimeCode(exr::meta::attribute::TimeCode::default())),
        ];
        let opts = ExrWriteOptions {
            attributes: vec![
                ("focus".into(), ExrAttribute::F32(3.0)),
                ("aperture".into(), ExrAttribute::F32(2.8)),
                ("chromaticities".into(), ExrAttribute::Chromaticities(REC709)),
            ],
            input_attributes: input.clone(),
            ..Default::default()
        };
        write_exr_rgba(&path, &ramp(3, 2), &opts).unwrap();
        let header = exr::meta::MetaData::read_from_file(&path, false).unwrap().headers.remove(0);
        let written: std::collections::BTreeMap<String, AttributeValue> =
            header.all_named_attributes().map(|(k, v)| (Text::from_slice_unchecked(k).to_string(), v)).collect();
        let get = |k: &str| written.get(k).cloned();
        for (k, v) in &input[..6] {
            assert_eq!(get(k).as_ref(), Some(v), "{k}");
        }
        assert_eq!(get("focus"), Some(AttributeValue::F32(3.0)));
        assert_eq!(get("input/focus"), Some(AttributeValue::F32(7.5)));
        assert_eq!(get("input/input/focus"), Some(AttributeValue::F32(1.0)));
        assert_eq!(get("aperture"), Some(AttributeValue::F32(2.8)));
        assert_eq!(get("input/aperture"), None, "the same value is written once");
        assert_eq!(get("software"), Some(t(SOFTWARE)));
        assert_eq!(get("input/software"), Some(t("Blender 3.4")));
        assert_eq!(get("realcam/grain"), None);
        assert_eq!(get("input/realcam/grain"), Some(AttributeValue::F32(0.05)));
        assert_eq!((get("comments"), get("input/comments")), (None, Some(AttributeValue::I32(3))));
        assert_eq!(get("input/chromaticities"), Some(AttributeValue::Chromaticities(aces)));
        assert_eq!(get("timeCode"), Some(input.last().unwrap().1.clone()));
        // input/realcam/xxx... would be 253 + 6 bytes, over OpenEXR's 255: left out, alone.
        assert!(!written.keys().any(|k| k.ends_with("xxx")), "{written:?}");
        assert!(SOFTWARE.starts_with("realcam ") && SOFTWARE.ends_with(env!("CARGO_PKG_VERSION")), "{SOFTWARE}");
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
        let attributes: Vec<(String, ExrAttribute)> =
            (0..12).map(|i| (format!("realcam/k{i}"), ExrAttribute::Text(format!("{i}")))).collect();
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
        let reserved = ExrWriteOptions {
            attributes: vec![("channels".into(), ExrAttribute::Text("x".into()))],
            ..Default::default()
        };
        let err = write_exr_rgba(&target, &ramp(4, 2), &reserved).unwrap_err();
        assert!(err.to_string().starts_with("cannot encode OpenEXR file"), "{err}");
        let mistyped = ExrWriteOptions {
            attributes: vec![("aperture".into(), ExrAttribute::Text("f/2".into()))],
            ..Default::default()
        };
        let err = write_exr_rgba(&target, &ramp(4, 2), &mistyped).unwrap_err();
        assert!(err.to_string().ends_with("attribute aperture is OpenEXR's float, not string"), "{err}");
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
