//! `realcam bench --sequence`: a frame sequence's throughput as one `realcam render --frames`
//! process (one device, one set of pipelines, reading and writing overlapped with the GPU work)
//! against one process per frame, on generated frames of the demo scene. Wall time of whole
//! processes, median of interleaved runs, with the GPU time per frame (timestamp queries, from
//! the sequence's `--trace` files) and the bare pass measured in the same run.

use crate::gpu::Gpu;
use crate::io::IoError;
use crate::tools::bench::{bare_pass_ms, median};
use crate::tools::synth::{write_scene, SynthScene};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The first frame's number.
const FIRST_FRAME: i64 = 1001;

/// Pixels the subject card moves per frame (at 640x360; scaled with the frame), so that every
/// frame differs.
const CARD_STEP_PX: u32 = 8;

#[derive(Clone, Debug)]
pub struct SequenceBenchOptions {
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    /// Interleaved timed runs of both (after one warm-up of each); the median is reported.
    pub runs: usize,
    /// The realcam executable that renders.
    pub realcam: PathBuf,
    /// More `render` flags for both (after the camera's `--fstop 2 --focus 2`), e.g. `--no-flare`.
    pub render_flags: Vec<String>,
    /// Where the frames and outputs go (a temporary folder).
    pub dir: PathBuf,
}

