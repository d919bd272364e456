//! The committed scenes in testdata/ are exactly what the generator in src/tools/synth.rs makes, so
//! the tests' known geometry (depths, highlight energy and position) is the generator's.

use realcam::io::{read_exr_channel, read_exr_rgba};
use std::path::PathBuf;

#[test]
fn committed_testdata_matches_the_generator() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("testdata");
    for (name, scene) in realcam::tools::synth::testdata_scenes() {
        let (color, depth) = scene.render();
        let file_color = read_exr_rgba(&dir.join(format!("{name}_color.exr"))).unwrap_or_else(|e| panic!("{e}"));
        let file_depth =
            read_exr_channel(&dir.join(format!("{name}_depth.exr")), "Z").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(file_color.data, color.data, "{name}: color differs; run `realcam synth --out testdata`");
        assert_eq!(file_depth.data, depth.data, "{name}: depth differs; run `realcam synth --out testdata`");
    }
}

#[test]
fn point_scenes_hold_one_highlight_of_known_energy() {
    for (name, scene) in realcam::tools::synth::testdata_scenes() {
        if !name.starts_with("point_") {
            continue;
        }
        let (color, _) = scene.render();
        let bright: Vec<usize> = (0..color.data.len() / 4).filter(|&i| color.data[i * 4] > 1.0).collect();
        assert_eq!(bright, vec![(72 * 256 + 128) as usize], "{name}");
        assert_eq!(color.data[bright[0] * 4], 400.0);
    }
}
