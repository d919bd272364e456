//! `realcam synth`: the deterministic synthetic test scenes, or one generated layered scene.

use anyhow::{Context, Result};
use realcam::tools::layered_scene::LayeredScene;
use realcam::tools::synth::{testdata_scenes, write_scene};
use std::path::Path;

pub fn run(out: &Path, layered: Option<u64>, size: &str, motion: bool, demo_scale: Option<u32>) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    if let Some(k) = demo_scale {
        for p in realcam::tools::synth::write_scaled_demo(out, k)? {
            println!("wrote {}", p.display());
        }
        return Ok(());
    }
    if let Some(seed) = layered {
        let (width, height) = realcam::model::settings::parse_size_px(size).context("--size")?;
        if motion {
            let scene = LayeredScene::random_moving(seed, width, height);
            let paths = scene.render_motion().write(out, &format!("layered_{seed}_motion"))?;
            for p in &paths {
                println!("wrote {}", p.display());
            }
            let [color, depth, vector, truth] = paths.map(|p| p.display().to_string());
            let [open, close] = scene.shutter_frames;
            println!(
                "shutter: centred, {:.0} degrees (open {open} to {close} frames), a box; no defocus (the truth is through a pinhole)\n\
                 e.g. realcam render --color {color} --depth {depth} --velocity {vector} --velocity-format blender \
                 --shutter-angle {:.0} --max-blur 1000 --max-coc 0 --no-flare -o out.exr \
                 (exposure and film at their defaults), against {truth}",
                360.0 * (close - open),
                360.0 * (close - open),
            );
            return Ok(());
        }
        let scene = LayeredScene::random(seed, width, height);
        let paths = scene.render().write(out, &format!("layered_{seed}"))?;
        for p in &paths {
            println!("wrote {}", p.display());
        }
        let [color, depth, truth] = paths.map(|p| p.display().to_string());
        println!(
            "camera: {}\ne.g. realcam accuracy --color {color} --depth {depth} --truth {truth} {} --max-coc {}",
            scene.camera.flags(),
            scene.camera.flags(),
            2 * width
        );
        return Ok(());
    }
    for (name, scene) in testdata_scenes() {
        write_scene(out, name, &scene)?;
        println!("wrote {0}/{name}_color.exr and {0}/{name}_depth.exr", out.display());
    }
    Ok(())
}
