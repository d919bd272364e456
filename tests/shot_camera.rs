//! A shot's camera per frame (issue 31, item 1): each frame's settings from a flag, a camera
//! file's keys, the frame's own header (`focus`, `aperture`), or the default, in that order;
//! the output's header and its in-focus plane follow the frame. The `realcam` binary renders
//! inputs written here with the exr crate; outputs are read back with it.

mod support;
use support::TestDir;

use exr::image::{AnyChannel, AnyChannels, Encoding, FlatSamples, Layer};
use exr::math::Vec2;
use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::meta::header::{ImageAttributes, LayerAttributes};
use exr::prelude::{ReadChannels, ReadLayers, WritableImage};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const W: usize = 256;
const H: usize = 64;
/// The left half of the frame is at 1 m, the right half at 3 m.
const NEAR_M: f32 = 1.0;
const FAR_M: f32 = 3.0;

/// A one-pixel checkerboard (0.1 / 0.9) over two planes, 1 m on the left, 3 m on the right,
/// with `attributes` in its header.
fn write_input(path: &Path, attributes: &[(&str, f32)]) {
    let checker: Vec<f32> = (0..W * H).map(|i| if (i % W + i / W).is_multiple_of(2) { 0.1 } else { 0.9 }).collect();
    let depth: Vec<f32> = (0..W * H).map(|i| if i % W < W / 2 { NEAR_M } else { FAR_M }).collect();
    let channels = vec![
        AnyChannel::new("R", FlatSamples::F32(checker.clone())),
        AnyChannel::new("G", FlatSamples::F32(checker.clone())),
        AnyChannel::new("B", FlatSamples::F32(checker)),
        AnyChannel::new("A", FlatSamples::F32(vec![1.0; W * H])),
        AnyChannel::new("Z", FlatSamples::F32(depth)),
    ];
    let mut layer_attributes = LayerAttributes::default();
    for (name, value) in attributes {
        match *name {
            "focus" => layer_attributes.focus = Some(*value),
            "aperture" => layer_attributes.aperture = Some(*value),
            _ => {
                layer_attributes.other.insert(Text::from(*name), AttributeValue::F32(*value));
            }
        }
    }
    let layer = Layer::new(
        Vec2(W, H),
        layer_attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels.into_iter().collect()),
    );
    let image = exr::image::Image::new(ImageAttributes::new(IntegerBounds::from_dimensions(Vec2(W, H))), layer);
    image.write().to_file(path).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
}

/// Runs `realcam render` with `args` in `dir` (the ideal lens, linear film, no exposure gain,
/// vignetting or flare: pixels stay scene values).
fn realcam(dir: &TestDir, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(["render", "--validate", "--lens", "ideal", "--film", "linear", "--no-exposure", "--no-vignetting"])
        .args(["--no-flare", "--float"])
        .args(args)
        .current_dir(&dir.0)
        .env("REALCAM_CACHE_DIR", dir.join("cache"))
        .env_remove("OCIO")
        .env_remove("REALCAM_VALIDATE")
        .output()
        .expect("running the realcam binary")
}

fn succeeded(out: Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "realcam failed ({:?}):\n{stderr}", out.status.code());
    stderr
}

fn header(path: &Path) -> BTreeMap<String, AttributeValue> {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .unwrap_or_else(|e| panic!("reading the header of {}: {e}", path.display()));
    meta.headers[0].all_named_attributes().map(|(n, v)| (Text::from_slice_unchecked(n).to_string(), v)).collect()
}

fn float(header: &BTreeMap<String, AttributeValue>, name: &str) -> f32 {
    match header.get(name) {
        Some(AttributeValue::F32(v)) => *v,
        other => panic!("{name}: {other:?}"),
    }
}

fn text(header: &BTreeMap<String, AttributeValue>, name: &str) -> String {
    match header.get(name) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{name}: {other:?}"),
    }
}

/// The output's R channel, row-major.
fn red(path: &Path) -> Vec<f32> {
    let image = exr::image::read::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let channel = image.layer_data.channel_data.list.iter().find(|c| c.name == *"R").expect("an R channel");
    channel.sample_data.values_as_f32().collect()
}

/// The checkerboard's contrast left in the half of the frame from `x0` to `x1` (the mean
/// absolute difference between horizontal neighbours, 0.8 when sharp), rows and columns away
/// from the frame's edges and the depth edge.
fn contrast(red: &[f32], x0: usize, x1: usize) -> f32 {
    let mut sum = 0.0;
    let mut n = 0;
    for y in 16..H - 16 {
        for x in x0 + 16..x1 - 16 {
            sum += (red[y * W + x + 1] - red[y * W + x]).abs();
            n += 1;
        }
    }
    sum / n as f32
}

