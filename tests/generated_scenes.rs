//! The depth of field on scenes nobody tuned for: 20 random layered scenes
//! (src/tools/layered_scene.rs: cards, discs, masked cards and highlights at random depths,
//! ray-traced through the renderers' thin lens), their colour and depth passes through
//! `--bokeh reference` and the default tiled path of `--lens ideal`, each against the scene's
//! exact defocused image: the share of 16-px tiles whose mean luminance is off by more than 5%
//! (src/tools/metrics.rs tile_luminance), the worst tile, FLIP, and the alpha.
//!
//! The motion blur the same way (issue 30): the same 20 scenes set in motion
//! (`LayeredScene::random_moving`: each layer still or moving 2..40 px per frame, a centred
//! shutter of 90..360 degrees), their colour, one-sample depth and one-sample vectors through
//! `--motion-blur fast` and `reference`, each against the exact motion-blurred image (pinhole,
//! pixel area x open time), by the RMSE of `realcam accuracy --motion-blur` (energy matched,
//! values clamped at 4); and a turning wheel, whose arcs the two-segment path follows.
//!
//! `cargo test --test generated_scenes -- --nocapture` prints the per-seed tables; the images of
//! every seed (input | truth | tiled | reference, sRGB) are written to
//! `target/tmp/generated_scenes/seed_NN.png` (`motion_NN.png`: input | truth | fast |
//! reference).

mod support;

use realcam::io::lens_file::LensFile;
use realcam::model::camera::{BokehMode, Camera, CameraRequest, CocLimit, MotionBlurMode};
use realcam::model::frame::Frame;
use realcam::tools::layered_scene::{Layer, LayerMotion, LayeredScene, Mask, MotionPasses, Shape, Texture};
use realcam::tools::metrics::{compare_rgba, local_fidelity, LocalFidelity};
use support::*;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 96;
const SEEDS: u64 = 20;

/// What holds today for `--bokeh reference` against the exact image (lavapipe, 2026-11-27,
/// docs/measurements.md): 0.8% of the tiles off by more than 5% on average over the 20 seeds,
/// 3.3% (2 of 60 tiles) on the worst; the bounds leave one tile of room.
const REFERENCE_MEAN_BOUND: f64 = 0.02;
const REFERENCE_MAX_BOUND: f64 = 0.05;
/// What holds today for the default tiled path: 1.4% on average, 11.7% on the worst seed (17:
/// f/1.4, a card with round holes 21 px out of focus over a background 17 px out of focus: rings
/// at the holes' rims), mean FLIP 0.061 (the reference's 0.044); 16 of 20 seeds within the 3%
/// goal (one 16-px tile of 60 is 1.7%). Since the pixels too sharp for their tile's level take
/// the exact gather (dof_tiles.glsl `exact_radius_px`): before it 1.7%, 11.7%, FLIP 0.065, 14
/// of 20 seeds (seed 6's checkered disc drawn as blocks). Since the level gather fills the background a pixel's
/// own surface hides, as the exact gather does (issue 29; scene A f/2: 3.4% -> 1.7% of the
/// tiles off its reference): before it 2.5%, 18.3% and FLIP 0.069; before the nearest-CoC
/// pyramid 2.1%, 11.7% and 0.082; before the alpha and tile-radius fixes 9.2%, 40% and 0.123.
/// Issue 29's goal is 3% on every seed: set both shares to 0.03 when the tiled path gets there.
const TILED_MEAN_BOUND: f64 = 0.02;
const TILED_MAX_BOUND: f64 = 0.15;
const TILED_MEAN_FLIP_BOUND: f64 = 0.066;