/// The measured throughput.
#[derive(Clone, Debug)]
pub struct SequenceBenchRow {
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    /// Median wall time of the whole sequence as one process, s.
    pub sequence_s: f64,
    /// Median wall time of the frames as one process each, s.
    pub processes_s: f64,
    /// Mean GPU time per frame in the sequence (every pass, upload and download), ms.
    pub gpu_ms_per_frame: f64,
    pub bare_ms: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum SequenceBenchError {
    #[error(transparent)]
    Io(#[from] IoError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error("running {command}: {reason}")]
    Run { command: String, reason: String },
    #[error("frame {frame}: the sequence's output differs from the single run's")]
    Differs { frame: i64 },
}

/// Frame `index` of the sequence: the demo scene scaled to `width x height`, its subject card
/// moved [`CARD_STEP_PX`] per frame to the right.
pub fn sequence_scene(width: u32, height: u32, index: u32) -> SynthScene {
    let demo = SynthScene::demo();
    let (sx, sy) = (f64::from(width) / f64::from(demo.width), f64::from(height) / f64::from(demo.height));
    let x = |v: u32| (f64::from(v) * sx).round() as u32;
    let y = |v: u32| (f64::from(v) * sy).round() as u32;
    let mut scene = demo.clone();
    scene.width = width;
    scene.height = height;
    for (i, plane) in scene.planes.iter_mut().enumerate() {
        // The third plane is the subject card (SynthScene::demo).
        let shift = if i == 2 { CARD_STEP_PX * index } else { 0 };
        (plane.x0, plane.x1) = (x(plane.x0 + shift), x(plane.x1 + shift));
        (plane.y0, plane.y1) = (y(plane.y0), y(plane.y1));
        plane.checker_px = x(plane.checker_px).max(1);
    }
    for light in &mut scene.highlights {
        (light.x, light.y) = (x(light.x), y(light.y));
    }
    scene
}

/// Runs `realcam args` and returns its wall time, s.
fn timed(realcam: &Path, args: &[String]) -> Result<f64, SequenceBenchError> {
    let command = format!("{} {}", realcam.display(), args.join(" "));
    let started = Instant::now();
    let out = Command::new(realcam)
        .args(args)
        .output()
        .map_err(|e| SequenceBenchError::Run { command: command.clone(), reason: e.to_string() })?;
    let wall_s = started.elapsed().as_secs_f64();
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        return Err(SequenceBenchError::Run { command, reason: format!("{}: {}", out.status, stderr.trim()) });
    }
    Ok(wall_s)
}

/// The sum of the `"dur"` values (µs) of a Chrome trace that `Profile::chrome_trace_json` wrote, ms.
fn trace_gpu_ms(json: &str) -> f64 {
    json.split("\"dur\":")
        .skip(1)
        .filter_map(|rest| rest.split(['}', ',']).next()?.trim().parse::<f64>().ok())
        .sum::<f64>()
        / 1e3
}

pub fn run(
    gpu: &Gpu,
    options: &SequenceBenchOptions,
    mut progress: impl FnMut(&str),
) -> Result<SequenceBenchRow, SequenceBenchError> {
    let (w, h, n) = (options.width, options.height, options.frames);
    let dir = &options.dir;
    progress("writing the frames");
    let frames: Vec<i64> = (0..n as i64).map(|i| FIRST_FRAME + i).collect();
    for (i, &frame) in frames.iter().enumerate() {
        write_scene(dir, &format!("f{frame}"), &sequence_scene(w, h, i as u32))?;
    }
    progress("the bare pass");
    let bare_ms = bare_pass_ms(gpu, w, h, options.runs)?;
    let path = |name: String| dir.join(name).to_string_lossy().into_owned();
    let mut camera: Vec<String> = ["--fstop", "2", "--focus", "2"].map(String::from).into();
    camera.extend(options.render_flags.iter().cloned());
    let mut sequence: Vec<String> = ["render", "--color"].map(String::from).into();
    sequence.extend([path("f####_color.exr".into()), "--depth".into(), path("f####_depth.exr".into())]);
    sequence.extend(["-o".into(), path("seq.####.exr".into()), "--trace".into(), path("seq.####.json".into())]);
    sequence.extend(["--frames".into(), format!("{}-{}", FIRST_FRAME, FIRST_FRAME + n as i64 - 1)]);
    sequence.extend(camera.iter().cloned());
    let single = |frame: i64| -> Vec<String> {
        let mut args: Vec<String> = vec!["render".into(), "--color".into(), path(format!("f{frame}_color.exr"))];
        args.extend([
            "--depth".into(),
            path(format!("f{frame}_depth.exr")),
            "-o".into(),
            path(format!("one.{frame}.exr")),
            // The same outputs as the sequence's frames (its traces give the GPU time).
            "--trace".into(),
            path(format!("one.{frame}.json")),
        ]);
        args.extend(camera.iter().cloned());
        args
    };
    let processes = || -> Result<f64, SequenceBenchError> {
        frames.iter().map(|&frame| timed(&options.realcam, &single(frame))).sum()
    };
    let (mut sequence_s, mut processes_s) = (Vec::new(), Vec::new());
    // A warm-up of each (the pipeline cache, the file cache), then interleaved timed runs.
    for run in 0..=options.runs.max(1) {
        progress(&format!("run {run}: one sequence"));
        let s = timed(&options.realcam, &sequence)?;
        progress(&format!("run {run}: {n} processes"));
        let p = processes()?;
        if run > 0 {
            sequence_s.push(s);
            processes_s.push(p);
        }
    }
    let mut gpu_ms = 0.0;
    for &frame in &frames {
        let read = |name: String| {
            let path = dir.join(name);
            std::fs::read(&path).map_err(|source| IoError::Read { what: "bench output".into(), path, source })
        };
        if read(format!("seq.{frame}.exr"))? != read(format!("one.{frame}.exr"))? {
            return Err(SequenceBenchError::Differs { frame });
        }
        gpu_ms += trace_gpu_ms(&String::from_utf8_lossy(&read(format!("seq.{frame}.json"))?));
    }
    Ok(SequenceBenchRow {
        width: w,
        height: h,
        frames: n,
        sequence_s: median(sequence_s),
        processes_s: median(processes_s),
        gpu_ms_per_frame: gpu_ms / n as f64,
        bare_ms,
    })
}

/// The result as a Markdown table, with the device.
pub fn markdown(device: &str, command: &str, row: &SequenceBenchRow) -> String {
    let mut out = format!("Device: {device}\n\nCommand: `{command}`\n\n");
    out += "Whole processes' wall time (median of interleaved runs after a warm-up of each): the sequence as one \
            `realcam render --frames` against one `realcam render` per frame, the same bytes; GPU ms per frame from \
            the sequence's timestamp queries (every pass, upload and download), also as a multiple of the bare pass \
            (read the frame, write it) measured in the same run.\n\n";
    out += "| frames | resolution | one sequence s | frames/s | separate processes s | frames/s | speed-up | GPU ms/frame | x bare | bare pass ms |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    let fps = |s: f64| row.frames as f64 / s;
    out += &format!(
        "| {} | {}x{} | {:.2} | {:.3} | {:.2} | {:.3} | {:.2}x | {:.1} | {:.0}x | {:.2} |\n",
        row.frames,
        row.width,
        row.height,
        row.sequence_s,
        fps(row.sequence_s),
        row.processes_s,
        fps(row.processes_s),
        row.processes_s / row.sequence_s,
        row.gpu_ms_per_frame,
        row.gpu_ms_per_frame / row.bare_ms,
        row.bare_ms
    );
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_trace_sum_is_the_profiles_total() {
        let mut profile = crate::gpu::Profile::default();
        for (name, gpu_ms) in [("upload", 0.25), ("coc", 1.5), ("film", 2.125)] {
            profile.passes.push(crate::gpu::PassTiming { name: name.into(), start_ms: 0.0, gpu_ms });
        }
        let ms = super::trace_gpu_ms(&profile.chrome_trace_json());
        assert!((ms - 3.875).abs() < 1e-6, "{ms}");
    }

    #[test]
    fn frames_move_the_card_and_scale_the_demo() {
        let (a, b) = (super::sequence_scene(1280, 720, 0), super::sequence_scene(1280, 720, 3));
        assert_eq!((a.width, a.height), (1280, 720));
        // The card: 250..430 at 640 px wide, 2x here, 3 frames of 8 px (16 px at this width) later.
        assert_eq!((a.planes[2].x0, a.planes[2].x1), (500, 860));
        assert_eq!((b.planes[2].x0, b.planes[2].x1), (548, 908));
        assert_eq!(a.planes[0], b.planes[0]);
    }
}
