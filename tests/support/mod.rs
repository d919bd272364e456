//! Shared helpers for the GPU tests: a validated device, test cameras, measurements.
#![allow(dead_code)]

use realcam::gpu::{Gpu, GpuOptions, Profile};
use realcam::io::lens_file::LensFile;
use realcam::model::camera::{Camera, CameraRequest};
use realcam::model::frame::Frame;
use realcam::pipeline::planner::{plan, Plan};
use realcam::pipeline::render::Renderer;
use std::path::PathBuf;

/// The GPU with the Khronos validation layer and synchronization validation on. Tests fail if
/// the layer is missing: CI installs it (vulkan-validationlayers).
pub fn gpu() -> Gpu {
    gpu_with(false)
}

/// [`gpu`] that uses no subgroup operations even where the device has them: the shaders'
/// variants for devices without them run (GpuOptions::no_subgroup_ops).
pub fn gpu_without_subgroup_ops() -> Gpu {
    gpu_with(true)
}

fn gpu_with(no_subgroup_ops: bool) -> Gpu {
    let options = GpuOptions {
        validation: true,
        device: std::env::var("REALCAM_DEVICE").ok(),
        pipeline_cache_dir: Some(std::env::temp_dir().join("realcam-test-pipeline-cache")),
        max_memory_bytes: None,
        no_subgroup_ops,
    };
    Gpu::new(&options).unwrap_or_else(|e| panic!("opening the GPU with validation: {e}"))
}

/// No validation message of warning severity or above.
pub fn assert_validation_clean(gpu: &Gpu) {
    assert!(gpu.validation_enabled());
    let messages = gpu.validation_messages();
    assert!(messages.is_empty(), "{} validation messages:\n{}", messages.len(), messages.join("\n"));
}

/// A camera with only depth of field: exposure, vignetting and the film curve off, so pixel
/// values stay scene values. 9.6 mm wide sensor (pitch 0.0375 mm at 256 px).
pub fn dof_camera(focal_length_mm: f64, f_number: f64, focus_m: f64, blades: u32) -> Camera {
    let request = CameraRequest {
        sensor: Some("9.6x5.4".into()),
        blades: Some(blades),
        blade_rotation_deg: Some(0.0),
        force: true,
        ..CameraRequest::blur_only().with_lens(focal_length_mm, f_number, focus_m)
    };
    Camera::new(&LensFile::default_lens(), &request).expect("valid test camera")
}

/// Plan and render a frame; returns RGBA, the plan and the GPU profile. Checks validation.
pub fn render(gpu: &Gpu, frame: &Frame, camera: &Camera) -> (Vec<f32>, Plan, Profile) {
    let plan = plan(frame, camera);
    let (rgba, profile) = render_plan(gpu, frame, &plan);
    (rgba, plan, profile)
}

pub fn render_plan(gpu: &Gpu, frame: &Frame, plan: &Plan) -> (Vec<f32>, Profile) {
    let renderer = Renderer::new(gpu, plan).expect("pipelines");
    let out = renderer.render(frame, plan, false).expect("render");
    assert_validation_clean(gpu);
    (out.rgba, out.profile)
}

/// A committed test scene from testdata/ (made by `realcam synth`), loaded through the EXR reader.
pub fn testdata_frame(name: &str, camera: &Camera) -> Frame {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("testdata");
    let sources = realcam::io::PassSources {
        depth_path: Some(dir.join(format!("{name}_depth.exr"))),
        ..realcam::io::PassSources::new(dir.join(format!("{name}_color.exr")))
    };
    let passes = realcam::io::load_passes(&sources).unwrap_or_else(|e| panic!("{e}"));
    Frame::from_passes(passes, camera, realcam::io::DepthKind::Planar)
}

/// Sum of R+G+B over an RGBA image, in f64.
pub fn energy(rgba: &[f32]) -> f64 {
    rgba.chunks_exact(4).map(|p| p[0] as f64 + p[1] as f64 + p[2] as f64).sum()
}

/// Pixel (x, y) channel c of an RGBA image of width w.
pub fn at(rgba: &[f32], w: u32, x: u32, y: u32, c: usize) -> f32 {
    rgba[(y * w + x) as usize * 4 + c]
}

/// A camera for motion blur alone (no depth of field, exposure, vignetting or film): `fps`
/// frames per second, the shutter open `shutter_frames` of a frame, centred.
pub fn motion_camera(fps: f64, shutter_frames: f64) -> Camera {
    let request = CameraRequest {
        sensor: Some("9.6x5.4".into()),
        max_coc: realcam::model::camera::CocLimit::Px(0.0),
        force: true,
        fps: Some(fps),
        shutter_angle_deg: Some(360.0 * shutter_frames),
        ..CameraRequest::blur_only().with_lens(50.0, 2.0, 2.0)
    };
    Camera::new(&LensFile::default_lens(), &request).expect("valid motion camera")
}

/// A frame with a vertical bar (columns `x0..x1`, colour `bar`, depth `bar_m`) over a textured
/// background (depth `background_m`); the bar moves with `next_px` toward the next frame and
/// `prev_px` toward the previous one (px per frame, x right, y down), the background is still.
#[allow(clippy::too_many_arguments)]
pub fn moving_bar_frame(
    w: u32,
    h: u32,
    (x0, x1): (u32, u32),
    bar: [f32; 3],
    (bar_m, background_m): (f32, f32),
    next_px: [f32; 2],
    prev_px: Option<[f32; 2]>,
    background: impl Fn(u32, u32) -> [f32; 3],
) -> Frame {
    let (mut color, mut depth, mut next, mut prev) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            let on_bar = (x0..x1).contains(&x);
            let c = if on_bar { bar } else { background(x, y) };
            color.extend([c[0], c[1], c[2], 1.0]);
            depth.push(if on_bar { bar_m } else { background_m });
            let (n, p) =
                if on_bar { (next_px, prev_px.unwrap_or([-next_px[0], -next_px[1]])) } else { ([0.0; 2], [0.0; 2]) };
            next.extend(n);
            prev.extend(p);
        }
    }
    Frame::new(w, h, color, depth).with_velocity(next, prev_px.map(|_| prev))
}

/// A fresh directory for one test (`realcam-NAME-PID` under the system's temporary folder),
/// removed on drop.
pub struct TestDir(pub PathBuf);

impl TestDir {
    pub fn new(name: &str) -> TestDir {
        let path = std::env::temp_dir().join(format!("realcam-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).unwrap_or_else(|e| panic!("creating {}: {e}", path.display()));
        TestDir(path)
    }

    pub fn join(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