/// The goal of issue 31: frames whose headers carry `focus` 1 m / `aperture` 2 and `focus`
/// 3 m / `aperture` 8, rendered with no camera flags: each output's `focus`/`aperture`
/// attributes and its in-focus plane follow its frame.
#[test]
fn each_frame_takes_the_camera_its_header_carries() {
    let dir = TestDir::new("shot-headers");
    write_input(&dir.join("in_0001.exr"), &[("focus", 1.0), ("aperture", 2.0)]);
    write_input(&dir.join("in_0002.exr"), &[("focus", 3.0), ("aperture", 8.0)]);
    let stderr = succeeded(realcam(&dir, &["--color", "in_####.exr", "--frames", "1-2", "-o", "out_####.exr"]));
    assert!(!stderr.contains("warning"), "{stderr}");
    let (near, far) = ((0, W / 2), (W / 2, W));
    for (frame, focus_m, f_number) in [(1, 1.0, 2.0), (2, 3.0, 8.0)] {
        let path = dir.join(&format!("out_000{frame}.exr"));
        let h = header(&path);
        assert_eq!(float(&h, "focus"), focus_m, "frame {frame}");
        assert_eq!(float(&h, "aperture"), f_number, "frame {frame}");
        assert_eq!(text(&h, "realcam/source/focus_distance_m"), "the input's focus attribute");
        assert_eq!(text(&h, "realcam/source/f_number"), "the input's aperture attribute");
        assert_eq!(text(&h, "realcam/source/shutter_s"), "default");
        // The plane in focus keeps the checkerboard whole (a CoC of 0 copies the pixel); the
        // other is blurred: at f/2 the 3 m plane by a 6 px disc, at f/8 the 1 m plane by 1.5 px.
        let r = red(&path);
        let (sharp, blurred) = if focus_m == 1.0 { (near, far) } else { (far, near) };
        let (c_sharp, c_blurred) = (contrast(&r, sharp.0, sharp.1), contrast(&r, blurred.0, blurred.1));
        assert!((c_sharp - 0.8).abs() < 0.01, "frame {frame}: the plane at {focus_m} m is not sharp: {c_sharp}");
        assert!(c_blurred < 0.4, "frame {frame}: the plane out of focus keeps contrast {c_blurred}");
    }
}

/// A camera file's rack focus over one shared input; a flag wins over the file, the file over
/// the input's header, and a header that disagrees is warned about once.
#[test]
fn a_camera_file_racks_focus_and_a_flag_wins() {
    let dir = TestDir::new("shot-keys");
    write_input(&dir.join("in.exr"), &[("focus", 5.0), ("aperture", 4.0)]);
    std::fs::write(
        dir.join("rack.toml"),
        "[focus_distance_m]\ninterpolation = \"linear\"\nkeys = [[1, 1.0], [3, 3.0]]\n",
    )
    .unwrap();
    let args =
        ["--color", "in.exr", "--camera-file", "rack.toml", "--frames", "1-3", "-o", "out_####.exr", "--explain"];
    let stderr = succeeded(realcam(&dir, &args));
    for (frame, focus_m) in [(1, 1.0), (2, 2.0), (3, 3.0)] {
        let h = header(&dir.join(&format!("out_000{frame}.exr")));
        assert_eq!(float(&h, "focus"), focus_m, "frame {frame}");
        // The input's aperture: no flag or key gives one.
        assert_eq!(float(&h, "aperture"), 4.0, "frame {frame}");
        assert_eq!(text(&h, "realcam/source/focus_distance_m"), "the camera file \"rack.toml\"");
    }
    assert_eq!(
        stderr.matches("warning: frame 1: the input's focus attribute says focus distance 5 m, the camera file \"rack.toml\" says 1").count(),
        1,
        "{stderr}"
    );
    assert_eq!(stderr.matches("the input's focus attribute says").count(), 1, "said once: {stderr}");
    assert!(stderr.contains("focus distance 2 m: the camera file \"rack.toml\""), "--explain: {stderr}");

    // A flag over both.
    let mut flagged = args.to_vec();
    flagged.extend(["--focus", "2.5"]);
    flagged[7] = "flag_####.exr";
    succeeded(realcam(&dir, &flagged));
    let h = header(&dir.join("flag_0003.exr"));
    assert_eq!(float(&h, "focus"), 2.5);
    assert_eq!(text(&h, "realcam/source/focus_distance_m"), "flag --focus");
}

