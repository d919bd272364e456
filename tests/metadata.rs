//! The input's header attributes in the output (issue 31, "metadata kept"): the `realcam`
//! binary renders an input whose header has Cryptomatte's metadata, a renderer's camera and
//! custom attributes; the output's header is read back with the exr crate.

mod support;
use support::TestDir;

use exr::image::{AnyChannel, AnyChannels, Encoding, FlatSamples, Layer};
use exr::math::Vec2;
use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::meta::header::{ImageAttributes, LayerAttributes};
use exr::prelude::WritableImage;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

const W: usize = 16;
const H: usize = 8;

fn text(s: &str) -> AttributeValue {
    AttributeValue::Text(Text::from(s))
}

/// The Cryptomatte metadata of one layer, as Blender writes it (`<id>` from the layer's name).
fn cryptomatte() -> Vec<(&'static str, AttributeValue)> {
    vec![
        ("cryptomatte/f834d0a/name", text("CryptoObject")),
        ("cryptomatte/f834d0a/hash", text("MurmurHash3_32")),
        ("cryptomatte/f834d0a/conversion", text("uint32_to_float32")),
        ("cryptomatte/f834d0a/manifest", text(r#"{"Cube":"3f2f24ce","Plane":"0c8e8b1f"}"#)),
    ]
}

/// The input's own attributes besides Cryptomatte's: a float, an int, a Blender stamp, a
/// renderer's camera (`focus`, 7.5 m: realcam writes its own) and its `software`.
fn custom() -> Vec<(&'static str, AttributeValue)> {
    vec![
        ("renderTime_s", AttributeValue::F32(12.25)),
        ("cycles/samples", AttributeValue::I32(128)),
        ("Camera", text("Camera.001")),
        ("focus", AttributeValue::F32(7.5)),
        ("software", text("Blender 3.4.1")),
    ]
}

/// The Cryptomatte channels' values: ids and coverages, as stored.
fn crypto_values(c: usize) -> Vec<f32> {
    (0..W * H).map(|i| (i * 4 + c) as f32 * 0.125 - 3.0).collect()
}

/// Writes a float32 input with R, G, B, A, Z (3 m) and `CryptoObject00.R/G/B/A`, whose header
/// has `attributes`.
fn write_input(path: &Path, attributes: &[(&str, AttributeValue)]) {
    let constant = |v: f32| FlatSamples::F32(vec![v; W * H]);
    let mut channels = vec![
        AnyChannel::new("R", constant(0.2)),
        AnyChannel::new("G", constant(0.3)),
        AnyChannel::new("B", constant(0.4)),
        AnyChannel::new("A", constant(1.0)),
        AnyChannel::new("Z", constant(3.0)),
    ];
    for (c, name) in ["R", "G", "B", "A"].into_iter().enumerate() {
        channels.push(AnyChannel::new(format!("CryptoObject00.{name}").as_str(), FlatSamples::F32(crypto_values(c))));
    }
    let mut layer_attributes = LayerAttributes::default();
    for (name, value) in attributes {
        match (*name, value) {
            ("focus", AttributeValue::F32(v)) => layer_attributes.focus = Some(*v),
            ("software", AttributeValue::Text(t)) => layer_attributes.software_name = Some(t.clone()),
            _ => {
                layer_attributes.other.insert(Text::from(*name), value.clone());
            }
        }
    }
    let layer = Layer::new(
        Vec2(W, H),
        layer_attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into_iter().collect()),
    );
    let image = exr::image::Image::new(ImageAttributes::new(IntegerBounds::from_dimensions(Vec2(W, H))), layer);
    image.write().to_file(path).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
}

/// Renders `input` into `output` with `extra` flags; panics with the run's output on failure.
fn render(dir: &TestDir, input: &Path, output: &Path, extra: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .arg("render")
        .arg("--validate")
        .arg("--color")
        .arg(input)
        .arg("-o")
        .arg(output)
        .args(["--fstop", "2", "--focus", "3"])
        .args(extra)
        .current_dir(&dir.0)
        .env("REALCAM_CACHE_DIR", dir.join("cache"))
        .env_remove("OCIO")
        .env_remove("REALCAM_VALIDATE")
        .output()
        .expect("running the realcam binary");
    assert!(
        out.status.success(),
        "realcam failed ({:?}):\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Every attribute of the first header, by name, the standard ones included.
fn header(path: &Path) -> BTreeMap<String, AttributeValue> {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .unwrap_or_else(|e| panic!("reading the header of {}: {e}", path.display()));
    let header = &meta.headers[0];
    header.all_named_attributes().map(|(name, value)| (Text::from_slice_unchecked(name).to_string(), value)).collect()
}

fn channel_names(path: &Path) -> Vec<String> {
    let meta = exr::meta::MetaData::read_from_file(path, false).unwrap();
    meta.headers[0].channels.list.iter().map(|c| c.name.to_string()).collect()
}

/// With --keep-layers the kept Cryptomatte channels come with their name, hash, conversion and
/// manifest, and the input's custom attributes (a float, an int, a stamp) come as they were;
/// `software` is realcam's with its version. Without the flag, the Cryptomatte metadata stays
/// behind with its channels; the rest still comes.
#[test]
fn keep_layers_keeps_the_cryptomatte_metadata_and_the_inputs_attributes() {
    let dir = TestDir::new("metadata-keep");
    let input = dir.join("in.exr");
    let attributes: Vec<_> = cryptomatte().into_iter().chain(custom()).collect();
    write_input(&input, &attributes);
    let output = dir.join("out.exr");
    render(&dir, &input, &output, &["--keep-layers"]);
    let written = header(&output);
    for (name, value) in cryptomatte().iter().chain(&custom()[..3]) {
        assert_eq!(written.get(*name), Some(value), "{name}: {written:?}");
    }
    let names = channel_names(&output);
    for (c, name) in ["R", "G", "B", "A"].into_iter().enumerate() {
        let name = format!("CryptoObject00.{name}");
        assert!(names.contains(&name), "{name} not in {names:?}");
        let kept = realcam::io::read_exr_channel(&output, &name).unwrap();
        assert_eq!(kept.data, crypto_values(c), "{name}");
    }
    let Some(AttributeValue::Text(software)) = written.get("software") else {
        panic!("no software attribute: {written:?}")
    };
    let software = software.to_string();
    assert!(software.starts_with("realcam "), "{software}");
    assert_eq!(software, format!("realcam {}", env!("CARGO_PKG_VERSION")));

    render(&dir, &input, &output, &[]);
    let written = header(&output);
    assert!(!written.keys().any(|k| k.starts_with("cryptomatte/")), "{written:?}");
    for (name, value) in &custom()[..3] {
        assert_eq!(written.get(*name), Some(value), "{name}: {written:?}");
    }
    assert_eq!(channel_names(&output), ["A", "B", "G", "R"]);
}

/// An input attribute that realcam writes itself (`focus`, `software`): realcam's value is the
/// output's, the input's is kept under `input/<name>`; one that realcam writes with the same
/// value is written once.
#[test]
fn an_input_attribute_realcam_writes_too_is_kept_under_input() {
    let dir = TestDir::new("metadata-clash");
    let input = dir.join("in.exr");
    let mut attributes = custom();
    attributes.push(("realcam/aperture_blades", AttributeValue::I32(5)));
    write_input(&input, &attributes);
    let output = dir.join("out.exr");
    render(&dir, &input, &output, &["--keep-layers"]);
    let written = header(&output);
    assert_eq!(written.get("focus"), Some(&AttributeValue::F32(3.0)), "{written:?}");
    assert_eq!(written.get("input/focus"), Some(&AttributeValue::F32(7.5)), "{written:?}");
    assert_eq!(written.get("input/software"), Some(&text("Blender 3.4.1")), "{written:?}");
    assert_eq!(written.get("input/realcam/aperture_blades"), Some(&AttributeValue::I32(5)), "{written:?}");
    assert!(matches!(written.get("realcam/aperture_blades"), Some(AttributeValue::I32(b)) if *b != 5), "{written:?}");
    assert_eq!(written.get("input/aperture"), None, "no aperture in the input: {written:?}");

    // A render of that render: its input/ attributes go one level deeper, and its realcam
    // attributes equal to this render's are written once.
    let again = dir.join("again.exr");
    render(&dir, &output, &again, &["--keep-layers"]);
    let twice = header(&again);
    assert_eq!(twice.get("input/input/focus"), Some(&AttributeValue::F32(7.5)), "{twice:?}");
    assert_eq!(twice.get("input/focus"), None, "the same focus: {twice:?}");
    assert_eq!(twice.get("input/input/software"), Some(&text("Blender 3.4.1")), "{twice:?}");
    assert_eq!(twice.get("renderTime_s"), Some(&AttributeValue::F32(12.25)), "{twice:?}");
}
