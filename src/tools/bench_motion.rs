//! `realcam bench --motion-blur`: GPU time per pass of the motion blur against the longest blur,
//! on a frame that moves everywhere (a textured background panning, a nearer disc moving across
//! it the other way), with the reference's time and the fast path's error against it where the
//! reference runs. Every time is also a multiple of the bare pass measured in the same run.

use crate::gpu::{Gpu, GpuResult, Profile};
use crate::io::lens_file::LensFile;
use crate::model::camera::{Camera, CameraRequest, MotionBlurMode};
use crate::model::frame::Frame;
use crate::pipeline::planner::plan;
use crate::pipeline::render::Renderer;
use crate::tools::bench::{bare_pass_ms, median};
use crate::tools::metrics::{compare_rgba, ImageError};

/// The shutter of the benchmark: half a frame, centred, at 24 fps.
const SHUTTER_FRAMES: f64 = 0.5;

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct MotionBenchRow {
    pub width: u32,
    pub height: u32,
    /// The longest blur in the frame (px over the open shutter).
    pub blur_px: f64,
    /// The fast path's profile nearest its median.
    pub fast: Profile,
    pub fast_ms: f64,
    pub reference_ms: Option<f64>,
    pub error: Option<ImageError>,
    pub bare_ms: f64,
}

#[derive(Clone, Debug)]
pub struct MotionBenchOptions {
    pub resolutions: Vec<(u32, u32)>,
    pub blurs_px: Vec<f64>,
    pub runs: usize,
    /// Run the reference only up to this blur (its cost grows with the blur).
    pub reference_max_blur_px: f64,
}

fn bench_camera(mode: MotionBlurMode) -> Camera {
    let request = CameraRequest {
        max_coc: crate::model::camera::CocLimit::Px(0.0),
        force: true,
        fps: Some(24.0),
        shutter_angle_deg: Some(360.0 * SHUTTER_FRAMES),
        motion_blur: mode,
        ..CameraRequest::blur_only()
    };
    // Fixed, valid numbers: this cannot fail.
    Camera::new(&LensFile::default_lens(), &request).unwrap_or_else(|e| panic!("motion bench camera: {e}"))
}

/// A textured background at 10 m panning left and a disc at 2 m (a third of the height across)
/// moving right and down, so that the longest blur over the shutter is `blur_px`.
pub fn motion_frame(width: u32, height: u32, blur_px: f64) -> Frame {
    let speed = (blur_px / SHUTTER_FRAMES) as f32;
    let (cx, cy, r) = (width as f32 * 0.5, height as f32 * 0.5, height as f32 / 6.0);
    let (mut color, mut depth, mut next) = (Vec::new(), Vec::new(), Vec::new());
    for y in 0..height {
        for x in 0..width {
            let (dx, dy) = (x as f32 + 0.5 - cx, y as f32 + 0.5 - cy);
            let on_disc = dx * dx + dy * dy < r * r;
            let checker = if ((x / 24) + (y / 24)) % 2 == 0 { 0.6 } else { 0.2 };
            let c = if on_disc { [1.5, 0.8, 0.3] } else { [checker, 0.8 * checker, 0.5 * checker] };
            color.extend([c[0], c[1], c[2], 1.0]);
            depth.push(if on_disc { 2.0 } else { 10.0 });
            next.extend(if on_disc { [0.8 * speed, 0.6 * speed] } else { [-0.5 * speed, 0.0] });
        }
    }
    Frame::new(width, height, color, depth).with_velocity(next, None)
}

/// GPU time of the motion-blur passes (everything but upload and download).
fn motion_ms(profile: &Profile) -> f64 {
    profile.passes.iter().filter(|p| p.name != "upload" && p.name != "download").map(|p| p.gpu_ms).sum()
}

