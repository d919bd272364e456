//! `realcam bench`: GPU time per pass of the depth-of-field methods on a frame that is defocused
//! everywhere, for a range of CoC radii, with the fast path's error against the reference.
//! Timings come from timestamp queries; the table names the device.

use crate::gpu::{Gpu, GpuResult, Kernel, Profile, Recorder, TwinCheck};
use crate::io::lens_file::LensFile;
use crate::model::camera::{BokehMode, Camera, CameraRequest};
use crate::model::frame::Frame;
use crate::passes::copy::{self, CopyShader};
use crate::passes::FrameImages;
use crate::pipeline::planner::plan;
use crate::pipeline::render::Renderer;
use crate::tools::metrics::{compare_rgba, local_fidelity, local_fidelity_legend, ImageError, LocalFidelity};
use ash::vk;

const PIXEL_PITCH_MM: f64 = 0.01;

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub width: u32,
    pub height: u32,
    pub coc_radius_px: f64,
    /// The process's host memory peak after the tiled path's runs at this size, in bytes.
    pub host_peak_bytes: u64,
    /// Median over the runs of the tiled path's GPU time per pass.
    pub tiled: Profile,
    pub tiled_ms: f64,
    pub reference_ms: Option<f64>,
    pub error: Option<ImageError>,
    /// Tiles off, worst tile, FLIP (against the reference) and alpha of the tiled path, where
    /// the reference ran.
    pub local: Option<LocalFidelity>,
    /// The bare pass (read the frame, write it) at this resolution, in the same run.
    pub bare_ms: f64,
}

#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub resolutions: Vec<(u32, u32)>,
    pub radii_px: Vec<f64>,
    pub runs: usize,
    /// Run the reference only up to this radius (its cost grows with the radius squared).
    pub reference_max_radius_px: f64,
}

/// The lens of the benchmark: 50 mm at f/1.4 focused at 0.5 m, on a sensor with 10 um pixels
/// (so every radius up to 190 px is reachable at any resolution); the plane's distance sets the CoC.
fn bench_camera(width: u32, height: u32, bokeh: BokehMode) -> Camera {
    let request = CameraRequest {
        sensor: Some(format!("{}x{}", width as f64 * PIXEL_PITCH_MM, height as f64 * PIXEL_PITCH_MM)),
        blades: Some(7),
        blade_rotation_deg: Some(0.0),
        max_coc: crate::model::camera::CocLimit::Px(256.0),
        force: true,
        bokeh,
        ..CameraRequest::blur_only().with_lens(50.0, 1.4, 0.5)
    };
    // Fixed, valid numbers: this cannot fail.
    Camera::new(&LensFile::default_lens(), &request).unwrap_or_else(|e| panic!("bench camera: {e}"))
}

/// A textured plane at the distance whose CoC radius is `coc_radius_px`, with sparse highlights.
pub fn bench_frame(width: u32, height: u32, coc_radius_px: f64, camera: &Camera) -> Frame {
    let pitch_mm = camera.pixel_pitch_mm(width, height);
    let lens = &camera.lens;
    // Kyaw 2013 eq 5.3 solved for u: 1/u = 1/S - C N' P / v^2 (behind the focus plane).
    let v_mm = lens.image_distance_mm();
    let coc_mm = 2.0 * coc_radius_px * pitch_mm;
    let inv_u =
        1.0 / lens.focus_distance_mm - coc_mm * lens.effective_f_number() * lens.pupil_magnification / (v_mm * v_mm);
    // Radii beyond what the lens can reach (the CoC at infinity) are clamped to infinity.
    let depth_m = if inv_u > 0.0 { (1.0 / inv_u / 1000.0) as f32 } else { 1.0e10 };
    let hash = |i: u32| {
        let mut x = i.wrapping_mul(0x9E37_79B9) ^ 0x7F4A_7C15;
        x ^= x >> 16;
        x = x.wrapping_mul(0x85EB_CA6B);
        x ^= x >> 13;
        (x & 0xFFFF) as f32 / 65535.0
    };
    let mut color = Vec::with_capacity((width * height * 4) as usize);
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            let checker = if ((x / 24) + (y / 24)) % 2 == 0 { 0.6 } else { 0.2 };
            let n = 0.1 * hash(i);
            let highlight = if hash(i ^ 0xABCD) > 0.9995 { 50.0 } else { 0.0 };
            color.extend([checker + n + highlight, 0.8 * checker + n + highlight, 0.5 * checker + n + highlight, 1.0]);
        }
    }
    Frame::new(width, height, color, vec![depth_m; (width * height) as usize])
}

