//! `realcam bench --flare`: GPU time of the lens-flare passes (src/passes/flare/mod.rs: lights per
//! tile, the light list and its sprites, the ghost-sprite kernel) for 1, 4 and 16 lights found in
//! the frame, with every ghost of the Tessar in lenses/ (21 two-reflection paths), its starburst
//! and halo; then the same lights with the Tessar's fitted ghosts (Walch ch. 6-8, the 21
//! `[[fitted_ghost]]` of docs/flare/tessar-walch-fitted.toml) drawing the ghosts instead. Every
//! time is also a multiple of the bare pass measured in the same run, and the kernel's time per
//! sprite is given.

use crate::gpu::{Gpu, GpuResult, Profile};
use crate::io::lens_file::LensFile;
use crate::model::camera::{Camera, CameraRequest};
use crate::model::frame::Frame;
use crate::passes::flare::{bins, fitted_ghosts, ghost_sprites, lights, tiles};
use crate::passes::flare::{Flare, FlareModel, FlareParams};
use crate::passes::PlanInput;
use crate::pipeline::planner::plan;
use crate::pipeline::render::Renderer;
use crate::tools::bench::{bare_pass_ms, median};
use std::path::Path;

/// The lens of the benchmark (and of the flare accuracy report): the Tessar of lenses/, with
/// its prescription and tables.
pub const TESSAR_LENS_TOML: &str = include_str!("../../lenses/tessar-walch-lens.toml");

/// The Tessar with its ghosts fitted by `realcam flare-fit` (green, 0..12 deg, 1280x720).
pub const TESSAR_FITTED_TOML: &str = include_str!("../../docs/flare/tessar-walch-fitted.toml");

/// The scene value of a light's pixels: a sun-like 1e5, so that every ghost of every light
/// shows (each adds at least a thousandth of saturation somewhere) and is drawn.
pub const LIGHT_VALUE: f32 = 1.0e5;
/// The scene value of the lights where the fitted ghosts are compared with the matrix ghosts:
/// the Tessar's fitted primitives spread their light over 1000-2000 px (at most 1e-11 of the
/// light's energy per px), so a light of 1e5 draws none of them; at 1e9 most show.
pub const FITTED_LIGHT_VALUE: f32 = 1.0e9;
/// A light is a square of this many pixels on a side.
pub const LIGHT_SIDE_PX: u32 = 3;

/// The flare passes, in recording order.
pub const FLARE_PASSES: [&str; 5] = [tiles::NAME, lights::NAME, bins::NAME, ghost_sprites::NAME, fitted_ghosts::NAME];

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct FlareBenchRow {
    /// Which model drew the ghosts: "matrix" or "fitted".
    pub model: &'static str,
    /// The lights' scene value.
    pub light_value: f32,
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

    /// Whether `o` is the same resolution and model.
    fn same_set(&self, o: &FlareBenchRow) -> bool {
        (o.width, o.height, o.model, o.light_value) == (self.width, self.height, self.model, self.light_value)
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
    camera_of(TESSAR_LENS_TOML, "lenses/tessar-walch-lens.toml", width, height)
}

/// [`flare_camera`] with the fitted Tessar (docs/flare/tessar-walch-fitted.toml): its fitted
/// ghosts draw (`--flare-ghosts auto`).
pub fn fitted_camera(width: u32, height: u32) -> Camera {
    camera_of(TESSAR_FITTED_TOML, "docs/flare/tessar-walch-fitted.toml", width, height)
}

fn camera_of(text: &str, path: &str, width: u32, height: u32) -> Camera {
    // The embedded lens files are checked by a unit test: this cannot fail.
    let lens = LensFile::parse(text, Path::new(path)).unwrap_or_else(|e| panic!("{e}"));
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
    flare_frame_of(width, height, lights, LIGHT_VALUE)
}

/// [`flare_frame`] with lights of scene value `value`.
pub fn flare_frame_of(width: u32, height: u32, lights: usize, value: f32) -> Frame {
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
                color[i..i + 3].copy_from_slice(&[value; 3]);
            }
        }
    }
    Frame::new(width, height, color, vec![1.0e4; (width * height) as usize])
}