pub fn run(gpu: &Gpu, options: &MotionBenchOptions, mut progress: impl FnMut(&str)) -> GpuResult<Vec<MotionBenchRow>> {
    let mut rows = Vec::new();
    for &(width, height) in &options.resolutions {
        progress(&format!("{width}x{height}: the bare pass"));
        let bare_ms = bare_pass_ms(gpu, width, height, options.runs)?;
        for &blur_px in &options.blurs_px {
            progress(&format!("{width}x{height}, blur {blur_px} px: fast"));
            let frame = motion_frame(width, height, blur_px);
            let fast_plan = plan(&frame, &bench_camera(MotionBlurMode::Fast));
            let renderer = Renderer::new(gpu, &fast_plan)?;
            // One warm-up run, then the median of `runs`.
            let mut out = renderer.render(&frame, &fast_plan, false)?;
            let mut profiles = Vec::new();
            for _ in 0..options.runs.max(1) {
                out = renderer.render(&frame, &fast_plan, false)?;
                profiles.push(out.profile.clone());
            }
            let fast_ms = median(profiles.iter().map(motion_ms).collect());
            let fast = profiles
                .iter()
                .min_by(|a, b| (motion_ms(a) - fast_ms).abs().total_cmp(&(motion_ms(b) - fast_ms).abs()))
                .cloned()
                .unwrap_or_default();
            let (mut reference_ms, mut error) = (None, None);
            if blur_px <= options.reference_max_blur_px {
                progress(&format!("{width}x{height}, blur {blur_px} px: reference"));
                let reference_plan = plan(&frame, &bench_camera(MotionBlurMode::Reference));
                let reference = Renderer::new(gpu, &reference_plan)?.render(&frame, &reference_plan, false)?;
                reference_ms = Some(motion_ms(&reference.profile));
                error = Some(compare_rgba(&out.rgba, &reference.rgba));
            }
            rows.push(MotionBenchRow { width, height, blur_px, fast, fast_ms, reference_ms, error, bare_ms });
        }
    }
    Ok(rows)
}

/// The results as a Markdown table, with the device and the fast path's time per pass.
pub fn markdown(device: &str, command: &str, rows: &[MotionBenchRow]) -> String {
    let mut out = format!("Device: {device}\n\nCommand: `{command}`\n\n");
    out += "The whole frame moves: a textured background panning, a disc in front moving the other way; the longest \
            blur over the shutter (0.5 frame, centred) as given. GPU ms from timestamp queries (median of the runs), \
            also as multiples of the bare pass (read the frame, write it: `glsl/copy.comp`) at the same resolution, \
            measured in the same run; the fast path against the reference (`--motion-blur reference`), RGB.\n\n";
    out += "| resolution | bare pass ms | blur px | fast ms | x bare | vs blur 8 | reference ms | x bare | RMSE | display RMSE | energy |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    for r in rows {
        let at8 = rows.iter().find(|o| (o.width, o.height) == (r.width, r.height) && o.blur_px == 8.0);
        let ratio = at8.map_or(String::new(), |o| format!("{:.2}x", r.fast_ms / o.fast_ms));
        let (reference, reference_x) = match r.reference_ms {
            Some(ms) => (format!("{ms:.1}"), format!("{:.0}x", ms / r.bare_ms)),
            None => ("(skipped)".into(), String::new()),
        };
        let (rmse, display, energy) = match &r.error {
            Some(e) => (
                format!("{:.4}", e.rmse),
                format!("{:.4}", e.rmse_display),
                format!("{:+.3}%", 100.0 * e.relative_energy_error),
            ),
            None => Default::default(),
        };
        out += &format!(
            "| {}x{} | {:.2} | {} | {:.1} | {:.0}x | {ratio} | {reference} | {reference_x} | {rmse} | {display} | {energy} |\n",
            r.width,
            r.height,
            r.bare_ms,
            r.blur_px,
            r.fast_ms,
            r.fast_ms / r.bare_ms
        );
    }
    // Every step of the fast path, the anti-aliased-edge resolve's first.
    use crate::passes::motion::{edges, gather, neighbor, still, tiles};
    let steps =
        [edges::TILES_NAME, edges::LIST_NAME, edges::NAME, tiles::NAME, neighbor::NAME, gather::NAME, still::NAME];
    out += &format!(
        "\nFast path, GPU ms per pass (x bare pass):\n\n| resolution | blur px | {} |\n| --- | --- |{}\n",
        steps.join(" | "),
        " --- |".repeat(steps.len())
    );
    for r in rows {
        out += &format!("| {}x{} | {} |", r.width, r.height, r.blur_px);
        for n in steps {
            let ms = r.fast.pass_ms(n).unwrap_or(0.0);
            out += &format!(" {ms:.2} ({:.1}x) |", ms / r.bare_ms);
        }
        out += "\n";
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bench_frame_has_the_requested_longest_blur() {
        let camera = bench_camera(MotionBlurMode::Fast);
        for blur in [8.0, 32.0, 128.0] {
            let frame = motion_frame(64, 36, blur);
            let p = plan(&frame, &camera);
            let params = p.params::<crate::passes::motion::blur::MotionBlur>().expect("runs");
            assert!((params.motion.max_blur_px - blur).abs() < 1e-3 * blur, "{blur}: {}", params.motion.max_blur_px);
        }
    }
}