/// realcam's camera for a generated scene: `--lens ideal` with the scene's lens, blades and
/// sensor; the depth of field alone (no exposure, vignetting, film curve or flare); no CoC clamp
/// within the scenes' range.
fn camera(scene: &LayeredScene, bokeh: BokehMode) -> Camera {
    let c = &scene.camera;
    let request = CameraRequest {
        sensor: Some(format!("{}x{}", c.sensor_width_mm, c.sensor_height_mm())),
        blades: Some(c.blades),
        blade_rotation_deg: Some(c.rotation_deg),
        max_coc: CocLimit::Px(2.0 * (WIDTH as f64)),
        force: true,
        bokeh,
        ..CameraRequest::blur_only().with_lens(c.focal_length_mm, c.f_number, c.focus_m)
    };
    let lens = LensFile::built_in("ideal").expect("the built-in ideal lens");
    Camera::new(&lens, &request).expect("valid generated camera")
}

/// sRGB 8-bit display values of linear RGBA, as an RGB image.
fn srgb(rgba: &[f32]) -> Vec<f32> {
    rgba.chunks_exact(4)
        .flat_map(|p| {
            [p[0], p[1], p[2]].map(|v| {
                let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
                if v <= 0.0031308 {
                    12.92 * v
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                }
            })
        })
        .collect()
}

/// input | truth | tiled | reference (or fast | reference), side by side with 4 px gaps,
/// written as a PNG.
fn write_strip(path: &std::path::Path, (w, h): (u32, u32), [input, truth, tiled, reference]: [&[f32]; 4]) {
    let (w, h) = (w as usize, h as usize);
    let images = [srgb(input), srgb(truth), srgb(tiled), srgb(reference)];
    let gap = 4;
    let sw = 4 * w + 3 * gap;
    let mut data = vec![1.0f32; sw * h * 3];
    for (k, img) in images.iter().enumerate() {
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    data[(y * sw + k * (w + gap) + x) * 3 + c] = img[(y * w + x) * 3 + c];
                }
            }
        }
    }
    let image = realcam::io::Image { width: sw as u32, height: h as u32, channels: 3, data };
    realcam::io::png::write_png(path, &image).expect("writing the PNG");
}

struct Row {
    seed: u64,
    scene: String,
    input: LocalFidelity,
    reference: LocalFidelity,
    tiled: LocalFidelity,
}

fn cell(f: &LocalFidelity) -> String {
    let worst =
        f.tiles.worst.map_or(String::new(), |w| format!("{:+.3} @({},{})", w.relative_error, w.tile.0, w.tile.1));
    format!("{:5.1}% {:>16} FLIP {:.4}", 100.0 * f.tiles.share_off(), worst, f.flip_mean)
}

