//! `realcam bench --flare`: GPU time of the lens-flare passes (src/passes/flare/mod.rs: lights per
//! tile, the light list and its sprites, the ghost-sprite kernel) for 1, 4 and 16 lights found in
//! the frame, with every ghost of the Tessar in lenses/ (21 two-reflection paths), its starburst
//! and halo. Every time is also a multiple of the bare pass measured in the same run, and the
//! kernel's time per sprite is given.

use crate::gpu::{Gpu, GpuResult, Profile};
use crate::io::lens_file::LensFile;
use crate::model::camera::{Camera, CameraRequest};
use crate::model::frame::Frame;
use crate::passes::flare::{bins, ghost_sprites, lights, tiles};
use crate::passes::flare::{Flare, FlareModel, FlareParams};
use crate::passes::PlanInput;
use crate::pipeline::planner::plan;
use crate::pipeline::render::Renderer;
use crate::tools::bench::{bare_pass_ms, median};
use std::path::Path;

/// The lens of the benchmark (and of the flare accuracy report): the Tessar of lenses/, with
/// its prescription and tables.
pub const TESSAR_LENS_TOML: &str = include_str!("../../lenses/tessar-walch-lens.toml");

/// The scene value of a light's pixels: a sun-like 1e5, so that every ghost of every light
/// shows (each adds at least a thousandth of saturation somewhere) and is drawn.
pub const LIGHT_VALUE: f32 = 1.0e5;
/// A light is a square of this many pixels on a side.
pub const LIGHT_SIDE_PX: u32 = 3;

/// The flare passes, in recording order.
pub const FLARE_PASSES: [&str; 4] = [tiles::NAME, lights::NAME, bins::NAME, ghost_sprites::NAME];

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct FlareBenchRow {
    pub width: u32,
    pub height: u32,
    pub lights: usize,
    /// Ghosts in the table (every one the prescription has above the energy cull).
    pub ghosts: usize,
    /// Sprites the lights make: per light its ghosts, its starburst's spikes and one glow.
    pub sprites: usize,
    /// The profile nearest the median.
    pub profile: Profile,
    /// Median GPU ms of the flare passes together.
    pub flare_ms: f64,
    pub bare_ms: f64,
}

impl FlareBenchRow {
    pub fn pass_ms(&self, name: &str) -> f64 {
        self.profile.pass_ms(name).unwrap_or(0.0)
    }
}

#[derive(Clone, Debug)]
pub struct FlareBenchOptions {
    pub resolutions: Vec<(u32, u32)>,
    pub light_counts: Vec<usize>,
    pub runs: usize,
}

/// The Tessar at f/2.8 focused at infinity on a 36 mm wide sensor of the frame's aspect, scene
/// values kept (no exposure, vignetting or film curve), flare on.
pub fn flare_camera(width: u32, height: u32) -> Camera {
    // The embedded lens file is checked by a unit test: this cannot fail.
    let lens =
        LensFile::parse(TESSAR_LENS_TOML, Path::new("lenses/tessar-walch-lens.toml")).unwrap_or_else(|e| panic!("{e}"));
    let request = CameraRequest {
        sensor: Some(format!("36x{}", 36.0 * height as f64 / width as f64)),
        flare: Some(true),
        force: true,
        ..CameraRequest::blur_only().with_lens(lens.focal_length_mm, 2.8, 1.0e4)
    };
    Camera::new(&lens, &request).unwrap_or_else(|e| panic!("flare bench camera: {e}"))
}

/// A dim checkerboard with `lights` bright squares on a grid (as near square as the count
/// allows) over the middle two thirds of the frame, every light at least two tiles from the
/// next so that each is its own light.
pub fn flare_frame(width: u32, height: u32, lights: usize) -> Frame {
    let cols = (lights as f64).sqrt().ceil().max(1.0) as usize;
    let rows = lights.div_ceil(cols).max(1);
    let mut color = Vec::with_capacity((width * height * 4) as usize);
    for y in 0..height {
        for x in 0..width {
            let checker = if ((x / 24) + (y / 24)) % 2 == 0 { 0.3 } else { 0.1 };
            color.extend([checker, 0.9 * checker, 0.8 * checker, 1.0]);
        }
    }
    for k in 0..lights {
        let (i, j) = (k % cols, k / cols);
        let cx = (width as f64 * (1.0 / 6.0 + (i as f64 + 0.5) / cols as f64 * 2.0 / 3.0)) as u32;
        let cy = (height as f64 * (1.0 / 6.0 + (j as f64 + 0.5) / rows as f64 * 2.0 / 3.0)) as u32;
        for y in cy..cy + LIGHT_SIDE_PX {
            for x in cx..cx + LIGHT_SIDE_PX {
                let i = ((y.min(height - 1) * width + x.min(width - 1)) * 4) as usize;
                color[i..i + 3].copy_from_slice(&[LIGHT_VALUE; 3]);
            }
        }
    }
    Frame::new(width, height, color, vec![1.0e4; (width * height) as usize])
}

/// The flare's parameters with every ghost of the catalogue (not only those the plan shows).
pub fn all_ghosts(frame: &Frame, camera: &Camera) -> FlareParams {
    let input = PlanInput::new(frame, camera);
    let model = FlareModel::new(camera, input.facts.pixel_pitch_mm, frame.centre_px);
    FlareParams::new(&input, &model, None)
}