/// One image of the motion-blur accuracy report.
#[derive(Clone, Debug)]
pub struct MotionAccuracyRow {
    pub method: String,
    /// GPU ms of the motion-blur passes (none for the pinhole and the CPU blur).
    pub gpu_ms: Option<f64>,
    pub error: ImageError,
}

/// A plain single-direction blur, for comparison: every pixel averages the colours along its own
/// straight path (next velocity, both ways over the open time), no depth, no neighbours (CPU).
pub fn single_direction_blur(frame: &Frame, camera: &Camera) -> Vec<f32> {
    let Some(next) = frame.velocity_px.as_ref() else { return frame.color.clone() };
    let t = &camera.motion.timing;
    let (w, h) = (frame.width as i64, frame.height as i64);
    let mut out = frame.color.clone();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (vx, vy) = (next[2 * i] as f64, next[2 * i + 1] as f64);
            let n = ((vx.hypot(vy) * t.open_length_frames()).ceil() as usize).max(1);
            let mut sum = [0.0f64; 4];
            for k in 0..n {
                let time = t.open_frames + (k as f64 + 0.5) / n as f64 * t.open_length_frames();
                let sx = ((x as f64 + 0.5 + vx * time).floor() as i64).clamp(0, w - 1);
                let sy = ((y as f64 + 0.5 + vy * time).floor() as i64).clamp(0, h - 1);
                let j = (sy * w + sx) as usize * 4;
                (0..4).for_each(|c| sum[c] += frame.color[j + c] as f64 / n as f64);
            }
            out[i * 4..i * 4 + 4].copy_from_slice(&sum.map(|v| v as f32));
        }
    }
    out
}

/// The pinhole input, the single-direction blur, the fast path and the reference against a
/// ground truth: [`ImageError::rmse_matched`](crate::tools::metrics::ImageError::rmse_matched)
/// (energy matched, values clamped).
pub fn accuracy(
    gpu: &Gpu,
    frame: &Frame,
    camera: &Camera,
    ground_truth: &[f32],
    mut progress: impl FnMut(&str),
) -> GpuResult<Vec<MotionAccuracyRow>> {
    use crate::tools::metrics::compare_rgba;
    let mut rows = vec![MotionAccuracyRow {
        method: "pinhole input".into(),
        gpu_ms: None,
        error: compare_rgba(&frame.color, ground_truth),
    }];
    progress("single-direction blur");
    let plain = single_direction_blur(frame, camera);
    rows.push(MotionAccuracyRow {
        method: "single-direction blur (CPU)".into(),
        gpu_ms: None,
        error: compare_rgba(&plain, ground_truth),
    });
    for (name, mode) in [("fast", MotionBlurMode::Fast), ("reference", MotionBlurMode::Reference)] {
        progress(name);
        let mut camera = camera.clone();
        camera.motion.mode = mode;
        let p = plan(frame, &camera);
        let renderer = Renderer::new(gpu, &p)?;
        let out = renderer.render(frame, &p, false)?;
        rows.push(MotionAccuracyRow {
            method: format!("--motion-blur {name}"),
            gpu_ms: Some(motion_ms(&out.profile)),
            error: compare_rgba(&out.rgba, ground_truth),
        });
    }
    Ok(rows)
}

pub fn accuracy_markdown(device: &str, command: &str, rows: &[MotionAccuracyRow]) -> String {
    let mut out = format!("Device: {device}\n\nCommand: `{command}`\n\n");
    out +=
        "RMSE over RGB against the ground truth after scaling each image to its total energy, values clamped at 4.\n\n";
    out += "| image | GPU ms | RMSE | x pinhole | display RMSE | energy before scaling |\n| --- | --- | --- | --- | --- | --- |\n";
    let pinhole = rows.first().map_or(1.0, |r| r.error.rmse_matched);
    for r in rows {
        out += &format!(
            "| {} | {} | {:.4} | {:.2}x | {:.4} | {:+.3}% |\n",
            r.method,
            r.gpu_ms.map_or(String::new(), |ms| format!("{ms:.0}")),
            r.error.rmse_matched,
            r.error.rmse_matched / pinhole,
            r.error.rmse_display,
            100.0 * r.error.relative_energy_error
        );
    }
    out
}