#[test]
fn generated_scenes_tiled_and_reference_against_the_exact_image() {
    let start = std::time::Instant::now();
    let gpu = gpu();
    let out_dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("generated_scenes");
    std::fs::create_dir_all(&out_dir).unwrap();
    let (mut trace_s, mut gpu_s) = (0.0, 0.0);
    let mut rows = Vec::new();
    for seed in 0..SEEDS {
        let t = std::time::Instant::now();
        let scene = LayeredScene::random(seed, WIDTH, HEIGHT);
        let passes = scene.render();
        trace_s += t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let frame = Frame::new(WIDTH, HEIGHT, passes.color.clone(), passes.depth_m.clone());
        let (reference, _, _) = render(&gpu, &frame, &camera(&scene, BokehMode::Reference));
        let (tiled, _, _) = render(&gpu, &frame, &camera(&scene, BokehMode::Tiled));
        gpu_s += t.elapsed().as_secs_f64();
        let judge = |rgba: &[f32]| local_fidelity(rgba, &passes.truth, &frame.color, WIDTH, HEIGHT);
        let images = [&passes.color[..], &passes.truth, &tiled, &reference];
        write_strip(&out_dir.join(format!("seed_{seed:02}.png")), (WIDTH, HEIGHT), images);
        let c = &scene.camera;
        let cocs: Vec<f64> = scene.layers.iter().map(|l| c.coc_px(l.depth_m)).collect();
        let max_coc = cocs.iter().fold(c.coc_px(1e10).abs(), |a, b| a.max(b.abs()));
        rows.push(Row {
            seed,
            scene: format!(
                "f/{} S {:.2} m, {} blades, {} layers, max CoC {:.0} px",
                c.f_number,
                c.focus_m,
                c.blades,
                scene.layers.len(),
                max_coc
            ),
            input: judge(&frame.color),
            reference: judge(&reference),
            tiled: judge(&tiled),
        });
    }
    println!(
        "\n{WIDTH}x{HEIGHT} px, {} tiles of 16 px; tiles off the exact image by > 5% (|mean - truth| / max(truth, 0.02)), the worst tile's \
         relative error @(column, row), mean FLIP:",
        WIDTH.div_ceil(16) * HEIGHT.div_ceil(16)
    );
    println!("| seed | scene | pinhole input | reference | tiled | tiled alpha min / holes |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for r in &rows {
        println!(
            "| {} | {} | {} | {} | {} | {:.3} / {} |",
            r.seed,
            r.scene,
            cell(&r.input),
            cell(&r.reference),
            cell(&r.tiled),
            r.tiled.alpha.min,
            r.tiled.alpha.holes
        );
    }
    let mean = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).sum::<f64>() / rows.len() as f64;
    let max = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).fold(0.0, f64::max);
    let (ref_mean, ref_max) = (mean(&|r| r.reference.tiles.share_off()), max(&|r| r.reference.tiles.share_off()));
    let (tiled_mean, tiled_max) = (mean(&|r| r.tiled.tiles.share_off()), max(&|r| r.tiled.tiles.share_off()));
    println!(
        "mean (max) share of tiles off: input {:.1}%, reference {:.1}% ({:.1}%), tiled {:.1}% ({:.1}%); mean FLIP reference {:.4}, tiled {:.4}",
        100.0 * mean(&|r| r.input.tiles.share_off()),
        100.0 * ref_mean,
        100.0 * ref_max,
        100.0 * tiled_mean,
        100.0 * tiled_max,
        mean(&|r| r.reference.flip_mean),
        mean(&|r| r.tiled.flip_mean)
    );
    println!(
        "ray tracing {trace_s:.1} s, GPU {gpu_s:.1} s, total {:.1} s; images in {}",
        start.elapsed().as_secs_f64(),
        out_dir.display()
    );
    // The reference as it is today (measured on lavapipe: docs/measurements.md).
    assert!(ref_mean <= REFERENCE_MEAN_BOUND, "reference: {:.1}% of the tiles off on average", 100.0 * ref_mean);
    assert!(ref_max <= REFERENCE_MAX_BOUND, "reference: up to {:.1}% of the tiles off", 100.0 * ref_max);
    // The tiled path as it is today. Issue 29's goal: within 3% of the tiles on every seed;
    // tighten the worst seed's bound to 0.03 when it gets there.
    assert!(tiled_mean <= TILED_MEAN_BOUND, "tiled: {:.1}% of the tiles off on average", 100.0 * tiled_mean);
    assert!(tiled_max <= TILED_MAX_BOUND, "tiled: up to {:.1}% of the tiles off", 100.0 * tiled_max);
    let tiled_flip = mean(&|r| r.tiled.flip_mean);
    assert!(tiled_flip <= TILED_MEAN_FLIP_BOUND, "tiled: mean FLIP {tiled_flip:.4}");
    // Every generated scene is opaque: so is the tiled path's output (issue 29, alpha).
    for r in &rows {
        assert!(r.tiled.alpha.min >= 0.999, "seed {}: tiled alpha falls to {}", r.seed, r.tiled.alpha.min);
    }
}

/// realcam's camera for a moving scene: the motion blur alone (no depth of field, exposure,
/// vignetting, film or flare), the scene's centred box shutter at 24 fps, no clamp on the blur
/// within the scenes' range, by `mode`.
fn motion_camera(scene: &LayeredScene, mode: MotionBlurMode) -> Camera {
    let [open, close] = scene.shutter_frames;
    let request = CameraRequest {
        sensor: Some(format!("{}x{}", scene.camera.sensor_width_mm, scene.camera.sensor_height_mm())),
        max_coc: CocLimit::Px(0.0),
        force: true,
        fps: Some(24.0),
        shutter_angle_deg: Some(360.0 * (close - open)),
        max_blur_px: 1000.0,
        ..CameraRequest::blur_only().with_lens(50.0, 2.0, 2.0)
    };
    let mut camera = Camera::new(&LensFile::default_lens(), &request).expect("valid motion camera");
    camera.motion.mode = mode;
    let t = &camera.motion.timing;
    assert!((t.open_frames - open).abs() < 1e-9 && (t.close_frames - close).abs() < 1e-9, "{t:?}");
    camera
}

