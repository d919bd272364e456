//! Every GPU pass against its CPU twin on tiny images (the twins are the test oracles).

mod support;

use realcam::model::camera::FilmMode;
use realcam::model::camera::{BokehMode, Camera};
use realcam::model::frame::Frame;
use realcam::optics::distortion::{DistortionTables, HeightTable};
use realcam::optics::film::FilmCurve;
use realcam::passes::dof::{bokeh_gather, coc};
use realcam::passes::lens::vignette;
use realcam::passes::{film, PASS_ORDER};
use realcam::pipeline::planner;
use realcam::pipeline::render::Renderer;
use std::collections::BTreeSet;
use support::*;

/// A small deterministic frame with varied depths (0.6 m .. 20 m and sky), colors and a few
/// strong highlights.
fn busy_frame(w: u32, h: u32) -> Frame {
    let hash = |i: u32| {
        let mut x = i.wrapping_mul(0x9E37_79B9) ^ 0x85EB_CA6B;
        x ^= x >> 15;
        x = x.wrapping_mul(0x2C1B_3C6D);
        x ^= x >> 12;
        (x & 0xFFFF) as f32 / 65535.0
    };
    let mut color = Vec::new();
    let mut depth = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let band = (x * 5 / w) as usize;
            depth.push([0.6, 1.4, 2.0, 5.0, 1.0e10][band] * (1.0 + 0.05 * hash(i + 7)));
            let boost = if hash(i + 99) > 0.98 { 200.0 } else { 1.0 };
            color.extend([hash(i) * boost, hash(i + 1) * boost, hash(i + 2) * boost, 1.0]);
        }
    }
    Frame::new(w, h, color, depth)
}

/// Depth bands across the frame: in focus (copy tiles), a small CoC (exact tiles), a large
/// CoC (half resolution, with sprites from the highlights), in front of and behind the focus.
fn banded_frame(w: u32, h: u32) -> Frame {
    let mut frame = busy_frame(w, h);
    for y in 0..h {
        for x in 0..w {
            let depth = match x * 10 / w {
                0..=3 => 2.0,
                4 | 5 => 2.3,
                6 | 7 => 0.9,
                _ => 8.0,
            };
            frame.depth_m[(y * w + x) as usize] = depth;
        }
    }
    frame
}

