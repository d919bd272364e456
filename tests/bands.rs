//! Banded rendering (issue 33): a frame rendered in bands, because the GPU memory it may use is
//! smaller than the frame needs, gives the same bits as the frame rendered whole, with every
//! effect on: motion blur, depth of field, a lens's distortion, coma and astigmatism, flare,
//! vignetting, grain and the film curve. Validation on (lavapipe in CI).

mod support;

use realcam::gpu::{Gpu, GpuOptions};
use realcam::io::lens_file::LensFile;
use realcam::model::camera::{Camera, CameraRequest, MotionBlurMode};
use realcam::model::frame::Frame;
use realcam::pipeline::bands::{apron_px, plan_bands, render_frame, BandError};
use realcam::pipeline::planner::{plan, plan_band};
use realcam::pipeline::render::Renderer;
use std::path::Path;
use support::assert_validation_clean;

/// A 256x480 frame: a checkered wall at 8 m, a striped card at 0.7 m on the left, a disc at
/// 1.2 m, the focus plane at 2 m in the middle, highlights of 40 to 4000 over all of them (flare
/// and bokeh sprites); velocities turning about (110, 90) and a card moving right.
fn busy_frame() -> Frame {
    let (w, h) = (256u32, 480u32);
    let mut color = Vec::with_capacity((w * h * 4) as usize);
    let mut depth = Vec::with_capacity((w * h) as usize);
    let mut next = Vec::with_capacity((w * h * 2) as usize);
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = (x as f32, y as f32);
            let (z, base): (f32, [f32; 3]) = if x < 70 {
                (0.7, if (x / 3) % 2 == 0 { [0.8, 0.5, 0.2] } else { [0.1, 0.1, 0.3] })
            } else if (fx - 230.0).hypot(fy - 60.0) < 35.0 {
                (1.2, [0.2, 0.7, 0.3])
            } else if (120..190).contains(&x) {
                (2.0, if (x / 2 + y / 2) % 2 == 0 { [0.9, 0.9, 0.9] } else { [0.05, 0.05, 0.05] })
            } else {
                (8.0, if (x / 8 + y / 8) % 2 == 0 { [0.4, 0.3, 0.2] } else { [0.2, 0.3, 0.4] })
            };
            let light = if x % 37 == 5 && y % 29 == 7 { 40.0 * (1.0 + ((x * 7 + y) % 100) as f32) } else { 0.0 };
            color.extend_from_slice(&[base[0] + light, base[1] + light * 0.8, base[2] + light * 0.6, 1.0]);
            depth.push(z);
            let v = if x < 70 { [12.0, 0.0] } else { [-(fy - 90.0) * 0.15, (fx - 110.0) * 0.15] };
            next.extend_from_slice(&v);
        }
    }
    let mut frame = Frame::new(w, h, color, depth).with_velocity(next, None);
    // The optical centre off the frame's middle, as for a data window inside a display window.
    frame.centre_px = [120.5, 250.0];
    frame
}

/// The lens of `lens_file` at `f_number`, focused at 2 m, with every effect on, a cat's eye and a
/// shutter of 180 degrees at 24 fps.
fn everything_camera(lens_file: &str, f_number: f64, motion_blur: MotionBlurMode) -> Camera {
    let lens = LensFile::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(lens_file)).expect("the lens file");
    let request = CameraRequest {
        f_number: Some(f_number),
        focus_distance_m: 2.0,
        grain: 0.05,
        seed: 7,
        fps: Some(24.0),
        shutter_angle_deg: Some(180.0),
        motion_blur,
        cats_eye: Some(0.4),
        flare_threshold: 2.0,
        ..CameraRequest::default()
    };
    Camera::new(&lens, &request).expect("camera")
}

/// The flare's place in the pass order: the passes before it are banded with aprons.
fn flare_index() -> usize {
    realcam::passes::PASS_ORDER.iter().position(|e| e.name == "flare").expect("a flare pass")
}

