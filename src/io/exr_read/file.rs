//! An EXR file decoded whole: every channel of every part, with the header attributes realcam
//! reads, and the channel look-ups the passes use.

use super::{IoError, MemoryBudget};
use exr::image::FlatSamples;
use std::io::Read;
use std::path::{Path, PathBuf};

/// One channel of a decoded file.
pub(super) struct Chan {
    /// Qualified name (`part.channel` in multi-part files).
    pub(super) name: String,
    /// Name as stored in its part.
    pub(super) bare: String,
    /// Data window size (px) and position (px) of its part.
    pub(super) size: (usize, usize),
    pub(super) origin: (i32, i32),
    pub(super) samples: FlatSamples,
}

impl Chan {
    pub(super) fn to_f32(&self) -> Vec<f32> {
        match &self.samples {
            FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
        }
    }

    pub(super) fn type_name(&self) -> &'static str {
        match self.samples {
            FlatSamples::F16(_) => "half",
            FlatSamples::F32(_) => "float",
            FlatSamples::U32(_) => "uint",
        }
    }
}

/// A decoded EXR file: every channel of every part.
pub(super) struct ExrFile {
    pub(super) path: PathBuf,
    pub(super) display_window: (i32, i32, u32, u32),
    pub(super) chans: Vec<Chan>,
    /// The focal length (mm) its first part's header gives, with the attribute's name.
    pub(super) focal_length_mm: Option<(f64, String)>,
    /// Its `chromaticities` attribute: the colour space of its RGB.
    pub(super) chromaticities: Option<crate::optics::colour::Chromaticities>,
    /// Its first part's header attributes, in name order, those of the file's structure
    /// ([`STRUCTURAL_ATTRIBUTES`]) left out.
    pub(super) header_attributes: Vec<(String, exr::meta::attribute::AttributeValue)>,
}

/// The attributes that describe a file's layout rather than its image: its channels, blocks,
/// windows and codec, its parts' names, and the `preview` thumbnail of its pixels. An output
/// has its own; the input's are not carried into it.
pub const STRUCTURAL_ATTRIBUTES: [&str; 17] = [
    "channels",
    "compression",
    "dataWindow",
    "displayWindow",
    "lineOrder",
    "pixelAspectRatio",
    "screenWindowCenter",
    "screenWindowWidth",
    "name",
    "type",
    "version",
    "chunkCount",
    "tiles",
    "maxSamplesPerPixel",
    "dwaCompressionLevel",
    "deepImageState",
    "preview",
];

/// A header's attributes as the file holds them (the exr crate's typed fields named again),
/// those of [`STRUCTURAL_ATTRIBUTES`] left out, in name order.
fn header_attributes(header: &exr::meta::header::Header) -> Vec<(String, exr::meta::attribute::AttributeValue)> {
    // The exr crate turns these two counts into i32 as it lists them; both are structural.
    let mut header = header.clone();
    header.chunk_count = 0;
    header.max_samples_per_pixel = None;
    let mut attributes: Vec<_> = header
        .all_named_attributes()
        .map(|(name, value)| (exr::meta::attribute::Text::from_slice_unchecked(name).to_string(), value))
        .filter(|(name, _)| !STRUCTURAL_ATTRIBUTES.contains(&name.as_str()))
        .collect();
    attributes.sort_by(|a, b| a.0.cmp(&b.0));
    attributes
}

/// The focal length a renderer wrote in a header: OpenEXR's lens attributes (floats, mm), else
/// Blender's `Lens` stamp (a text such as "50.00 mm").
pub(super) fn header_focal_length_mm(attributes: &exr::meta::header::LayerAttributes) -> Option<(f64, String)> {
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

pub(super) const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// How many times the exr crate panicked on a file and the panic became an error (the fuzzing
/// harness counts them: each is a decoder bug to report).
pub static DECODER_PANICS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Bytes per pixel that [`load_passes`](super::load_passes) allocates beyond the decoded
/// samples: the interleaved colour (4 f32), depth (1) and velocity (2), and one channel
/// converted to f32 at a time.
pub(super) const LOADED_BYTES_PER_PX: u64 = 4 * (4 + 1 + 2 + 1);

/// A channel's name as realcam reads it: `part.channel` in a multi-part file (unless the
/// stored name already starts with the part's), else as stored.
fn qualified_name(part: Option<&str>, multi_part: bool, bare: &str) -> String {
    match part {
        Some(p) if multi_part && !bare.starts_with(&format!("{p}.")) => format!("{p}.{bare}"),
        _ => bare.to_string(),
    }
}

impl ExrFile {
    /// The file's channels from its headers alone, with no samples: what the channel names say
    /// before the pixels are read (None where the headers do not read).
    pub(super) fn names_only(path: &Path) -> Option<ExrFile> {
        let meta = exr::meta::MetaData::read_from_file(path, false).ok()?;
        let multi_part = meta.headers.len() > 1;
        let mut chans = Vec::new();
        for header in &meta.headers {
            let part = header.own_attributes.layer_name.as_ref().map(|t| t.to_string());
            for ch in &header.channels.list {
                let bare = ch.name.to_string();
                chans.push(Chan {
                    name: qualified_name(part.as_deref(), multi_part, &bare),
                    bare,
                    size: (header.layer_size.0, header.layer_size.1),
                    origin: (header.own_attributes.layer_position.0, header.own_attributes.layer_position.1),
                    samples: FlatSamples::F32(Vec::new()),
                });
            }
        }
        Some(ExrFile {
            path: path.into(),
            display_window: (0, 0, 0, 0),
            chans,
            focal_length_mm: None,
            chromaticities: None,
            header_attributes: Vec::new(),
        })
    }

    pub(super) fn open(path: &Path, what: &str, budget: &MemoryBudget) -> Result<ExrFile, IoError> {
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
        let header_attributes = meta.headers.first().map(header_attributes).unwrap_or_default();
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
                let name = qualified_name(part.as_deref(), multi_part, &bare);
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
            header_attributes,
        })
    }

    /// A channel by qualified name, else by bare name when that is unique.
    pub(super) fn find(&self, name: &str) -> Option<&Chan> {
        if let Some(c) = self.chans.iter().find(|c| c.name == name) {
            return Some(c);
        }
        let mut it = self.chans.iter().filter(|c| c.bare == name);
        match (it.next(), it.next()) {
            (Some(c), None) => Some(c),
            _ => None,
        }
    }

    pub(super) fn find_all(&self, names: &[&str]) -> Option<Vec<&Chan>> {
        names.iter().map(|n| self.find(n)).collect()
    }

    /// The channel names, for error messages.
    pub(super) fn found(&self) -> String {
        const MAX: usize = 64;
        let mut s = self.chans.iter().take(MAX).map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ");
        if self.chans.is_empty() {
            s.push_str("(none)");
        } else if self.chans.len() > MAX {
            s.push_str(&format!(", ... ({} more)", self.chans.len() - MAX));
        }
        s
    }

    pub(super) fn missing(&self, what: &str, looked_for: &str) -> IoError {
        IoError::MissingChannel {
            what: what.into(),
            path: self.path.clone(),
            looked_for: looked_for.into(),
            found: self.found(),
        }
    }

    /// All of `names`, or an error naming the first missing one.
    pub(super) fn require(&self, what: &str, requested: &str, names: &[&str]) -> Result<Vec<&Chan>, IoError> {
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