/// A triangular aperture image.
fn triangle_mask() -> realcam::model::aperture::ApertureMask {
    let s = 32u32;
    let triangle: Vec<f32> = (0..s * s)
        .map(|i| {
            let (x, y) = ((i % s) as f32, (i / s) as f32);
            if x >= y * 0.5 && x <= s as f32 - y * 0.5 {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    realcam::model::aperture::ApertureMask::from_grey(s, s, &triangle).unwrap()
}

fn assert_close(gpu: &[f32], cpu: &[f32], what: &str, relative: f32) {
    assert_eq!(gpu.len(), cpu.len());
    for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        let tolerance = relative * c.abs().max(1.0);
        assert!((g - c).abs() <= tolerance, "{what}[{i}]: gpu {g} cpu {c}");
    }
}

/// Scenes and cameras that together make every pass of the pass order run, on tiny frames.
fn twin_cases() -> Vec<(&'static str, Frame, Camera)> {
    let mut cases = Vec::new();
    // The reference gather with everything the aperture can do, vignetting (cos^4, then a lens's
    // table) and the film curve.
    for (blades, with_mask) in [(5, false), (0, true)] {
        let mut camera = dof_camera(50.0, 1.4, 2.0, blades);
        // The clamp these cases were made with (the default until issue 29): 5 px on the 40 px
        // frame, a gather the f32 twin follows within its tolerance.
        camera.max_coc = realcam::model::camera::CocLimit::FilmMm(1.2);
        camera.aperture_mask = with_mask.then(triangle_mask);
        camera.aperture.spherical_aberration = 0.5;
        camera.aperture.cats_eye = 0.3;
        camera.field_curvature =
            Some(HeightTable { image_height_mm: vec![0.0, 1.0, 3.0], values: vec![0.0, 0.05, 0.3] });
        camera.bokeh = BokehMode::Reference;
        camera.vignetting = true;
        // The second case vignettes by a relative-illumination table, the first by cos^4.
        camera.relative_illumination =
            with_mask.then(|| HeightTable { image_height_mm: vec![0.0, 1.0, 3.0], values: vec![1.0, 0.9, 0.6] });
        camera.exposure = true;
        camera.film = FilmMode::Curve(FilmCurve::default_filmic());
        cases.push(("reference gather, vignette, film", busy_frame(40, 28), camera));
    }
    // The tiled path (copy, small and large tiles, sprites) once per channel for longitudinal
    // colour, then every aberration of the image.
    let mut camera = dof_camera(50.0, 1.4, 2.0, 6);
    camera.max_coc = realcam::model::camera::CocLimit::Px(64.0);
    camera.aperture.spherical_aberration = -0.4;
    camera.longitudinal_color_mm = Some([0.3, -0.3]);
    let table = |values: Vec<f64>| HeightTable { image_height_mm: vec![0.0, 2.0, 6.0], values };
    camera.distortion = Some(DistortionTables {
        green_percent: table(vec![0.0, -1.0, -4.0]),
        red_extra_percent: table(vec![0.0, 0.1, 0.3]),
        blue_extra_percent: table(vec![0.0, -0.1, -0.3]),
    });
    camera.astigmatism = Some((table(vec![0.0, 0.05, 0.2]), table(vec![0.0, 0.02, 0.1])));
    camera.coma = Some(table(vec![0.0, 0.1, 0.3]));
    cases.push(("tiled, longitudinal colour, distortion, astigmatism, coma", banded_frame(160, 48), camera));
    // Motion blur: a bar moving over a textured background along a bent path (its previous and
    // next vectors differ), a trapezoid shutter and a rolling readout, on a frame wide enough
    // for tiles nothing near moves in (copied by mb_still); then the reference on a smaller frame
    // (its sub-frame times are many dispatches).
    let mut camera = motion_camera(24.0, 0.5);
    camera.motion.timing = realcam::optics::shutter::ShutterTiming::new(
        0.5 / 24.0,
        24.0,
        realcam::optics::shutter::ShutterPosition::Centred,
        realcam::optics::shutter::ShutterCurve::Trapezoid { ramp: 0.25 },
    )
    .with_rolling(0.01, 24.0, realcam::optics::shutter::RollingDirection::Down);
    let texture = |x: u32, y: u32| [0.2 + 0.1 * ((x / 3 + y / 5) % 3) as f32, 0.3, 0.1 * (y % 4) as f32];
    let bar = |w, h, next, prev| moving_bar_frame(w, h, (14, 22), [4.0, 1.0, 0.5], (1.0, 6.0), next, prev, texture);
    cases.push((
        "motion blur, bent path, rolling trapezoid shutter",
        bar(96, 34, [12.0, 3.0], Some([-10.0, 4.0])),
        camera,
    ));
    // The edge resolve (mb_edges) changing pixels: a still 3x3 highlight whose anti-aliased
    // fringe carries the depth and velocity of the plane moving behind it.
    cases.push(("motion blur, anti-aliased highlight over a mover", highlight_frame(40, 24), motion_camera(24.0, 0.5)));
    let mut camera = motion_camera(24.0, 0.5);
    camera.motion.mode = realcam::model::camera::MotionBlurMode::Reference;
    cases.push(("motion blur reference", bar(36, 20, [6.0, 1.0], None), camera));
    // The diffraction focus processor.
    let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
    camera.bokeh = BokehMode::Diffraction;
    camera.max_coc = realcam::model::camera::CocLimit::Px(12.0);
    cases.push(("diffraction", busy_frame(24, 16), camera));
    // Lens flare: the Tessar's ghosts, a 5-bladed starburst and the halo, from two lights in
    // the frame (one of 3x3 px spanning two tiles) and one given just outside it.
    cases.push(("flare", flare_frame(72, 40), flare_camera("tessar-walch-lens.toml", 5)));
    // Neither ghosts (a lens file without a prescription) nor spikes (a round aperture): the
    // ghost-sprite kernel's pipeline specialised without both loops.
    let glow_only = flare_camera("default.toml", 0);
    let model = realcam::passes::flare::FlareModel::new(&glow_only, 0.01, [36.0, 20.0]);
    assert!(
        model.catalogue.is_none() && model.starburst.spikes().is_empty(),
        "the glow-only case has ghosts or spikes"
    );
    cases.push(("flare, glow only", flare_frame(72, 40), glow_only));
    // Walch's fitted ghosts (the Tessar's fits, docs/): covering tiles in ghost_sprites, crossing
    // ones in fitted_ghosts; a light of 4e9 in the frame and one of 1e10 given inside it.
    cases.push(("flare, fitted ghosts", fitted_flare_frame(96, 54), fitted_flare_camera(96, 54)));
    // The vignette in a dispatch of its own: no film pass to apply it (exposure off, linear).
    let mut camera = dof_camera(50.0, 1.4, 2.0, 5);
    camera.vignetting = true;
    camera.relative_illumination =
        Some(HeightTable { image_height_mm: vec![0.0, 1.0, 3.0], values: vec![1.0, 0.9, 0.6] });
    camera.exposure = false;
    camera.film = FilmMode::Linear;
    cases.push(("vignette without the film", busy_frame(40, 28), camera));
    cases
}

/// A still 3x3 highlight of 50 at 2 m at the frame's centre, its one-pixel fringe 30% (9% at the
/// corners) highlight in colour but with the depth (5 m) and velocity (12, 2 px per frame) of the
/// striped plane behind it.
fn highlight_frame(w: u32, h: u32) -> Frame {
    let (cx, cy) = (w as i32 / 2, h as i32 / 2);
    let (mut color, mut depth, mut next) = (Vec::new(), Vec::new(), Vec::new());
    for y in 0..h as i32 {
        for x in 0..w as i32 {
            let share = |d: i32| [1.0f32, 1.0, 0.3, 0.0][d.unsigned_abs().min(3) as usize];
            let a = share(x - cx) * share(y - cy);
            let inside = (x - cx).abs() <= 1 && (y - cy).abs() <= 1;
            let plane = [0.3 + 0.4 * ((x / 3) % 2) as f32, 0.5, 0.2];
            color.extend([0, 1, 2].map(|k| a * 50.0 + (1.0 - a) * plane[k]));
            color.push(1.0);
            depth.push(if inside { 2.0 } else { 5.0 });
            next.extend(if inside { [0.0, 0.0] } else { [12.0, 2.0] });
        }
    }
    Frame::new(w, h, color, depth).with_velocity(next, None)
}

/// A dim frame with two lights: 3x3 px of 4000 across a tile edge and one pixel of 20000.
fn flare_frame(w: u32, h: u32) -> Frame {
    let mut color: Vec<f32> = (0..w * h).flat_map(|_| [0.05, 0.04, 0.03, 1.0]).collect();
    let mut set = |x: u32, y: u32, v: [f32; 3]| color[((y * w + x) * 4) as usize..][..3].copy_from_slice(&v);
    for (x, y) in (15..18).flat_map(|x| (9..12).map(move |y| (x, y))) {
        set(x, y, [4000.0, 3000.0, 2000.0]);
    }
    set(50, 30, [20000.0, 20000.0, 20000.0]);
    Frame::new(w, h, color, vec![3.0; (w * h) as usize])
}

/// A shipped lens (lenses/`file`) with flare on, scene values kept (no exposure, vignetting or
/// film curve), a 10.8 mm wide sensor and a light just outside the frame.
fn flare_camera(file: &str, blades: u32) -> Camera {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("lenses").join(file);
    let lens = realcam::io::lens_file::LensFile::load(&path).expect("a shipped lens file");
    let request = realcam::model::camera::CameraRequest {
        sensor: Some("10.8x6".into()),
        blades: Some(blades),
        blade_rotation_deg: Some(10.0),
        flare: Some(true),
        flare_lights: vec![realcam::model::flare::FlareLight::white(-6.0, 20.0, 5.0e4)],
        force: true,
        ..realcam::model::camera::CameraRequest::blur_only().with_lens(100.0, 4.0, 50.0)
    };
    Camera::new(&lens, &request).expect("flare camera")
}

/// A black frame with a light of three pixels of 4e9.
fn fitted_flare_frame(w: u32, h: u32) -> Frame {
    let mut color = vec![0.0f32; (w * h * 4) as usize];
    for (x, y) in [(30, 40), (31, 40), (30, 41)] {
        color[((y * w + x) * 4) as usize..][..3].copy_from_slice(&[4.0e9; 3]);
    }
    Frame::new(w, h, color, vec![1.0e4; (w * h) as usize])
}

/// The Tessar with its fitted ghosts (docs/flare/tessar-walch-fitted.toml) at the fits' f/2.8
/// on a 36 mm wide sensor of the frame's aspect, scene values kept, no distortion, one light given.
fn fitted_flare_camera(w: u32, h: u32) -> Camera {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/flare/tessar-walch-fitted.toml");
    let lens = realcam::io::lens_file::LensFile::load(&path).expect("the fitted Tessar");
    let request = realcam::model::camera::CameraRequest {
        sensor: Some(format!("36x{}", 36.0 * h as f64 / w as f64)),
        flare: Some(true),
        flare_lights: vec![realcam::model::flare::FlareLight::white(70.0, 12.0, 1.0e10)],
        force: true,
        ..realcam::model::camera::CameraRequest::blur_only().with_lens(lens.focal_length_mm, 2.8, 1.0e4)
    };
    let mut camera = Camera::new(&lens, &request).expect("fitted flare camera");
    // The flare alone: the lens's distortion resampling the flare's 1e9-bright light is
    // another case's.
    camera.distortion = None;
    camera
}

/// Two of Walch's primitives on a 40x28 frame: a rounded one and a rolled diamond-like one.
fn bezier_case() -> Vec<realcam::tools::bezier_ghosts::DrawnGhost> {
    use realcam::optics::bezier_ghost::{BezierGhost, Transfer};
    let ghost = BezierGhost {
        centre_px: [14.3, 12.6],
        height_px: 9.0,
        left_px: 6.0,
        right_px: 11.0,
        left_control: 0.55,
        right_control: 0.8,
        transfer: Transfer {
            border: 3.0,
            inner: 0.5,
            inner_falloff_px: 4.0,
            outer_falloff_px: 2.5,
            inner_exponent: 0.7,
            outer_exponent: 2.0,
        },
    };
    let turned = BezierGhost { centre_px: [33.0, 20.0], left_control: 0.1, right_control: 0.3, ..ghost };
    vec![
        realcam::tools::bezier_ghosts::DrawnGhost {
            ghost,
            colour: [1.0, 0.5, 0.2],
            roll_rad: 0.0,
            pivot_px: [20.0, 14.0],
        },
        realcam::tools::bezier_ghosts::DrawnGhost {
            ghost: turned,
            colour: [0.1, 0.6, 1.0],
            roll_rad: 0.7,
            pivot_px: [20.0, 14.0],
        },
    ]
}

#[test]
fn every_dispatch_of_every_pass_matches_its_cpu_twin() {
    // Every dispatch of the plan is checked against its shader's CPU twin on the GPU's own
    // inputs (the recorder reads the bindings back before and after it). A pass of the pass
    // order that no case runs, or a compiled shader that no dispatch checked, fails the test.
    let gpu = gpu();
    let (mut ran, mut checked, mut failures) = (BTreeSet::new(), BTreeSet::new(), Vec::new());
    // The composite's two pipelines (with the exact gather over a level's class list, without
    // it over the level's blurred list) each checked on tiles.
    let mut composite_lists = BTreeSet::new();
    // The sprites' dispatch, on tiles that have sprites (it has no workgroup where none has).
    let mut sprite_tiles_checked = 0;
    // The motion blur's two tile lists, each checked on tiles.
    let (mut gather_tiles_checked, mut still_tiles_checked) = (0, 0);
    // The bare pass of the benchmark is no pass of a render: check it on its own.
    let copy = realcam::gpu::Kernel::new(&gpu).expect("copy pipeline");
    let (_, checks) = realcam::tools::bench::run_bare_pass(&gpu, &copy, &busy_frame(20, 12), true).expect("bare pass");
    for c in checks {
        checked.insert(c.shader);
        if let Err(e) = c.result {
            failures.push(format!("bare pass: {e}"));
        }
    }
    // Walch's measured ghosts are drawn by `realcam flare`, not a render: two primitives, one
    // turned by eq 8.2's roll, overlapping a tile edge and the frame's edge.
    let bezier = realcam::gpu::Kernel::new(&gpu).expect("bezier_ghosts pipeline");
    let (_, _, checks) =
        realcam::tools::bezier_ghosts::draw(&bezier, "bezier twin", &gpu, 40, 28, &bezier_case(), true)
            .expect("bezier ghosts");
    assert_validation_clean(&gpu);
    for c in checks {
        checked.insert(c.shader);
        if let Err(e) = c.result {
            failures.push(format!("bezier ghosts: {e}"));
        }
    }
    for (name, frame, camera) in twin_cases() {
        let plan = planner::plan(&frame, &camera);
        let renderer = Renderer::new(&gpu, &plan).expect("pipelines");
        let (_, checks) = renderer.render_with_twin_checks(&frame, &plan).expect("render");
        assert_validation_clean(&gpu);
        for c in checks {
            checked.insert(c.shader);
            if c.shader == "dof_composite" && c.groups[0] > 0 {
                composite_lists.insert(c.pass.ends_with("_blurred"));
            }
            match c.shader {
                "dof_sprites" => sprite_tiles_checked += c.groups[0],
                "mb_gather" => gather_tiles_checked += c.groups[0],
                "mb_still" => still_tiles_checked += c.groups[0],
                _ => {}
            }
            if let Err(e) = c.result {
                failures.push(format!("{name}: pass {}: {e}", c.pass));
            }
        }
        ran.extend(plan.passes.iter().filter(|p| p.runs()).map(|p| p.name));
    }
    // The shaders' variants for devices without subgroup operations (dof_sprites_plain), on the
    // cases that run them.
    let plain = gpu_without_subgroup_ops();
    let plain_cases = twin_cases().into_iter().filter(|(name, ..)| name.starts_with("tiled"));
    for (name, frame, camera) in plain_cases {
        let plan = planner::plan(&frame, &camera);
        let (_, checks) =
            Renderer::new(&plain, &plan).expect("pipelines").render_with_twin_checks(&frame, &plan).expect("render");
        assert_validation_clean(&plain);
        for c in checks.iter().filter(|c| c.shader.ends_with("_plain")) {
            checked.insert(c.shader);
            if let Err(e) = &c.result {
                failures.push(format!("{name}, no subgroup operations: pass {}: {e}", c.pass));
            }
        }
    }
    assert!(failures.is_empty(), "{} dispatches differ from their twins:\n{}", failures.len(), failures.join("\n"));
    for entry in PASS_ORDER {
        assert!(ran.contains(entry.name), "pass {} ran in no case: add one to twin_cases", entry.name);
    }
    for (shader, _) in realcam::gpu::shaders::ALL {
        assert!(checked.contains(shader), "shader {shader} was never checked against a twin");
    }
    assert_eq!(composite_lists.len(), 2, "the composite ran on tiles of only one kind of list: {composite_lists:?}");
    assert!(sprite_tiles_checked > 0, "the sprites were checked on no tile with sprites");
    assert!(gather_tiles_checked > 0 && still_tiles_checked > 0, "the motion blur's gather ({gather_tiles_checked} tiles) or copy ({still_tiles_checked}) was checked on no tile");
}

#[test]
fn whole_pipeline_matches_the_chained_cpu_twins() {
    // The renderer's composition: the CPU twins chained by hand give the GPU's output.
    let gpu = gpu();
    for (_, frame, camera) in twin_cases().into_iter().take(2) {
        let plan = planner::plan(&frame, &camera);
        for pass in ["coc", "bokeh_gather", "vignette", "film"] {
            assert!(plan.runs(pass), "{pass} should run:\n{}", plan.explain());
        }
        let renderer = Renderer::new(&gpu, &plan).expect("pipelines");
        let out = renderer.render(&frame, &plan, true).expect("render");
        assert_validation_clean(&gpu);

        let coc_params = plan.params::<coc::Coc>().unwrap();
        let coc_cpu = coc::coc_resolved_cpu(&frame.depth_m, &frame.color, &coc_params.push, &coc_params.table);
        assert_close(out.coc_px.as_ref().unwrap(), &coc_cpu, "coc", 1e-5);
        let gather = plan.params::<bokeh_gather::BokehGather>().unwrap();
        let dof = bokeh_gather::gather_cpu(&frame.color, &coc_cpu, &gather.push, &gather.aperture);
        // The film runs, so the vignette's falloff is applied in its dispatch: the film's twin
        // applies it, and the same falloff by the vignette's own twin then the film without it
        // gives the same values.
        let v = plan.params::<vignette::Vignette>().unwrap();
        let f = plan.params::<film::Film>().unwrap();
        assert!(v.in_film && f.push.vignette == 1, "{}", plan.explain());
        let cpu = film::film_cpu(&dof, &f.push, &f.table);
        assert_close(&out.rgba, &cpu, "pipeline", 1e-4);
        let film_alone = film::FilmPush { vignette: 0, ..f.push };
        let apart = film::film_cpu(&vignette::vignette_cpu(&dof, &v.push, &v.table), &film_alone, &f.table);
        assert_eq!(cpu, apart, "the vignette in the film's dispatch against the two passes apart");
        let corner = v.push.corner_falloff(&v.table);
        assert!(corner < 0.99, "the case vignettes visibly (twice would show): {corner}");
    }
}

#[test]
fn film_pass_matches_the_f64_characteristic_curve() {
    // The f32 shader against the f64 reference curve in src/optics/film.rs over 14 decades.
    let gpu = gpu();
    let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
    camera.film = FilmMode::Curve(FilmCurve::default_filmic());
    let (w, h) = (64u32, 2u32);
    let values: Vec<f32> = (0..w * h).map(|i| 10f32.powf(-8.0 + 14.0 * i as f32 / (w * h) as f32)).collect();
    let color: Vec<f32> = values.iter().flat_map(|&v| [v, v, v, 1.0]).collect();
    let frame = Frame::new(w, h, color, vec![2.0; (w * h) as usize]);
    let plan = planner::plan(&frame, &camera);
    assert!(plan.runs("film") && !plan.runs("bokeh_gather") && !plan.runs(realcam::pipeline::planner::BOKEH_TILED));
    let (rgba, _) = render_plan(&gpu, &frame, &plan);
    let curve = FilmCurve::default_filmic();
    for (i, &v) in values.iter().enumerate() {
        let reference = curve.apply(v as f64);
        let got = rgba[i * 4] as f64;
        assert!((got - reference).abs() <= 1e-4 * reference.max(1e-3), "H = {v}: gpu {got}, f64 {reference}");
    }
}

#[test]
fn the_tiled_depth_of_field_gives_the_same_bits_on_every_run() {
    // Many highlights whose sprites share tiles: dof_bin fills the tiles' bins with atomics, in
    // an order that changes between runs; dof_bin_order sorts each bin by the sprites' centres,
    // so the composite adds their light in the same order every time.
    let gpu = gpu();
    let frame = banded_frame(320, 96);
    let mut camera = dof_camera(50.0, 1.4, 2.0, 6);
    camera.max_coc = realcam::model::camera::CocLimit::Px(64.0);
    camera.bokeh = BokehMode::Tiled;
    let plan = planner::plan(&frame, &camera);
    assert!(plan.runs("bokeh_tiled"));
    let renders: Vec<Vec<u32>> =
        (0..4).map(|_| render_plan(&gpu, &frame, &plan).0.iter().map(|v| v.to_bits()).collect()).collect();
    for (i, r) in renders.iter().enumerate().skip(1) {
        let differing = r.iter().zip(&renders[0]).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "run {i}: {differing} values differ from run 0's");
    }
}

#[test]
fn the_sprites_give_the_same_bits_with_and_without_subgroup_operations() {
    // dof_sprites reads each tile's sprites once per subgroup and broadcasts them where the device
    // can (lavapipe can); dof_sprites_plain, for devices that cannot, reads them in every
    // invocation. Both add the same sprites in the same order: the same bits.
    let frame = banded_frame(320, 96);
    let mut camera = dof_camera(50.0, 1.4, 2.0, 6);
    camera.max_coc = realcam::model::camera::CocLimit::Px(64.0);
    camera.bokeh = BokehMode::Tiled;
    let plan = planner::plan(&frame, &camera);
    let (subgroup, profile) = render_plan(&gpu(), &frame, &plan);
    let (plain, plain_profile) = render_plan(&gpu_without_subgroup_ops(), &frame, &plan);
    let ran = |p: &realcam::gpu::Profile| p.passes.iter().filter(|t| t.name == "dof_sprites").count();
    assert!(ran(&profile) > 0 && ran(&plain_profile) > 0, "the frame drew no sprites");
    let differing = subgroup.iter().zip(&plain).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differing, 0, "{differing} values differ between the two variants");
}