/// The flare's parameters with every ghost of the catalogue (not only those the plan shows).
pub fn all_ghosts(frame: &Frame, camera: &Camera) -> FlareParams {
    let input = PlanInput::new(frame, camera);
    let model = FlareModel::chosen(camera, input.facts.pixel_pitch_mm, frame.centre_px);
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
        let (matrix, fitted) = (flare_camera(width, height), fitted_camera(width, height));
        let sets = [
            ("matrix", &matrix, LIGHT_VALUE),
            ("matrix", &matrix, FITTED_LIGHT_VALUE),
            ("fitted", &fitted, FITTED_LIGHT_VALUE),
        ];
        for (&lights, &(model, camera, light_value)) in
            options.light_counts.iter().flat_map(|l| sets.iter().map(move |c| (l, c)))
        {
            progress(&format!("{width}x{height}, {lights} lights of {light_value:.0e}, {model} ghosts"));
            let frame = flare_frame_of(width, height, lights, light_value);
            let mut p = plan(&frame, camera);
            let params = all_ghosts(&frame, camera);
            let ghosts = params.ghosts.len() + params.constants.fitted_count as usize;
            let per_light = params.constants.slots_per_light as usize;
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
                model,
                light_value,
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

/// The kernels that draw the sprites: ghost_sprites, and fitted_ghosts where the ghosts are fitted.
fn sprite_kernels_ms(r: &FlareBenchRow) -> f64 {
    r.pass_ms(ghost_sprites::NAME) + r.pass_ms(fitted_ghosts::NAME)
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
         the kernel's time over one light's, per sprite added. Ghosts: 'matrix' the prescription's ray-transfer \
         matrices (lenses/tessar-walch-lens.toml), 'fitted' Walch's fitted primitives (ch. 6-8) of \
         docs/flare/tessar-walch-fitted.toml (21 ghosts in green) for the same lights; 'sprite kernels' is \
         ghost_sprites + fitted_ghosts (the second runs only for fitted ghosts, on the tiles they cross), \
         'fitted / matrix' their time with the fitted ghosts over it with the matrix ghosts for the same \
         lights; the fitted ghosts need lights of {FITTED_LIGHT_VALUE:.0e} to show, so both models are measured \
         there too.\n\n"
    );
    out += "| resolution | ghosts model | bare pass ms | lights | light value | ghosts | sprites | flare ms | x bare | vs 1 light | flare_tiles | flare_lights | flare_bins | ghost_sprites | fitted_ghosts | sprite kernels ms per added sprite | fitted / matrix |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    for r in rows {
        let one = rows.iter().find(|o| r.same_set(o) && o.lights == 1);
        let matrix = rows.iter().find(|o| {
            (o.width, o.height, o.lights, o.model, o.light_value)
                == (r.width, r.height, r.lights, "matrix", r.light_value)
                && r.model == "fitted"
        });
        let versus = matrix.map_or(String::new(), |m| format!("{:.2}x", sprite_kernels_ms(r) / sprite_kernels_ms(m)));
        let ratio = one.map_or(String::new(), |o| format!("{:.2}x", r.flare_ms / o.flare_ms));
        // The kernel's cost of each sprite more than one light makes (its time per pixel is the
        // rest).
        let per_sprite = one.filter(|o| r.sprites > o.sprites).map_or(String::new(), |o| {
            let added = (r.sprites - o.sprites) as f64;
            format!("{:.2}", (sprite_kernels_ms(r) - sprite_kernels_ms(o)) / added)
        });
        let passes: Vec<String> =
            FLARE_PASSES.iter().map(|n| format!("{:.2} ({:.1}x)", r.pass_ms(n), r.pass_ms(n) / r.bare_ms)).collect();
        out += &format!(
            "| {}x{} | {} | {:.2} | {} | {:.0e} | {} | {} | {:.2} | {:.1}x | {ratio} | {} | {per_sprite} | {versus} |\n",
            r.width,
            r.height,
            r.model,
            r.bare_ms,
            r.lights,
            r.light_value,
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
            // The fitted Tessar: its 21 fitted ghosts instead of the matrices.
            let fitted = all_ghosts(&frame, &fitted_camera(320, 180));
            assert_eq!((fitted.ghosts.len(), fitted.constants.fitted_count), (0, 21));
        }
    }
}