/// A single render of an animated camera file must say which frame it is.
#[test]
fn a_single_render_of_an_animated_camera_file_needs_its_frame() {
    let dir = TestDir::new("shot-single");
    write_input(&dir.join("in.exr"), &[]);
    std::fs::write(dir.join("iris.toml"), "[f_number]\nkeys = [[10, 2.0], [20, 8.0]]\n").unwrap();
    let out = realcam(&dir, &["--color", "in.exr", "--camera-file", "iris.toml", "-o", "out.exr"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.trim_end().ends_with(
            "error: --camera-file: the camera file \"iris.toml\" changes f_number over frames 10 to 20: say which \
             frame this render is with --frame N, or render the shot with --frames"
        ),
        "{stderr}"
    );
    // Halfway by the default smooth curve: the mean of the keys.
    succeeded(realcam(&dir, &["--color", "in.exr", "--camera-file", "iris.toml", "--frame", "15", "-o", "out.exr"]));
    assert_eq!(float(&header(&dir.join("out.exr")), "aperture"), 5.0);
}

/// A USD camera's time samples drive a rack focus (issue 31, item 2); `fStop` 0 leaves the
/// f-number to the input's header.
#[test]
fn a_usd_camera_racks_focus_frame_by_frame() {
    let dir = TestDir::new("shot-usd");
    write_input(&dir.join("in.exr"), &[("aperture", 4.0)]);
    std::fs::write(
        dir.join("shot.usda"),
        "#usda 1.0\n(\n    metersPerUnit = 1\n)\n\ndef Xform \"Camera\"\n{\n    def Camera \"Lens\"\n    {\n        \
         float focusDistance.timeSamples = {\n            1: 1,\n            3: 3,\n        }\n        float fStop = 0\n    }\n}\n",
    )
    .unwrap();
    let args = ["--color", "in.exr", "--camera-file", "shot.usda", "--frames", "1-3", "-o", "out_####.exr"];
    succeeded(realcam(&dir, &args));
    for (frame, focus_m) in [(1, 1.0), (2, 2.0), (3, 3.0)] {
        let h = header(&dir.join(&format!("out_000{frame}.exr")));
        assert_eq!(float(&h, "focus"), focus_m, "frame {frame}");
        assert_eq!(float(&h, "aperture"), 4.0, "frame {frame}");
        assert_eq!(text(&h, "realcam/source/focus_distance_m"), "the USD camera /Camera/Lens of \"shot.usda\"");
    }
}

/// Python with Blender as a module (bpy 4.2 LTS, built with USD): `$REALCAM_BPY_PYTHON`, else the
/// virtual environment scripts/test.sh installs it into; None when there is none and
/// `$REALCAM_REQUIRE_BPY` is not set (scripts/test.sh sets it, so CI never skips).
fn bpy_python() -> Option<PathBuf> {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bpy-venv/bin/python");
    let found = std::env::var_os("REALCAM_BPY_PYTHON").map(PathBuf::from).or_else(|| venv.exists().then_some(venv));
    if found.is_none() {
        assert!(
            std::env::var_os("REALCAM_REQUIRE_BPY").is_none(),
            "REALCAM_REQUIRE_BPY is set but bpy is not installed (scripts/test.sh installs it)"
        );
        eprintln!("skipped: bpy (Blender as a Python module) is not installed (scripts/test.sh installs it into target/bpy-venv)");
    }
    found
}

/// Issue 31, item 2: a camera keyed in Blender (focus 1 -> 3 m, f/2 -> f/8 over frames 1-3) and
/// exported by Blender's USD exporter drives the shot: each output's `focus`, `aperture` and
/// focal length follow the file's samples (Blender writes the lens in tenths of a metre), and
/// the plane in focus moves from the near half of the frame to the far one.
#[test]
fn a_camera_blender_exports_to_usd_racks_focus_and_pulls_the_iris() {
    let Some(python) = bpy_python() else { return };
    let dir = TestDir::new("shot-blender-usd");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/blender/export_usd_camera.py");
    let export = Command::new(&python).arg(&script).arg(dir.join("shot.usda")).output().expect("running bpy");
    assert!(export.status.success(), "{}", String::from_utf8_lossy(&export.stderr));
    let usda = std::fs::read_to_string(dir.join("shot.usda")).unwrap();
    assert!(usda.contains("doc = \"Blender v4.2"), "not Blender's export:\n{usda}");
    write_input(&dir.join("in.exr"), &[]);
    let args = ["--color", "in.exr", "--camera-file", "shot.usda", "--frames", "1-3", "-o", "out_####.exr"];
    succeeded(realcam(&dir, &args));
    let (near, far) = ((0, W / 2), (W / 2, W));
    // Blender's Bezier keys pass halfway at frame 2.
    for (frame, focus_m, f_number) in [(1, 1.0, 2.0), (2, 2.0, 5.0), (3, 3.0, 8.0)] {
        let path = dir.join(&format!("out_000{frame}.exr"));
        let h = header(&path);
        assert_eq!(float(&h, "focus"), focus_m, "frame {frame}");
        assert_eq!(float(&h, "aperture"), f_number, "frame {frame}");
        assert!((float(&h, "effectiveFocalLength") - 50.0).abs() < 1e-3, "frame {frame}");
        let origin = "the USD camera /root/Camera/Camera of \"shot.usda\"";
        for setting in ["focus_distance_m", "f_number", "focal_length_mm"] {
            assert_eq!(text(&h, &format!("realcam/source/{setting}")), origin, "frame {frame}");
        }
        if frame != 2 {
            let r = red(&path);
            let (sharp, blurred) = if focus_m == 1.0 { (near, far) } else { (far, near) };
            let (c_sharp, c_blurred) = (contrast(&r, sharp.0, sharp.1), contrast(&r, blurred.0, blurred.1));
            assert!((c_sharp - 0.8).abs() < 0.01, "frame {frame}: the plane at {focus_m} m is not sharp: {c_sharp}");
            assert!(c_blurred < 0.4, "frame {frame}: the plane out of focus keeps contrast {c_blurred}");
        }
    }
}