/// The frame a renderer would hand over: the colour, depth and both vectors of `passes`.
fn motion_frame(passes: &MotionPasses) -> Frame {
    Frame::new(passes.width, passes.height, passes.color.clone(), passes.depth_m.clone())
        .with_velocity(passes.velocity_next_px.clone(), Some(passes.velocity_prev_px.clone()))
}

/// The goal (issue 30): on every generated scene the motion blur's RMSE against the
/// exact image at most half the unblurred input's.
const MOTION_GOAL_RATIO: f64 = 0.5;
/// What holds today (lavapipe, 2026-11-28, docs/measurements.md): the fast path's ratio 0.46 on
/// average, 0.84 on the worst seed (8), above the goal on 4 of the 20 seeds (2, 6, 8, 19); the
/// reference's 0.39 and 0.96 (8), above on the same 4 (sub-pixel highlights that no pixel centre
/// hits, objects entering from beyond the frame). The bounds leave about 0.05 of room. Tighten each per-seed bound to
/// MOTION_GOAL_RATIO when it holds.
const FAST_MEAN_RATIO_BOUND: f64 = 0.5;
const FAST_MAX_RATIO_BOUND: f64 = 0.9;
const REFERENCE_MEAN_RATIO_BOUND: f64 = 0.45;
const REFERENCE_MAX_RATIO_BOUND: f64 = 1.0;
/// The turning wheel's two-segment fast blur against the input's RMSE (today 0.49; the issue's
/// goal).
const WHEEL_RATIO_BOUND: f64 = 0.5;