#[test]
fn sensor_noise_is_deterministic_and_grows_with_the_square_root_of_iso() {
    // A flat grey frame through a linear film with exposure off: the noise alone. Its standard
    // deviation is grain * sqrt(ISO / 100) * sqrt(value); the same seed gives the same image, the
    // GPU matches the CPU twin, and the mean stays.
    let gpu = gpu();
    let (w, h) = (128u32, 128u32);
    let value = 0.25f32;
    let color: Vec<f32> = (0..w * h).flat_map(|_| [value, value, value, 1.0]).collect();
    let frame = Frame::new(w, h, color, vec![2.0; (w * h) as usize]);
    let mut stds = Vec::new();
    for (iso, seed) in [(100.0, 7u32), (1600.0, 7), (1600.0, 7), (1600.0, 8)] {
        let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
        camera.iso = iso;
        camera.grain = 0.02;
        camera.seed = seed;
        let plan = planner::plan(&frame, &camera);
        assert!(plan.runs("film"));
        let (rgba, _) = render_plan(&gpu, &frame, &plan);
        let f = plan.params::<film::Film>().unwrap();
        let cpu = film::film_cpu(&frame.color, &f.push, &f.table);
        assert_close(&rgba, &cpu, "noise GPU vs CPU", 1e-4);
        let greens: Vec<f64> = rgba.chunks_exact(4).map(|p| p[1] as f64).collect();
        let mean = greens.iter().sum::<f64>() / greens.len() as f64;
        let std = (greens.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / greens.len() as f64).sqrt();
        let expected = 0.02 * (iso / 100.0f64).sqrt() * (value as f64).sqrt();
        assert!((mean / value as f64 - 1.0).abs() < 0.01, "mean {mean}");
        assert!((std / expected - 1.0).abs() < 0.05, "ISO {iso}: std {std}, expected {expected}");
        stds.push((std, rgba));
    }
    assert_eq!(stds[1].1, stds[2].1, "the same seed gives the same noise");
    assert_ne!(stds[2].1, stds[3].1, "another seed gives other noise");
    assert!((stds[1].0 / stds[0].0 - 4.0).abs() < 0.2, "ISO 1600 / ISO 100 noise: {}", stds[1].0 / stds[0].0);
}