/// The bare pass (src/passes/copy.rs) on `frame`: upload, copy, download; its profile, and the
/// dispatch checked against its twin when `twin_checks` is set.
pub fn run_bare_pass(
    gpu: &Gpu,
    kernel: &Kernel<CopyShader>,
    frame: &Frame,
    twin_checks: bool,
) -> GpuResult<(Profile, Vec<TwinCheck>)> {
    let mut rec =
        if twin_checks { Recorder::with_twin_checks(gpu, "bare pass")? } else { Recorder::new(gpu, "bare pass")? };
    rec.begin_pass("upload");
    let color = rec.create_image("color (input)", frame.width, frame.height, vk::Format::R32G32B32A32_SFLOAT)?;
    rec.upload_images(&[(&color, &frame.color)])?;
    rec.end_pass();
    let mut images = FrameImages::new(color, None);
    copy::record(kernel, &mut rec, &mut images)?;
    rec.begin_pass("download");
    rec.download_image(images.color(), 4)?;
    rec.end_pass();
    let (profile, _, checks) = rec.submit_checked()?;
    Ok((profile, checks))
}

/// The bare pass is timed at least this often: it takes a few ms, the noisiest figure of a run
/// on lavapipe (its two threads waking for one short dispatch), and every multiple divides by it.
const BARE_PASS_MIN_RUNS: usize = 15;

/// GPU ms of the bare pass on a `width x height` frame: the median of `runs` (at least
/// BARE_PASS_MIN_RUNS) after a warm-up.
pub fn bare_pass_ms(gpu: &Gpu, width: u32, height: u32, runs: usize) -> GpuResult<f64> {
    let kernel = Kernel::<CopyShader>::new(gpu)?;
    let camera = bench_camera(width, height, BokehMode::Tiled);
    let frame = bench_frame(width, height, 8.0, &camera);
    let time = || run_bare_pass(gpu, &kernel, &frame, false).map(|(p, _)| p.pass_ms(copy::NAME).unwrap_or(f64::NAN));
    time()?;
    let times = (0..runs.max(BARE_PASS_MIN_RUNS)).map(|_| time()).collect::<GpuResult<Vec<_>>>()?;
    Ok(median(times))
}

pub fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}

/// GPU time of the depth-of-field passes (everything but upload and download).
fn dof_ms(profile: &Profile) -> f64 {
    profile.passes.iter().filter(|p| p.name != "upload" && p.name != "download").map(|p| p.gpu_ms).sum()
}

pub fn run(gpu: &Gpu, options: &BenchOptions, mut progress: impl FnMut(&str)) -> GpuResult<Vec<BenchRow>> {
    let mut rows = Vec::new();
    for &(width, height) in &options.resolutions {
        progress(&format!("{width}x{height}: the bare pass"));
        let bare_ms = bare_pass_ms(gpu, width, height, options.runs)?;
        for &radius in &options.radii_px {
            progress(&format!("{width}x{height}, CoC radius {radius} px: tiled"));
            let camera = bench_camera(width, height, BokehMode::Tiled);
            let frame = bench_frame(width, height, radius, &camera);
            let tiled_plan = plan(&frame, &camera);
            let renderer = Renderer::new(gpu, &tiled_plan)?;
            // One warm-up run, then the median of `runs`.
            let mut out = renderer.render(&frame, &tiled_plan, false)?;
            let mut profiles = Vec::new();
            for _ in 0..options.runs.max(1) {
                out = renderer.render(&frame, &tiled_plan, false)?;
                profiles.push(out.profile.clone());
            }
            let tiled_ms = median(profiles.iter().map(dof_ms).collect());
            let tiled = profiles
                .iter()
                .min_by(|a, b| (dof_ms(a) - tiled_ms).abs().total_cmp(&(dof_ms(b) - tiled_ms).abs()))
                .cloned()
                .unwrap_or_default();
            let (mut reference_ms, mut error, mut local) = (None, None, None);
            if radius <= options.reference_max_radius_px {
                progress(&format!("{width}x{height}, CoC radius {radius} px: reference"));
                let camera = bench_camera(width, height, BokehMode::Reference);
                let reference_plan = plan(&frame, &camera);
                let reference = Renderer::new(gpu, &reference_plan)?.render(&frame, &reference_plan, false)?;
                reference_ms = Some(dof_ms(&reference.profile));
                error = Some(compare_rgba(&out.rgba, &reference.rgba));
                local = Some(local_fidelity(&out.rgba, &reference.rgba, &frame.color, width, height));
            }
            let host_peak_bytes = crate::session::report::host_peak_bytes();
            rows.push(BenchRow {
                width,
                height,
                coc_radius_px: radius,
                host_peak_bytes,
                tiled,
                tiled_ms,
                reference_ms,
                error,
                local,
                bare_ms,
            });
        }
    }
    Ok(rows)
}