fn flare_ms(profile: &Profile) -> f64 {
    FLARE_PASSES.iter().filter_map(|n| profile.pass_ms(n)).sum()
}

pub fn run(gpu: &Gpu, options: &FlareBenchOptions, mut progress: impl FnMut(&str)) -> GpuResult<Vec<FlareBenchRow>> {
    let mut rows = Vec::new();
    for &(width, height) in &options.resolutions {
        progress(&format!("{width}x{height}: the bare pass"));
        let bare_ms = bare_pass_ms(gpu, width, height, options.runs)?;
        let camera = flare_camera(width, height);
        for &lights in &options.light_counts {
            progress(&format!("{width}x{height}, {lights} lights"));
            let frame = flare_frame(width, height, lights);
            let mut p = plan(&frame, &camera);
            let params = all_ghosts(&frame, &camera);
            let (ghosts, per_light) = (params.ghosts.len(), params.constants.slots_per_light as usize);
            p.force::<Flare>(params);
            let renderer = Renderer::new(gpu, &p)?;
            // One warm-up run, then the median of `runs`.
            renderer.render(&frame, &p, false)?;
            let mut profiles = Vec::new();
            for _ in 0..options.runs.max(1) {
                profiles.push(renderer.render(&frame, &p, false)?.profile);
            }
            let ms = median(profiles.iter().map(flare_ms).collect());
            let profile = profiles
                .iter()
                .min_by(|a, b| (flare_ms(a) - ms).abs().total_cmp(&(flare_ms(b) - ms).abs()))
                .cloned()
                .unwrap_or_default();
            rows.push(FlareBenchRow {
                width,
                height,
                lights,
                ghosts,
                sprites: lights * per_light,
                profile,
                flare_ms: ms,
                bare_ms,
            });
        }
    }
    Ok(rows)
}

/// The results as a Markdown table, with the device.
pub fn markdown(device: &str, command: &str, rows: &[FlareBenchRow]) -> String {
    let mut out = format!("Device: {device}\n\nCommand: `{command}`\n\n");
    out += &format!(
        "The Tessar of lenses/ at f/2.8 on a 36 mm wide sensor; a dim checkerboard with {LIGHT_SIDE_PX}x{LIGHT_SIDE_PX} px \
         lights of scene value {LIGHT_VALUE:.0e}, found in the frame by the GPU; every ghost of the prescription, the \
         starburst and the halo of each light drawn. GPU ms from timestamp queries (median of the runs), also as \
         multiples of the bare pass (read the frame, write it: `glsl/copy.comp`) at the same resolution, measured in \
         the same run. Sprites: per light its ghosts, its starburst's spikes and one glow; the cost per sprite is \
         the kernel's time over one light's, per sprite added.\n\n"
    );
    out += "| resolution | bare pass ms | lights | ghosts | sprites | flare ms | x bare | vs 1 light | flare_tiles | flare_lights | flare_bins | ghost_sprites | ghost_sprites ms per added sprite |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    for r in rows {
        let one = rows.iter().find(|o| (o.width, o.height) == (r.width, r.height) && o.lights == 1);
        let ratio = one.map_or(String::new(), |o| format!("{:.2}x", r.flare_ms / o.flare_ms));
        // The kernel's cost of each sprite more than one light makes (its time per pixel is the
        // rest).
        let per_sprite = one.filter(|o| r.sprites > o.sprites).map_or(String::new(), |o| {
            let added = (r.sprites - o.sprites) as f64;
            format!("{:.2}", (r.pass_ms(ghost_sprites::NAME) - o.pass_ms(ghost_sprites::NAME)) / added)
        });
        let passes: Vec<String> =
            FLARE_PASSES.iter().map(|n| format!("{:.2} ({:.1}x)", r.pass_ms(n), r.pass_ms(n) / r.bare_ms)).collect();
        out += &format!(
            "| {}x{} | {:.2} | {} | {} | {} | {:.2} | {:.1}x | {ratio} | {} | {per_sprite} |\n",
            r.width,
            r.height,
            r.bare_ms,
            r.lights,
            r.ghosts,
            r.sprites,
            r.flare_ms,
            r.flare_ms / r.bare_ms,
            passes.join(" | "),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bench_frame_has_the_requested_lights_and_every_ghost() {
        // Each light is found as its own light (the plan counts its pixels) and the table holds
        // all 21 two-reflection paths of the Tessar's 7 reflecting surfaces (Walch eq 3.3).
        let camera = flare_camera(320, 180);
        for lights in [1, 4, 16] {
            let frame = flare_frame(320, 180, lights);
            let lit = frame.color.chunks_exact(4).filter(|p| p[0] == LIGHT_VALUE).count();
            assert_eq!(lit, lights * (LIGHT_SIDE_PX * LIGHT_SIDE_PX) as usize);
            let params = all_ghosts(&frame, &camera);
            assert_eq!(params.ghosts.len(), 21);
            let p = plan(&frame, &camera);
            assert!(p.params::<Flare>().is_some(), "the flare runs with {lights} lights");
        }
    }
}