fn gpu_with_budget(max_memory_bytes: Option<u64>) -> Gpu {
    let options = GpuOptions {
        validation: true,
        device: std::env::var("REALCAM_DEVICE").ok(),
        pipeline_cache_dir: Some(std::env::temp_dir().join("realcam-test-pipeline-cache")),
        max_memory_bytes,
        no_subgroup_ops: false,
    };
    Gpu::new(&options).unwrap_or_else(|e| panic!("opening the GPU: {e}"))
}

/// The frame rendered by `camera` with at most `budget` bytes of GPU memory; the output and the
/// number of bands (0: whole).
fn render_with(frame: &Frame, camera: &Camera, budget: Option<u64>) -> (Vec<f32>, usize) {
    let gpu = gpu_with_budget(budget);
    let whole = plan(frame, camera);
    let renderer = Renderer::new(&gpu, &whole).expect("pipelines");
    let mut frame = frame.clone();
    let out = render_frame(&gpu, &renderer, &mut frame, &whole, &|band| plan_band(band, camera, &whole))
        .unwrap_or_else(|e| panic!("render: {e}"));
    assert_validation_clean(&gpu);
    (out.rendered.rgba, out.bands.map_or(0, |b| b.rows.len()))
}

/// The Distagon 21 mm's tables give its distortion; the Tessar's prescription and tables its
/// ghosts, astigmatism and coma.
#[test]
fn a_frame_rendered_in_bands_has_the_bits_of_the_frame_rendered_whole() {
    let distagon = ("lenses/zeiss-distagon-21-f2.8.toml", 2.8, &["distortion"][..]);
    let tessar = ("lenses/tessar-walch-lens.toml", 4.0, &["astigmatism", "coma"][..]);
    for (lens_file, f_number, lens_passes) in [distagon, tessar] {
        let camera = everything_camera(lens_file, f_number, MotionBlurMode::Fast);
        same_bits_whole_and_banded(&camera, &["motion_blur", "coc", "bokeh_tiled", "flare", "film"], lens_passes);
    }
}

/// The same with the reference methods of both blurs and a rolling shutter (its lines' open
/// times are the whole frame's).
#[test]
fn the_reference_methods_and_a_rolling_shutter_give_the_same_bits_in_bands() {
    let mut camera = everything_camera("lenses/zeiss-distagon-21-f2.8.toml", 2.8, MotionBlurMode::Reference);
    camera.bokeh = realcam::model::camera::BokehMode::Reference;
    camera.motion.timing.readout_frames = 0.3;
    same_bits_whole_and_banded(&camera, &["motion_blur_reference", "coc", "bokeh_gather", "flare", "film"], &[]);
}

fn same_bits_whole_and_banded(camera: &Camera, passes: &[&str], lens_passes: &[&str]) {
    let frame = busy_frame();
    let camera = camera.clone();
    let whole = plan(&frame, &camera);
    for pass in passes.iter().chain(lens_passes) {
        assert!(whole.runs(pass), "{pass} should run:\n{}", whole.explain());
    }
    let (expected, none) = render_with(&frame, &camera, None);
    assert_eq!(none, 0, "the whole frame fits the device");
    // A budget of 96 rows with the aprons of the passes' reach (those before the flare): five
    // bands, each computed from its rows and its aprons only.
    let per_px = realcam::pipeline::render::estimated_gpu_bytes_per_px(&whole);
    let apron = apron_px(&whole, 0..flare_index()).expect("no flare before the flare");
    let (banded, bands) = render_with(&frame, &camera, Some(per_px * 256 * (2 * apron + 96) as u64));
    assert_eq!(bands, 5);
    let differing = expected.iter().zip(&banded).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differing, 0, "{differing} of {} values differ from the whole frame's", expected.len());
}