#[test]
fn film_table_matches_its_cpu_twin_and_the_curve_it_samples() {
    // A film file's table sampled from the neutral curve every 0.1 decade: the GPU follows its
    // CPU twin, and the tabled curve stays within the linear-interpolation error of the
    // parametric one (second derivative * step^2 / 8).
    use realcam::io::film_file::{FilmFile, FilmResponse};
    let curve = FilmCurve::default_filmic();
    let xs: Vec<f64> = (0..=100).map(|i| -8.0 + 0.1 * i as f64).collect();
    let ys: Vec<f64> = xs.iter().map(|&x| curve.apply_log10(x)).collect();
    let row = |v: &[f64]| v.iter().map(|x| format!("{x:.9}")).collect::<Vec<_>>().join(", ");
    let text = format!(
        "name = \"sampled\"\nsource = \"test\"\n[table]\nlog10_sensor_value = [{}]\nlog10_output = [{}]\n",
        row(&xs),
        row(&ys)
    );
    let film = FilmFile::parse(&text, std::path::Path::new("sampled.toml")).unwrap();
    assert!(matches!(film.response, FilmResponse::Table(_)));
    let gpu = gpu();
    let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
    camera.film = FilmMode::from_file(&film);
    let (w, h) = (64u32, 2u32);
    let values: Vec<f32> = (0..w * h).map(|i| 10f32.powf(-7.0 + 9.0 * i as f32 / (w * h) as f32)).collect();
    let color: Vec<f32> = values.iter().flat_map(|&v| [v, v, v, 1.0]).collect();
    let frame = Frame::new(w, h, color.clone(), vec![2.0; (w * h) as usize]);
    let plan = planner::plan(&frame, &camera);
    assert!(plan.runs("film"));
    let (rgba, _) = render_plan(&gpu, &frame, &plan);
    let f = plan.params::<film::Film>().unwrap();
    let cpu = film::film_cpu(&color, &f.push, &f.table);
    assert_close(&rgba, &cpu, "film table GPU vs CPU", 1e-4);
    // Linear interpolation error bound: max |y''| h^2 / 8 = max |second difference| / 8.
    let bound = (1..ys.len() - 1).map(|i| (ys[i + 1] - 2.0 * ys[i] + ys[i - 1]).abs()).fold(0.0, f64::max) / 8.0;
    assert!(bound < 0.01, "bound {bound}");
    for (i, &v) in values.iter().enumerate() {
        let decades = (rgba[i * 4] as f64).log10() - curve.apply_log10((v as f64).log10());
        assert!(
            decades.abs() < 1.5 * bound + 1e-5,
            "H = {v}: table off the curve by {decades} decades (bound {bound})"
        );
    }
}

