//! `realcam synth`: the deterministic synthetic test scenes.

use anyhow::{Context, Result};
use realcam::tools::synth::{testdata_scenes, write_scene};
use std::path::Path;

pub fn run(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    for (name, scene) in testdata_scenes() {
        write_scene(out, name, &scene)?;
        println!("wrote {0}/{name}_color.exr and {0}/{name}_depth.exr", out.display());
    }
    Ok(())
}