#[test]
fn bands_cover_the_frame_on_whole_tiles_and_each_fits_the_budget() {
    let frame = busy_frame();
    let camera = everything_camera("lenses/zeiss-distagon-21-f2.8.toml", 2.8, MotionBlurMode::Fast);
    let whole = plan(&frame, &camera);
    let per_px = realcam::pipeline::render::estimated_gpu_bytes_per_px(&whole);
    let apron = apron_px(&whole, 0..flare_index()).expect("no flare before the flare");
    assert_eq!(apron % 16, 0);
    let budget = per_px * 256 * 400;
    let bands = plan_bands(256, 480, &whole, apron, budget, 16384).expect("bands").expect("banded");
    assert_eq!(bands.rows.first().map(|r| r.0), Some(0));
    assert_eq!(bands.rows.last().map(|r| r.1), Some(480));
    for pair in bands.rows.windows(2) {
        assert_eq!(pair[0].1, pair[1].0, "bands meet");
        assert_eq!(pair[1].0 % 16, 0, "a band starts on a tile row");
    }
    for &(start, end) in &bands.rows {
        let rendered = (end + apron).min(480) - start.saturating_sub(apron);
        assert!(per_px * 256 * rendered as u64 <= budget, "band {start}..{end} with its aprons fits");
    }
    // The whole frame fits a budget of its size: no bands. A budget that cannot hold one tile
    // row with its aprons is an error saying so.
    assert_eq!(plan_bands(256, 480, &whole, apron, per_px * 256 * 480, 16384), Ok(None));
    let too_small = plan_bands(256, 480, &whole, apron, per_px * 256 * 2 * apron as u64, 16384);
    assert_eq!(
        too_small,
        Err(BandError::ApronTooLarge {
            width: 256,
            apron_px: apron,
            bytes: per_px * 256 * (2 * apron + 16) as u64,
            budget: per_px * 256 * 2 * apron as u64
        })
    );
}

/// Walch's fitted ghosts (the Tessar's fits, of 1280x720 frames) of two lights of 1e9, drawn band
/// by band from the whole frame's lights: the bits of the whole frame's flare.
#[test]
fn fitted_ghosts_drawn_in_bands_have_the_bits_of_the_whole_frames() {
    let (w, h) = (1280u32, 720u32);
    let mut color: Vec<f32> = (0..w * h)
        .flat_map(|i| if (i % w / 16 + i / w / 16) % 2 == 0 { [0.1, 0.1, 0.1, 1.0] } else { [0.05; 4] })
        .collect();
    for (lx, ly) in [(300u32, 200u32), (900, 500)] {
        for y in ly - 1..=ly + 1 {
            for x in lx - 1..=lx + 1 {
                color[((y * w + x) * 4) as usize..][..3].copy_from_slice(&[1e9; 3]);
            }
        }
    }
    // Everything at the focus distance (the lens's longitudinal colour still defocuses red and
    // blue a little).
    let frame = Frame::new(w, h, color, vec![2.0; (w * h) as usize]);
    let lens = LensFile::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/flare/tessar-walch-fitted.toml"))
        .expect("the Tessar's fits");
    let request = CameraRequest { f_number: Some(2.8), focus_distance_m: 2.0, grain: 0.05, ..CameraRequest::default() };
    let camera = Camera::new(&lens, &request).expect("camera");
    let whole = plan(&frame, &camera);
    assert!(whole.runs("flare"), "{}", whole.explain());
    assert!(whole.explain().contains("fitted"), "{}", whole.explain());
    let (expected, _) = render_with(&frame, &camera, None);
    let per_px = realcam::pipeline::render::estimated_gpu_bytes_per_px(&whole);
    let apron = apron_px(&whole, 0..flare_index()).expect("no flare before the flare");
    let (banded, bands) = render_with(&frame, &camera, Some(per_px * w as u64 * (2 * apron + 200) as u64));
    assert_eq!(bands, 4);
    let differing = expected.iter().zip(&banded).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differing, 0, "{differing} of {} values differ from the whole frame's", expected.len());
    // The ghosts reach rows far from both lights: the flare is drawn across the bands.
    assert!(expected.iter().step_by(4).skip((650 * w) as usize).take(w as usize).any(|&r| r > 0.2));
}