#[test]
fn generated_moving_scenes_fast_and_reference_against_the_exact_motion_blur() {
    let start = std::time::Instant::now();
    let gpu = gpu();
    let out_dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("generated_scenes");
    std::fs::create_dir_all(&out_dir).unwrap();
    let (mut trace_s, mut gpu_s) = (0.0, 0.0);
    println!("\n{WIDTH}x{HEIGHT} px; RMSE against the exact motion blur (energy matched, clamped at 4); ratio to the input's:");
    println!("| seed | shutter | layers moving, fastest | input | fast | ratio | reference | ratio |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    let mut ratios = Vec::new();
    for seed in 0..SEEDS {
        let t = std::time::Instant::now();
        let scene = LayeredScene::random_moving(seed, WIDTH, HEIGHT);
        let passes = scene.render_motion();
        trace_s += t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let frame = motion_frame(&passes);
        let (fast, _, _) = render(&gpu, &frame, &motion_camera(&scene, MotionBlurMode::Fast));
        let (reference, _, _) = render(&gpu, &frame, &motion_camera(&scene, MotionBlurMode::Reference));
        gpu_s += t.elapsed().as_secs_f64();
        let images = [&passes.color[..], &passes.truth, &fast, &reference];
        write_strip(&out_dir.join(format!("motion_{seed:02}.png")), (WIDTH, HEIGHT), images);
        let rmse = |rgba: &[f32]| compare_rgba(rgba, &passes.truth).rmse_matched;
        let (input, fast, reference) = (rmse(&passes.color), rmse(&fast), rmse(&reference));
        let speeds: Vec<f64> = scene
            .layers
            .iter()
            .map(|l| {
                l.motion.velocity_m_per_frame[0].hypot(l.motion.velocity_m_per_frame[1]) / scene.m_per_px(l.depth_m)
            })
            .collect();
        let [open, close] = scene.shutter_frames;
        println!(
            "| {seed} | {:.0} deg | {} of {}, {:.0} px/frame | {input:.4} | {fast:.4} | {:.2} | {reference:.4} | {:.2} |",
            360.0 * (close - open),
            speeds.iter().filter(|&&v| v > 0.0).count(),
            speeds.len(),
            speeds.iter().fold(0.0f64, |a, &b| a.max(b)),
            fast / input,
            reference / input
        );
        ratios.push((seed, fast / input, reference / input));
    }
    let mean = |k: usize| ratios.iter().map(|r| [r.1, r.2][k]).sum::<f64>() / ratios.len() as f64;
    let max = |k: usize| ratios.iter().map(|r| [r.1, r.2][k]).fold(0.0, f64::max);
    let missing =
        |k: usize| ratios.iter().filter(|r| [r.1, r.2][k] > MOTION_GOAL_RATIO).map(|r| r.0).collect::<Vec<_>>();
    println!(
        "ratio to the input's RMSE: fast mean {:.2}, worst {:.2} (above {MOTION_GOAL_RATIO} on seeds {:?}); reference mean {:.2}, worst {:.2} (above on {:?})",
        mean(0),
        max(0),
        missing(0),
        mean(1),
        max(1),
        missing(1)
    );
    println!(
        "ray tracing {trace_s:.1} s, GPU {gpu_s:.1} s, total {:.1} s; images in {}",
        start.elapsed().as_secs_f64(),
        out_dir.display()
    );
    // Better than doing nothing on every seed, by the margins that hold today; the goal (0.5 on
    // every seed) is printed above and not yet asserted.
    assert!(mean(0) <= FAST_MEAN_RATIO_BOUND, "fast: mean ratio {:.2}", mean(0));
    assert!(max(0) <= FAST_MAX_RATIO_BOUND, "fast: worst ratio {:.2}", max(0));
    assert!(mean(1) <= REFERENCE_MEAN_RATIO_BOUND, "reference: mean ratio {:.2}", mean(1));
    assert!(max(1) <= REFERENCE_MAX_RATIO_BOUND, "reference: worst ratio {:.2}", max(1));
}

#[test]
fn a_turning_wheel_blurs_along_its_arcs_with_both_vectors() {
    // Issue 30 item 3: a checkered wheel of radius 36 px turning 30 degrees per frame about its
    // still centre, a shutter of one frame centred: its points sweep arcs of 30 degrees (18.8 px
    // at the rim). The renderer's vectors are the chords to the next and previous frame; the two
    // segments (next for t > 0, previous for t < 0) bend toward the centre as the arc does, a
    // single straight line (previous = -next, what a pass with one vector gives) leaves the arc
    // by up to 2 r (1 - cos 30 deg) / 2 = 4.8 px at the rim by the shutter's ends. Against the
    // exact image the reference must be closer with the two segments.
    let gpu = gpu();
    let out_dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("generated_scenes");
    std::fs::create_dir_all(&out_dir).unwrap();
    let scene = LayeredScene::turning_wheel(WIDTH, HEIGHT, 30f64.to_radians(), 1.0);
    let passes = scene.render_motion();
    let bent = motion_frame(&passes);
    let straight = Frame::new(WIDTH, HEIGHT, passes.color.clone(), passes.depth_m.clone())
        .with_velocity(passes.velocity_next_px.clone(), None);
    let rmse = |rgba: &[f32]| compare_rgba(rgba, &passes.truth).rmse_matched;
    let input = rmse(&passes.color);
    println!("\nturning wheel, 30 deg/frame, 360 deg shutter: RMSE input {input:.4}");
    for mode in [MotionBlurMode::Fast, MotionBlurMode::Reference] {
        let camera = motion_camera(&scene, mode);
        let (two, _, _) = render(&gpu, &bent, &camera);
        let (one, _, _) = render(&gpu, &straight, &camera);
        // truth | one straight line | two segments | input.
        let images = [&passes.truth[..], &one, &two, &passes.color];
        write_strip(&out_dir.join(format!("wheel_{mode:?}.png")), (WIDTH, HEIGHT), images);
        let (two, one) = (rmse(&two), rmse(&one));
        println!(
            "{mode:?}: two segments {two:.4} ({:.2} of the input's), one line {one:.4} ({:.2})",
            two / input,
            one / input
        );
        // The reference follows the path model exactly: the arcs must show (today 0.83x the
        // straight line's error). The fast path's lines are the neighbourhood's and the pixel's
        // own next and previous directions, and on a turning field the sources on a pixel's arc lie
        // on neither: it gains nothing from the bend (today 1.04x the straight line's error; the
        // gap is in docs/measurements.md); asserted not to lose more than that, and to halve the
        // input's error.
        let (gain_bound, input_bound) = match mode {
            MotionBlurMode::Reference => (0.9, 0.4),
            _ => (1.1, WHEEL_RATIO_BOUND),
        };
        assert!(two <= gain_bound * one, "{mode:?}: two segments {two:.4}, one straight line {one:.4}");
        assert!(two <= input_bound * input, "{mode:?}: two segments {two:.4}, input {input:.4}");
    }
}

/// Each 16-px tile's mean luminance (Rec.709) of an RGBA image.
fn tile_means(rgba: &[f32], w: u32, h: u32) -> Vec<f64> {
    let (tw, th) = (w / 16, h / 16);
    let mut means = vec![0.0f64; (tw * th) as usize];
    for y in 0..th * 16 {
        for x in 0..tw * 16 {
            let p = &rgba[((y * w + x) * 4) as usize..][..3];
            let luminance = 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
            means[((y / 16) * tw + x / 16) as usize] += luminance / 256.0;
        }
    }
    means
}

#[test]
fn a_rack_focus_changes_every_tile_smoothly_from_frame_to_frame() {
    // Issue 31 item 5: generated scene 3 at 256x160, f/2.8, focus from 1.5 m to 6 m over 24
    // frames (docs/measurements.md, "A rack focus, frame to frame"). A tile's jerk: its mean's
    // largest second difference over the frames, relative to its mean (floor 0.02). The
    // reference measures 0.77% on its worst tile. The tiled path measured 4.2% when a tile's
    // nearly sharp pixels switched from the exact gather to the pyramid's level within half a
    // pixel of CoC radius (one frame of the rack); blended over 1.5 px it measures 2.2%. What
    // is left is a tile changing pyramid level (no blend between two levels).
    let (w, h, frames) = (256u32, 160u32, 24usize);
    let gpu = gpu();
    let mut scene = LayeredScene::random(3, w, h);
    scene.truth_spp = 1; // only the passes are used
    let passes = scene.render();
    let frame = Frame::new(w, h, passes.color.clone(), passes.depth_m.clone());
    let c = scene.camera.clone();
    let series: Vec<[Vec<f64>; 2]> = (0..frames)
        .map(|k| {
            let focus_m = 1.5 + 4.5 * k as f64 / (frames - 1) as f64;
            [BokehMode::Tiled, BokehMode::Reference].map(|bokeh| {
                let request = CameraRequest {
                    sensor: Some(format!("{}x{}", c.sensor_width_mm, c.sensor_height_mm())),
                    blades: Some(6),
                    blade_rotation_deg: Some(c.rotation_deg),
                    max_coc: CocLimit::Px(2.0 * w as f64),
                    force: true,
                    bokeh,
                    ..CameraRequest::blur_only().with_lens(c.focal_length_mm, 2.8, focus_m)
                };
                let camera = Camera::new(&LensFile::built_in("ideal").unwrap(), &request).unwrap();
                tile_means(&render(&gpu, &frame, &camera).0, w, h)
            })
        })
        .collect();
    let worst_jerk = |which: usize| {
        let tiles = series[0][which].len();
        (0..tiles)
            .map(|t| {
                let m: Vec<f64> = series.iter().map(|s| s[which][t]).collect();
                let mean = (m.iter().sum::<f64>() / m.len() as f64).max(0.02);
                m.windows(3).map(|v| (v[2] - 2.0 * v[1] + v[0]).abs()).fold(0.0, f64::max) / mean
            })
            .fold(0.0, f64::max)
    };
    let (tiled, reference) = (worst_jerk(0), worst_jerk(1));
    println!("worst tile's jerk over the rack focus: tiled {:.2}%, reference {:.2}%", 100.0 * tiled, 100.0 * reference);
    assert!(reference < 0.01, "reference: {:.2}%", 100.0 * reference);
    assert!(tiled < 0.03, "tiled: {:.2}%", 100.0 * tiled);
}

#[test]
fn a_static_highlight_before_a_fast_mover_stays_sharp_against_the_exact_blur() {
    // Issue 30's hidden scene, generated: a textured ball (a disc of 30 px radius at 5 m) moving
    // left 93 px per frame behind a still, very bright 3x3-px highlight (50, at 3 m, placed off
    // the pixel grid so that its fringe pixels mix it with the ball in colour while their depth
    // and vectors are the ball's or the highlight's, one sample each), before a still checkered
    // wall; 24 fps, 180-degree shutter. Against the exact image (pixel area x open time), the
    // fast path's RMSE must be at most half the unblurred input's (the goal for its
    // hidden scene, where realcam measured 1.6x the input's before the edge resolve moved the
    // fringe's light with its own layer).
    let (w, h) = (256u32, 144u32);
    let gpu = gpu();
    let mut scene = LayeredScene::random(0, w, h);
    let (ball_m, light_m, wall_m) = (5.0, 3.0, 10.0);
    let px = |depth_m: f64| scene.m_per_px(depth_m);
    let (ball_px, light_px) = (px(ball_m), px(light_m));
    scene.layers = vec![
        Layer {
            depth_m: light_m,
            shape: Shape::Rect { x0: 0.3 * light_px, y0: -1.6 * light_px, x1: 3.3 * light_px, y1: 1.4 * light_px },
            mask: Mask::Opaque,
            texture: Texture::Flat([50.0, 50.0, 50.0]),
            motion: LayerMotion::STILL,
        },
        Layer {
            depth_m: ball_m,
            shape: Shape::Disc { cx: 20.0 * ball_px, cy: 0.0, r: 30.0 * ball_px },
            mask: Mask::Opaque,
            texture: Texture::Stripes { period: 9.0 * ball_px, a: [0.8, 0.3, 0.2], b: [0.2, 0.1, 0.05] },
            motion: LayerMotion { velocity_m_per_frame: [-93.0 * ball_px, 0.0], ..LayerMotion::STILL },
        },
        Layer {
            depth_m: wall_m,
            shape: Shape::Everywhere,
            mask: Mask::Opaque,
            texture: Texture::Checker { cell: 8.0 * px(wall_m), a: [0.3, 0.35, 0.3], b: [0.15, 0.15, 0.2] },
            motion: LayerMotion::STILL,
        },
    ];
    scene.shutter_frames = [-0.25, 0.25];
    scene.truth_spp = 256;
    let passes = scene.render_motion();
    let frame = motion_frame(&passes);
    let rmse = |rgba: &[f32]| compare_rgba(rgba, &passes.truth).rmse_matched;
    let input = rmse(&passes.color);
    let out_dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("generated_scenes");
    std::fs::create_dir_all(&out_dir).unwrap();
    let mut outputs = Vec::new();
    for mode in [MotionBlurMode::Fast, MotionBlurMode::Reference] {
        let (out, _, _) = render(&gpu, &frame, &motion_camera(&scene, mode));
        println!("{mode:?}: RMSE {:.4}, {:.2} of the input's {input:.4}", rmse(&out), rmse(&out) / input);
        outputs.push(out);
    }
    let images = [&passes.color[..], &passes.truth, &outputs[0], &outputs[1]];
    write_strip(&out_dir.join("highlight_before_mover.png"), (w, h), images);
    for (out, name) in outputs.iter().zip(["fast", "reference"]) {
        assert!(rmse(out) <= 0.5 * input, "{name}: RMSE {:.4} against the input's {input:.4}", rmse(out));
    }
}