/// The results as a Markdown table, with the device and the per-pass times of the tiled path.
pub fn markdown(device: &str, command: &str, rows: &[BenchRow]) -> String {
    let mut out = format!("Device: {device}\n\nCommand: `{command}`\n\n");
    out += "Frame defocused everywhere (a textured plane with sparse highlights of 50x), 7-bladed aperture. \
            GPU ms from timestamp queries (median of the runs); error of the tiled path against the reference \
            (`--bokeh reference`), RGB, values clamped to [0,1] for the display RMSE.\n\n";
    out += "Every time is also given as a multiple of the bare pass (read the frame, write it: `glsl/copy.comp`) at the same \
            resolution, measured in the same run.\n\n";
    out += "| resolution | bare pass ms | CoC radius px | tiled ms | x bare | vs radius 8 | reference ms | x bare | RMSE | display RMSE | PSNR dB | energy |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    for r in rows {
        let at8 = rows.iter().find(|o| (o.width, o.height) == (r.width, r.height) && o.coc_radius_px == 8.0);
        let ratio = at8.map_or("".into(), |o| format!("{:.2}x", r.tiled_ms / o.tiled_ms));
        let (reference, reference_x) = match r.reference_ms {
            Some(ms) => (format!("{ms:.1}"), format!("{:.0}x", ms / r.bare_ms)),
            None => ("(skipped)".into(), String::new()),
        };
        let (rmse, display, psnr, energy) = match &r.error {
            Some(e) => (
                format!("{:.4}", e.rmse),
                format!("{:.4}", e.rmse_display),
                format!("{:.1}", e.psnr_db),
                format!("{:+.3}%", 100.0 * e.relative_energy_error),
            ),
            None => Default::default(),
        };
        out += &format!(
            "| {}x{} | {:.2} | {} | {:.1} | {:.0}x | {ratio} | {reference} | {reference_x} | {rmse} | {display} | {psnr} | {energy} |\n",
            r.width,
            r.height,
            r.bare_ms,
            r.coc_radius_px,
            r.tiled_ms,
            r.tiled_ms / r.bare_ms
        );
    }
    out += "\nLocal fidelity of the tiled path against the reference. ";
    out += &local_fidelity_legend();
    out += "\n\n| resolution | CoC radius px | tiles off > 5% | worst tile | FLIP | alpha min | alpha < 0.999 |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- |\n";
    for r in rows {
        if let Some(l) = &r.local {
            let worst = l
                .tiles
                .worst
                .map_or("-".into(), |w| format!("{:+.1}% at px ({}, {})", 100.0 * w.relative_error, w.x, w.y));
            out += &format!(
                "| {}x{} | {} | {:.1}% ({}/{}) | {worst} | {:.4} | {:.4} | {} |\n",
                r.width,
                r.height,
                r.coc_radius_px,
                100.0 * l.tiles.share_off(),
                l.tiles.tiles_off,
                l.tiles.tiles,
                l.flip_mean,
                l.alpha.min,
                l.alpha.holes
            );
        }
    }
    out += "\nMemory of the tiled path, per pixel of the frame: the GPU memory in use when the frame's work \
            was submitted (every image and buffer of the frame alive; the pool's idle ones from earlier frames too) \
            and the allocator's blocks; the process's host peak so far (on a device that runs on the CPU the GPU's \
            memory is in it).\n\n| resolution | CoC radius px | GPU in use B/px | GPU blocks B/px | host peak so far B/px |\n";
    out += "| --- | --- | --- | --- | --- |\n";
    for r in rows {
        let px = (r.width as u64 * r.height as u64).max(1) as f64;
        out += &format!(
            "| {}x{} | {} | {:.0} | {:.0} | {:.0} |\n",
            r.width,
            r.height,
            r.coc_radius_px,
            r.tiled.gpu_memory_bytes as f64 / px,
            r.tiled.gpu_memory_held_bytes as f64 / px,
            r.host_peak_bytes as f64 / px
        );
    }
    out += "\nTiled path, GPU ms per pass:\n\n| resolution | CoC radius px |";
    let names: Vec<String> = rows
        .first()
        .map(|r| r.tiled.passes.iter().map(|p| p.name.clone()).filter(|n| n != "upload" && n != "download").collect())
        .unwrap_or_default();
    for n in &names {
        out += &format!(" {n} |");
    }
    out += "\n| --- | --- |";
    out += &" --- |".repeat(names.len());
    out += "\n";
    for r in rows {
        out += &format!("| {}x{} | {} |", r.width, r.height, r.coc_radius_px);
        for n in &names {
            out += &format!(" {:.2} |", r.tiled.pass_ms(n).unwrap_or(0.0));
        }
        out += "\n";
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bench_plane_has_the_requested_coc() {
        let camera = bench_camera(64, 36, BokehMode::Tiled);
        for radius in [4.0, 8.0, 64.0, 128.0] {
            let frame = bench_frame(64, 36, radius, &camera);
            let pitch_mm = camera.pixel_pitch_mm(64, 36);
            let coc_px = camera.lens.coc_mm(frame.depth_m[0] as f64 * 1000.0) / pitch_mm;
            assert!((coc_px / 2.0 - radius).abs() < 1e-3 * radius, "radius {radius}: got {}", coc_px / 2.0);
        }
    }
}