#[test]
fn each_channel_run_of_the_tiled_depth_of_field_reads_the_colour_as_it_was() {
    // With longitudinal colour the tiled path runs once per channel, each on the input colour.
    // Each run takes its sprites' excess out of that colour in place (dof_sprite_excess) and
    // puts those pixels back at its end: run in the reverse channel order, the output is the
    // same bits (a run that left its change behind would change the next runs' highlights and
    // gathers, and which runs see it depends on the order).
    use realcam::passes::dof::tiled::{TiledDof, TiledDofParams};
    let gpu = gpu();
    let frame = banded_frame(160, 48);
    let mut camera = dof_camera(50.0, 1.4, 2.0, 6);
    camera.max_coc = realcam::model::camera::CocLimit::Px(64.0);
    camera.longitudinal_color_mm = Some([0.3, -0.3]);
    let plan = planner::plan(&frame, &camera);
    let mut reversed = planner::plan(&frame, &camera);
    let tiled = reversed.passes.iter_mut().find(|p| p.name == "bokeh_tiled").expect("the tiled pass");
    let mut runs: Vec<TiledDofParams> = tiled.params::<TiledDof>().cloned().collect();
    runs.reverse();
    assert_eq!(runs.len(), 3, "one run per channel:\n{}", plan.explain());
    tiled.set_runs::<TiledDof>(runs, "the channels in reverse order");
    // Every run has sprites, so each changes the colour it reads.
    let renderer = Renderer::new(&gpu, &plan).expect("pipelines");
    let (_, checks) = renderer.render_with_twin_checks(&frame, &plan).expect("render");
    let excess: Vec<_> = checks.iter().filter(|c| c.shader == "dof_sprite_excess").collect();
    assert_eq!(excess.len(), 6, "a take-out and a restore per run");
    assert!(excess.iter().all(|c| c.groups[0] > 0 && c.result.is_ok()), "{excess:?}");
    let bits = |rgba: Vec<f32>| rgba.into_iter().map(f32::to_bits).collect::<Vec<_>>();
    let forward = bits(render_plan(&gpu, &frame, &plan).0);
    let backward = bits(render_plan(&gpu, &frame, &reversed).0);
    assert_validation_clean(&gpu);
    let differing = forward.iter().zip(&backward).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} values differ between the channel orders");
}
