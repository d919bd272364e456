//! Lens flare on the GPU (lavapipe, validation on): ghosts where the matrices and the traced
//! reference put them, with the light's energy times the reflectances and transmissions; the
//! starburst's spikes counted and its energy and the halo's against their formulas; a light
//! partly hidden flares less; no flare pass without a bright light; hard inputs stay finite.

mod support;

use realcam::gpu::shaders::flare::SPRITE_LIST;
use realcam::io::lens_file::LensFile;
use realcam::model::camera::{Camera, CameraRequest};
use realcam::model::flare::FlareLight;
use realcam::model::frame::Frame;
use realcam::optics::flare::coating::reflectance;
use realcam::optics::flare::ghosts::{path_matrix, Event, GhostPath, Moments};
use realcam::optics::flare::traced::{chief_ray, display_px, optical_slope};
use realcam::optics::flare::{channel_nm, BANDS_NM, BAND_WEIGHTS};
use realcam::passes::flare::{bins, ghost_sprites, lights, tiles};
use realcam::passes::flare::{Flare, FlareModel, FlareParams};
use realcam::passes::PlanInput;
use realcam::pipeline::planner::plan;
use realcam::pipeline::render::Renderer;
use std::path::Path;
use support::*;

fn lens(name: &str) -> LensFile {
    LensFile::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("lenses").join(name)).expect("lens file")
}

/// A camera that keeps scene values (no exposure, vignetting or film curve) with flare on.
fn flare_camera(lens_file: &LensFile, f_number: f64, sensor: &str, lights: Vec<FlareLight>) -> Camera {
    let request = CameraRequest {
        sensor: Some(sensor.into()),
        flare: Some(true),
        flare_lights: lights,
        force: true,
        ..CameraRequest::blur_only().with_lens(lens_file.focal_length_mm, f_number, 1.0e4)
    };
    Camera::new(lens_file, &request).expect("camera")
}

fn black(w: u32, h: u32) -> Frame {
    Frame::new(w, h, vec![0.0; (w * h * 4) as usize], vec![1.0e4; (w * h) as usize])
}

/// Render `frame` with the flare pass run with `params` (the other passes as planned).
fn render_with(frame: &Frame, camera: &Camera, params: FlareParams) -> Vec<f32> {
    let gpu = gpu();
    let mut p = plan(frame, camera);
    p.force::<Flare>(params);
    let (rgba, _) = render_plan(&gpu, frame, &p);
    assert!(rgba.iter().all(|v| v.is_finite()), "a value is not finite");
    rgba
}

/// The flare's parameters for `ghosts` only (no spikes, glow or halo).
fn ghosts_only(frame: &Frame, camera: &Camera, ghosts: &[GhostPath]) -> FlareParams {
    let input = PlanInput::new(frame, camera);
    let model = FlareModel::new(camera, input.facts.pixel_pitch_mm, frame.centre_px);
    let mut p = FlareParams::new(&input, &model, Some(ghosts));
    p.constants.spike_count = 0;
    p.constants.glow_coef_px = [0.0; 4];
    p.constants.halo_fraction = 0.0;
    p.constants.slots_per_light = p.constants.ghost_count + 1;
    p
}

/// Per channel: the image's energy, and its light's moments.
fn channel_moments(rgba: &[f32], w: u32, c: usize) -> Option<Moments> {
    let points = rgba
        .chunks_exact(4)
        .enumerate()
        .filter(|(_, p)| p[c] > 0.0)
        .map(move |(i, p)| ([(i as u32 % w) as f64 + 0.5, (i as u32 / w) as f64 + 0.5], p[c] as f64));
    Moments::of(points.collect::<Vec<_>>().into_iter())
}

/// R_i R_j times the path's transmissions over the direct path's, at normal incidence,
/// averaged over the channel's band: what a ghost of the uncoated lens carries of its light.
fn fresnel_share(camera: &Camera, path: GhostPath, c: usize) -> f64 {
    let p = camera.flare.prescription.as_ref().unwrap();
    let n = p.surfaces.len();
    let media =
        |k: usize, l: f64| (if k == 0 { 1.0 } else { p.surfaces[k - 1].index_at(l) }, p.surfaces[k].index_at(l));
    let share = |events: &[Event], l: f64| -> f64 {
        events
            .iter()
            .map(|e| match *e {
                Event::Transmit { surface, forward } => {
                    let (a, b) = media(surface, l);
                    1.0 - if forward { reflectance(a, b, 1.0, l, None) } else { reflectance(b, a, 1.0, l, None) }
                }
                Event::Reflect { surface, from_front } => {
                    let (a, b) = media(surface, l);
                    if from_front {
                        reflectance(a, b, 1.0, l, None)
                    } else {
                        reflectance(b, a, 1.0, l, None)
                    }
                }
            })
            .product()
    };
    let direct: Vec<Event> = (0..n).map(|k| Event::Transmit { surface: k, forward: true }).collect();
    BANDS_NM[c].iter().zip(BAND_WEIGHTS).map(|(&l, w)| w * share(&path.events(n), l) / share(&direct, l)).sum()
}

#[test]
fn ghosts_lie_where_the_matrices_and_the_traced_rays_put_them_with_the_lights_energy_times_r_r_t() {
    // The uncoated Tessar at f/32 (its ghosts are hundreds of pixels wide wider open) at the
    // pitch of 36 mm over 1280 px, on a 720 x 720 px crop around the optical centre; a light
    // 54 px from the centre. The first six ghosts that fit the frame unclipped, each drawn
    // alone (src/optics/flare/traced.rs checks the chief rays of all 21 on the CPU): its light's centroid per channel lies on the line through the centre and the light,
    // within 0.25 px of the matrix model's centre and within 1 px of the real chief ray's
    // (src/optics/flare/traced.rs); its energy is the light's times R_i R_j times the path's
    // transmissions over the direct path's (Fresnel at normal incidence over the band,
    // computed here from the indices) within 2% (times the share of the entrance pupil its
    // aperture sees, for a path reflecting in front of the stop).
    let tessar = lens("tessar-walch-lens.toml");
    let (w, h) = (720u32, 720u32);
    let light = FlareLight::white(410.5, 380.5, 1.0e9);
    let mut camera = flare_camera(&tessar, 32.0, "20.25x20.25", vec![light]);
    camera.flare.coating_design_nm = None;
    let frame = black(w, h);
    let input = PlanInput::new(&frame, &camera);
    let pitch = input.facts.pixel_pitch_mm;
    assert!((pitch - 36.0 / 1280.0).abs() < 1e-12);
    let model = FlareModel::new(&camera, pitch, frame.centre_px);
    let catalogue = model.catalogue.as_ref().unwrap();
    let flare_lens = model.lens.as_ref().unwrap();
    let g0 = catalogue.direct.centre_mm[1];
    let u = [(light.x_px - 360.0) * pitch / g0, (light.y_px - 360.0) * pitch / g0];
    let aperture = model.starburst.aperture;
    let mut tested = 0;
    for g in &catalogue.ghosts {
        let shapes: Vec<_> =
            (0..3).map(|c| g.channels[c].shape(u, frame.centre_px, pitch, 1.0, aperture.area_factor())).collect();
        let fits = shapes.iter().all(|s| {
            let m = s.moments(&aperture, 1);
            let unclipped =
                m.is_some_and(|m| (m.area_px2 / (std::f64::consts::PI * s.radius_px * s.radius_px) - 1.0).abs() < 0.01);
            unclipped
                && s.radius_px > 3.0
                && s.centre_px[0] - s.radius_px > 2.0
                && s.centre_px[0] + s.radius_px < w as f64 - 2.0
                && s.centre_px[1] - s.radius_px > 2.0
                && s.centre_px[1] + s.radius_px < h as f64 - 2.0
        });
        if !fits || tested == 6 {
            continue;
        }
        tested += 1;
        let rgba = render_with(&frame, &camera, ghosts_only(&frame, &camera, &[g.path]));
        let events = g.path.events(flare_lens.prescription.surfaces.len());
        for (c, shape) in shapes.iter().enumerate() {
            let m = channel_moments(&rgba, w, c).expect("the ghost is drawn");
            let miss = (m.centroid_px[0] - shape.centre_px[0]).hypot(m.centroid_px[1] - shape.centre_px[1]);
            assert!(
                miss < 0.25,
                "{:?} channel {c}: centroid {:?}, matrix {:?}",
                g.path,
                m.centroid_px,
                shape.centre_px
            );
            let (dx, dy) = (m.centroid_px[0] - 360.0, m.centroid_px[1] - 360.0);
            let off_line = (dx * (light.y_px - 360.0) - dy * (light.x_px - 360.0)).abs()
                / (light.x_px - 360.0).hypot(light.y_px - 360.0);
            assert!(off_line < 0.25, "{:?} channel {c}: {off_line} px off the line", g.path);
            let chief =
                chief_ray(flare_lens, &events, g.channels[c].aperture_crossing, optical_slope(u), channel_nm(c));
            if let Some(chief) = chief {
                let d = display_px(chief, pitch);
                let traced_miss = (m.centroid_px[0] - 360.0 - d[0]).hypot(m.centroid_px[1] - 360.0 - d[1]);
                assert!(traced_miss < 1.0, "{:?} channel {c}: {traced_miss} px from the traced chief ray", g.path);
            }
            // Behind the stop the ghost's light enters through the entrance pupil; a path that
            // reflects before the stop lets through the entrance region its own stop crossing
            // sees: (a_direct / a_ghost)^2 of the pupil's area, from the matrices.
            let stop = flare_lens.prescription.stop_index();
            let area = if g.path.second > stop {
                1.0
            } else {
                let a = |events: &[Event]| {
                    path_matrix(flare_lens, events, channel_nm(c)).crossings[..]
                        .iter()
                        .filter(|x| x.surface == stop)
                        .map(|x| x.a.abs())
                        .fold(0.0, f64::max)
                };
                let direct: Vec<Event> =
                    (0..events.len().min(8)).map(|k| Event::Transmit { surface: k, forward: true }).collect();
                (a(&direct) / a(&events)).powi(2)
            };
            let expected = light.energy[c] * fresnel_share(&camera, g.path, c) * area;
            let drawn = m.area_px2;
            assert!((drawn / expected - 1.0).abs() < 0.02, "{:?} channel {c}: {drawn} vs E R R T = {expected}", g.path);
        }
    }
    assert_eq!(tested, 6, "only {tested} ghosts fit the frame");
}

fn spike_count(rgba: &[f32], w: u32, centre: [f64; 2], radius: f64) -> (usize, Vec<f64>) {
    let samples = 3600;
    let value = |a: f64| {
        let (x, y) = (centre[0] + radius * a.cos(), centre[1] - radius * a.sin());
        at(rgba, w, x as u32, y as u32, 1) as f64
    };
    let v: Vec<f64> = (0..samples).map(|i| value(2.0 * std::f64::consts::PI * i as f64 / samples as f64)).collect();
    let mut sorted = v.clone();
    sorted.sort_by(f64::total_cmp);
    let threshold = 10.0 * sorted[samples / 2].max(1e-12);
    // Runs above the threshold, going round (a run across angle 0 counts once).
    let start = (0..samples).find(|&i| v[i] <= threshold).unwrap_or(0);
    let (mut runs, mut inside, mut first, mut centres) = (0, false, 0, Vec::new());
    for k in 0..samples {
        let i = (start + k) % samples;
        if v[i] > threshold && !inside {
            inside = true;
            first = k;
        } else if v[i] <= threshold && inside {
            inside = false;
            runs += 1;
            centres.push(((start + (first + k) / 2) % samples) as f64 * 360.0 / samples as f64);
        }
    }
    if inside {
        runs += 1;
        centres.push(((start + (first + samples) / 2) % samples) as f64 * 360.0 / samples as f64);
    }
    (runs, centres)
}

#[test]
fn starburst_has_n_spikes_for_even_blade_counts_2n_for_odd_and_its_energy() {
    // The default lens (no prescription: no ghosts), straight blades, no halo; a light of
    // 1e7 in the middle of 161 x 161 px, the spikes drawn out to 70 px. Around a circle of
    // 50 px the spikes stand out of the background: 10, 6 and 14 for 5, 6 and 7 blades, along
    // the blades' normals. The light in the frame is E lambda N L1 / (2 pi^2 A1) per spike
    // (src/optics/flare/starburst.rs) times (1/r0 - 1/70): exactly, per channel (0.1%).
    let default = LensFile::default_lens();
    for (blades, spikes) in [(5u32, 10usize), (6, 6), (7, 14)] {
        let light = FlareLight::white(80.5, 80.5, 1.0e7);
        let mut camera = flare_camera(&default, 4.0, "9x9", vec![light]);
        camera.aperture.blades = blades;
        camera.aperture.curvature = 0.0;
        camera.aperture.rotation_deg = 0.0;
        camera.flare.halo.fraction = 0.0;
        let frame = black(161, 161);
        let input = PlanInput::new(&frame, &camera);
        let model = FlareModel::new(&camera, input.facts.pixel_pitch_mm, frame.centre_px);
        let mut params = FlareParams::new(&input, &model, Some(&[]));
        params.constants.max_radius_px = 70.0;
        let rgba = render_with(&frame, &camera, params.clone());
        let (count, directions) = spike_count(&rgba, 161, [80.5, 80.5], 50.0);
        assert_eq!(count, spikes, "{blades} blades: spikes at {directions:?} degrees");
        // Each along a blade's normal: 90 + (k + 1/2) 360/n degrees (y up), or opposite.
        let sector = 360.0 / blades as f64;
        for d in &directions {
            let k = (d - 90.0 - 0.5 * sector) / (0.5 * sector);
            let off = (k - k.round()).abs() * 0.5 * sector;
            assert!(off < 0.6, "{blades} blades: a spike at {d} degrees is off the normals by {off}");
        }
        for c in 0..3 {
            let drawn: f64 = rgba.chunks_exact(4).map(|p| p[c] as f64).sum();
            let coef = model.starburst.spike_coefficient(channel_nm(c)) / input.facts.pixel_pitch_mm;
            let expected = light.energy[c] * 2.0 * blades as f64 * coef * (1.0 - 1.0 / 70.0);
            assert!((drawn / expected - 1.0).abs() < 1e-3, "{blades} blades, channel {c}: {drawn} vs {expected}");
        }
    }
}

#[test]
fn the_halo_and_a_round_apertures_glow_hold_their_share_and_the_light_keeps_its_energy() {
    // A light of 3x3 px of 2e4 in a black frame; the default lens with a round aperture and a
    // halo of 1% with rho = 1 mm (10 px: the 9.6 mm sensor over 96 px, 0.1 mm pixels). The
    // halo and the round diffraction glow drawn out to 40 px hold their formulas' shares (2%:
    // sampled at pixel centres), and the light gives up exactly what they hold: the frame's
    // energy is kept (0.1%).
    let default = LensFile::default_lens();
    let mut camera = flare_camera(&default, 2.8, "9.6x9.6", Vec::new());
    camera.aperture.blades = 0;
    camera.flare.halo.radius_mm = 1.0;
    let (w, h) = (96u32, 96u32);
    let mut frame = black(w, h);
    for y in 47..50 {
        for x in 47..50 {
            frame.color[((y * w + x) * 4) as usize..][..3].copy_from_slice(&[2.0e4, 2.0e4, 2.0e4]);
        }
    }
    let input = PlanInput::new(&frame, &camera);
    let pitch = input.facts.pixel_pitch_mm;
    assert!((pitch - 0.1).abs() < 1e-12);
    let model = FlareModel::new(&camera, pitch, frame.centre_px);
    let mut params = FlareParams::new(&input, &model, Some(&[]));
    params.constants.max_radius_px = 40.0;
    let rgba = render_with(&frame, &camera, params);
    let before = energy(&frame.color);
    let after = energy(&rgba);
    assert!((after / before - 1.0).abs() < 1e-3, "energy {after} vs {before}");
    // The light's share outside its own pixels, against the formulas from r0 = sqrt(9/pi).
    let r0 = (9.0f64 / std::f64::consts::PI).sqrt();
    for c in 0..3 {
        let outside: f64 = rgba
            .chunks_exact(4)
            .enumerate()
            .filter(|(i, _)| !((47..50).contains(&(*i as u32 % w)) && (47..50).contains(&(*i as u32 / w))))
            .map(|(_, p)| p[c] as f64)
            .sum();
        let lambda = channel_nm(c);
        let share = model.halo.fraction_between(r0 * pitch, 40.0 * pitch)
            + model.starburst.glow_fraction(lambda, r0 * pitch, 40.0 * pitch);
        let expected = 9.0 * 2.0e4 * share;
        assert!((outside / expected - 1.0).abs() < 0.02, "channel {c}: {outside} vs {expected}");
    }
}

#[test]
fn a_light_partly_hidden_flares_less() {
    // A 4x4 px light, then the same with half its pixels covered (a branch before the sun):
    // its halo, away from it, holds half the light (0.5%).
    let default = LensFile::default_lens();
    let mut camera = flare_camera(&default, 2.8, "9.6x9.6", Vec::new());
    camera.aperture.blades = 0;
    camera.flare.halo.radius_mm = 1.0;
    let (w, h) = (96u32, 96u32);
    let ring = |rgba: &[f32]| -> f64 {
        rgba.chunks_exact(4)
            .enumerate()
            .filter(|(i, _)| {
                let (x, y) = ((*i as u32 % w) as f64 - 48.0, (*i as u32 / w) as f64 - 48.0);
                (10.0..30.0).contains(&x.hypot(y))
            })
            .map(|(_, p)| p[1] as f64)
            .sum()
    };
    let mut halos = Vec::new();
    for hidden in [false, true] {
        let mut frame = black(w, h);
        for y in 46..50 {
            for x in 46..50 {
                if !(hidden && (x + y) % 2 == 0) {
                    frame.color[((y * w + x) * 4) as usize..][..3].copy_from_slice(&[5.0e4; 3]);
                }
            }
        }
        let (rgba, plan, _) = render(&gpu(), &frame, &camera);
        assert!(plan.runs("flare"), "{}", plan.explain());
        halos.push(ring(&rgba));
    }
    assert!((halos[1] / halos[0] - 0.5).abs() < 0.005, "{halos:?}");
}

#[test]
fn no_bright_light_records_no_flare_and_explain_says_how_bright_one_must_be() {
    // The Tessar on 36 mm at 64 px (0.56 mm pixels: most of a light's diffraction and halo
    // stays in its own pixel).
    let tessar = lens("tessar-walch-lens.toml");
    let camera = flare_camera(&tessar, 2.8, "36x20.25", Vec::new());
    // Every pixel at 1.5x saturation: below the threshold of 2.
    let frame = Frame::new(64, 36, vec![1.5; 64 * 36 * 4], vec![1.0e4; 64 * 36]);
    let p = plan(&frame, &camera);
    let explain = p.explain();
    assert!(!p.runs("flare"), "{explain}");
    assert!(explain.contains("[skip] flare         no pixel reaches 2 x saturation (scene value 2.0000) and no light is given: a light would need an energy (scene value x px) of"), "{explain}");
    assert!(explain.contains("to add 1/1000 of saturation"), "{explain}");
    // A light over the threshold but too dim for any element to show.
    let mut dim = frame.clone();
    dim.color[..3].copy_from_slice(&[2.1, 2.1, 2.1]);
    let p = plan(&dim, &camera);
    assert!(!p.runs("flare"), "{}", p.explain());
    assert!(
        p.explain().contains(
            "1 px from 2 x saturation (scene value 2.0000) hold at most 2.100e0 (scene value x px): a light needs"
        ),
        "{}",
        p.explain()
    );
    assert!(p.explain().contains("; invisible"), "{}", p.explain());
    // Bright enough: it runs, with the Tessar's ghosts.
    let mut bright = frame.clone();
    bright.color[..3].copy_from_slice(&[1.0e7, 1.0e7, 1.0e7]);
    let p = plan(&bright, &camera);
    assert!(p.runs("flare"), "{}", p.explain());
    assert!(p.explain().contains("of the prescription's 21 ghosts (two reflections, Walch eq 3.3)"), "{}", p.explain());
    // Turned off.
    let mut off = camera.clone();
    off.flare.enabled = false;
    assert!(plan(&bright, &off).explain().contains("[skip] flare         turned off (--no-flare)"));
}

#[test]
fn hard_inputs_stay_finite() {
    // NaN, Inf and 1e6 pixels; a light on the optical centre itself (every ghost centred there);
    // a light far outside the frame; the Tessar focused at its closest (the sensor moved back).
    let tessar = lens("tessar-walch-lens.toml");
    let lights = vec![FlareLight::white(40.0, 24.0, 1.0e9), FlareLight::white(-5000.0, 10.0, 1.0e12)];
    let mut camera = flare_camera(&tessar, 2.8, "36x20.25", lights);
    camera.lens = realcam::optics::ThinLens::new(camera.lens.focal_length_mm, 2.8, 1000.0).unwrap();
    let (w, h) = (80u32, 48u32);
    let mut frame = black(w, h);
    frame.color[0] = f32::NAN;
    frame.color[5] = f32::INFINITY;
    frame.color[8..11].copy_from_slice(&[1.0e6, 1.0e6, 1.0e6]);
    frame.color[((20 * w + 60) * 4) as usize..][..3].copy_from_slice(&[f32::NEG_INFINITY, 1.0e6, 0.0]);
    let p = plan(&frame, &camera);
    assert!(p.runs("flare"), "{}", p.explain());
    let (rgba, _) = render_plan(&gpu(), &frame, &p);
    assert!(rgba.iter().all(|v| v.is_finite()));
    assert!(rgba.iter().skip(4).step_by(4).any(|&v| v > 0.0), "no flare drawn");
}

#[test]
fn the_fitted_primitives_stand_beside_the_traced_ghosts_in_the_flare_report_with_their_gpu_time() {
    // Walch's loop closed with no camera: the Tessar at f/2.8 on a 320x180 frame, its ghost 4/0
    // in green traced with real rays (32 across per wavelength) with the light towards +x at
    // 2..5 degrees, fitted (ch. 7, sec. 7.3) and made parabolas of the angle (ch. 8), as
    // `realcam flare-fit` writes them. The report puts the light towards the upper right corner:
    // at 3 degrees the primitive, turned by eq 8.2's roll (29.4 degrees), keeps the traced
    // ghost's energy within 5% (measured 2.2%), its centroid within a fitted cell (45 px;
    // measured 31, the ghost is ~760 px wide) and its RMS size within 2% (0.2%), and has a GPU
    // time; at 7 degrees, outside the fitted range, the fitted model compares nothing and
    // draws nothing.
    use realcam::tools::accuracy_flare::{run, FlareAccuracyOptions};
    use realcam::tools::flare_fit::{fit_traced_ghosts, TracedFitOptions};
    let (w, h) = (320, 180);
    let camera = realcam::tools::bench_flare::flare_camera(w, h);
    let fit = TracedFitOptions {
        channels: vec![1],
        ghosts: vec![(4, 0)],
        ..TracedFitOptions::new(w, h, vec![2.0, 3.0, 4.0, 5.0])
    };
    let fitted: Vec<_> = fit_traced_ghosts(&camera, &fit, |_| {}).into_iter().map(|f| f.spec).collect();
    assert_eq!(fitted.len(), 1);
    let gpu = gpu();
    let options =
        FlareAccuracyOptions { width: w, height: h, angles_deg: vec![3.0, 7.0], rays_across: 32, runs: 1, fitted };
    let rows = run(&gpu, &camera, &options, |_| {}).expect("flare report");
    assert_validation_clean(&gpu);
    let models: Vec<_> = rows.iter().map(|r| (r.angle_deg, r.model.as_str())).collect();
    let names = ["traced reference", "matrix ghosts", "fitted primitives"];
    assert_eq!(models, names.iter().map(|n| (3.0, *n)).chain(names.iter().map(|n| (7.0, *n))).collect::<Vec<_>>());
    let at3 = &rows[2];
    let summary = format!("{at3:?}");
    assert_eq!((at3.compared, at3.disagree), (1, 0), "{summary}");
    assert_eq!(at3.worst.map(|g| (g.first, g.second)), Some((4, 0)));
    assert!(at3.energy_error.max < 0.05 && at3.centroid_error_px.max < 45.0, "{summary}");
    assert!(at3.size_error.max < 0.02, "{summary}");
    assert!(at3.gpu_ms.is_some_and(|ms| ms > 0.0), "{summary}");
    // The frames (in cells of 20 px): the primitive's against the traced rays' differs by
    // less than a black frame's 1 (measured 0.94: the ghost is ~760 px wide on the 320 px
    // frame, its wash barely shaped) and by more than the traced frame's own binning noise
    // (measured 0.26 with 32 rays across).
    let (noise, image) = (rows[0].image_error.unwrap_or(f64::NAN), at3.image_error.unwrap_or(f64::NAN));
    assert!(noise < image && image < 1.0, "noise {noise}, fitted {image}: {summary}");
    let at7 = &rows[5];
    assert_eq!((at7.compared, at7.disagree, at7.gpu_ms, at7.image_error), (0, 0, None, None), "{at7:?}");
    // The matrix ghosts compare every ghost the reference shows.
    assert!(rows[1].compared >= 60, "{:?}", rows[1]);
}

#[test]
fn sprites_past_one_list_are_shaded_in_batches_as_their_cpu_twin_does() {
    // 50 lights, each one bright pixel three tiles from the next (so each is its own light),
    // through the Tessar with room for 64: 50 x 22 sprite slots, more than ghost_sprites lists at
    // once (SPRITE_LIST per kind), so its pipeline lists and shades them in batches, the lights
    // after the 46th in the second. Every dispatch matches its CPU twin, and the last light's
    // glow is drawn (its pixel's neighbour brighter than a pixel between lights).
    let tessar = lens("tessar-walch-lens.toml");
    let (w, h, step) = (480u32, 240u32, 48u32);
    let mut frame = black(w, h);
    let spots: Vec<(u32, u32)> = (0..5).flat_map(|j| (0..10).map(move |i| (24 + step * i, 24 + step * j))).collect();
    for &(x, y) in &spots {
        frame.color[((y * w + x) * 4) as usize..][..3].copy_from_slice(&[1.0e4; 3]);
    }
    let camera = flare_camera(&tessar, 8.0, "36x18", vec![]);
    let input = PlanInput::new(&frame, &camera);
    let model = FlareModel::new(&camera, input.facts.pixel_pitch_mm, frame.centre_px);
    let mut params = FlareParams::new(&input, &model, None);
    params.max_lights = 64;
    let slots = params.constants.slots_per_light as u32;
    assert!(spots.len() as u32 * slots > SPRITE_LIST && 46 * slots <= SPRITE_LIST + slots, "{slots} slots a light");
    let kinds = ghost_sprites::specialization(&params.constants, bins::words_per_tile(params.sprite_slots()));
    assert_eq!(kinds[4], 1, "the batched pipeline: {kinds:?}");
    let gpu = gpu();
    let mut p = plan(&frame, &camera);
    p.force::<Flare>(params);
    let renderer = Renderer::new(&gpu, &p).expect("pipelines");
    let (rendered, checks) = renderer.render_with_twin_checks(&frame, &p).expect("render");
    let rgba = rendered.rgba;
    assert_validation_clean(&gpu);
    // The flare's dispatches (the lens's other passes have their own twin cases).
    let steps = [tiles::NAME, lights::NAME, bins::NAME, ghost_sprites::NAME];
    let flare: Vec<_> = checks.iter().filter(|c| steps.contains(&c.shader)).collect();
    assert!(flare.iter().any(|c| c.shader == ghost_sprites::NAME), "ghost_sprites was not checked");
    let failures: Vec<String> = flare.iter().filter_map(|c| c.result.as_ref().err().map(|e| e.to_string())).collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let (x, y) = *spots.last().unwrap();
    let at = |x: u32, y: u32| rgba[((y * w + x) * 4) as usize..][..3].iter().sum::<f32>();
    assert!(at(x + 2, y) > at(x - step / 2, y) && at(x + 2, y) > 0.0, "{} {}", at(x + 2, y), at(x - step / 2, y));
}

#[test]
fn a_light_the_depth_of_field_spreads_below_the_threshold_draws_nothing_and_the_frame_is_left_as_it_is() {
    // One pixel of 50 (the threshold is 2) a metre away with the focus at 10 km: the plan reads
    // the input and runs the flare, but the depth of field spreads the pixel over a disc of
    // about 9 px, so on the GPU no pixel is a light: flare_lights asks the sprite kernel (which
    // adds to the colour in place) for no group, and the frame is the one without flare, bit
    // for bit. The same pixel at 1e5 stays a light: a group for every tile, and the flare drawn.
    let default = LensFile::default_lens();
    let camera = flare_camera(&default, 2.0, "9.6x5.4", Vec::new());
    let (w, h) = (64u32, 36u32);
    let tiles = [w.div_ceil(16), h.div_ceil(16), 1];
    let mut no_flare = camera.clone();
    no_flare.flare.enabled = false;
    let gpu = gpu();
    for (value, lit) in [(50.0f32, false), (1.0e5, true)] {
        let mut frame = Frame::new(w, h, vec![0.05; (w * h * 4) as usize], vec![1.0; (w * h) as usize]);
        frame.color[((18 * w + 32) * 4) as usize..][..3].copy_from_slice(&[value; 3]);
        let p = plan(&frame, &camera);
        assert!(p.runs("flare") && p.runs("bokeh_tiled"), "{}", p.explain());
        let renderer = Renderer::new(&gpu, &p).expect("pipelines");
        let (rendered, checks) = renderer.render_with_twin_checks(&frame, &p).expect("render");
        assert_validation_clean(&gpu);
        let groups = |pass: &str| {
            let c = checks.iter().find(|c| c.pass == pass).unwrap_or_else(|| panic!("no dispatch in {pass}"));
            assert!(c.result.is_ok(), "{pass}: {:?}", c.result);
            c.groups
        };
        assert_eq!(groups(ghost_sprites::NAME), if lit { tiles } else { [0, 1, 1] }, "value {value}");
        let (without, _, _) = render(&gpu, &frame, &no_flare);
        let same = rendered.rgba.iter().zip(&without).all(|(a, b)| a.to_bits() == b.to_bits());
        assert_eq!(same, !lit, "value {value}: the frame with flare equals the one without");
    }
}

#[test]
fn a_defocused_lights_starburst_is_spread_by_its_disc_and_an_in_focus_light_keeps_its_star() {
    // Issue 29: the star is the image of a point in focus; a point out of focus images as the
    // star convolved with its CoC disc, so along each spike the pixels on its centre line hold
    // spike_share(A) of the light a one-pixel light puts there, A the disc's area
    // (src/optics/flare/starburst.rs). A light of 1e7 in the middle of 161 x 161 px, 6 straight
    // blades, no halo (spikes only); the focus at 10 km. In focus (the frame at 10 km) the light
    // is one pixel and keeps its whole star; the frame at 0.5 m defocuses it to a disc of about
    // 22 px (eq 5.3), and the flare's spikes beyond the disc carry spike_share(A) of the in-focus
    // light's there, A the pixels of the disc over the flare threshold (counted on the depth of
    // field's output): about 6%.
    let default = LensFile::default_lens();
    let mut camera = flare_camera(&default, 4.0, "9x9", Vec::new());
    camera.aperture.blades = 6;
    camera.aperture.curvature = 0.0;
    camera.aperture.rotation_deg = 0.0;
    camera.flare.halo.fraction = 0.0;
    let (w, h) = (161u32, 161u32);
    let gpu = gpu();
    let frame_at = |depth_m: f32| {
        let mut frame = Frame::new(w, h, vec![0.0; (w * h * 4) as usize], vec![depth_m; (w * h) as usize]);
        frame.color[((80 * w + 80) * 4) as usize..][..3].copy_from_slice(&[1.0e7; 3]);
        frame
    };
    let pitch = camera.pixel_pitch_mm(w, h);
    let disc_px = camera.lens.coc_mm(500.0).abs() / pitch;
    assert!((15.0..30.0).contains(&disc_px), "{disc_px} px");
    let r_out = 0.5 * disc_px + 3.0;
    // The flare alone (the render with it less the render without it), outside r_out.
    let mut flare_outside = Vec::new();
    let mut lit_area = Vec::new();
    for depth_m in [1.0e4f32, 0.5] {
        let frame = frame_at(depth_m);
        let p = plan(&frame, &camera);
        assert!(p.runs("flare"), "{}", p.explain());
        assert_eq!(p.runs("bokeh_tiled"), depth_m < 1.0, "{}", p.explain());
        let (with, _) = render_plan(&gpu, &frame, &p);
        let mut without_plan = plan(&frame, &camera);
        without_plan.skip::<Flare>();
        let (without, _) = render_plan(&gpu, &frame, &without_plan);
        let threshold = camera.flare.threshold / camera.exposure_gain();
        lit_area.push(without.chunks_exact(4).filter(|p| p[..3].iter().any(|&v| v as f64 >= threshold)).count());
        let outside: f64 = (0..(w * h) as usize)
            .filter(|i| ((i % w as usize) as f64 - 80.0).hypot((i / w as usize) as f64 - 80.0) > r_out)
            .map(|i| (0..3).map(|c| (with[4 * i + c] - without[4 * i + c]) as f64).sum::<f64>())
            .sum();
        flare_outside.push(outside);
    }
    use realcam::optics::flare::starburst::spike_share;
    let disc_area = std::f64::consts::PI * disc_px * disc_px / 4.0;
    let expected = spike_share(lit_area[1] as f64);
    let measured = flare_outside[1] / flare_outside[0];
    println!(
        "disc {disc_px:.2} px: lit {} px (pi D^2/4 = {disc_area:.0}); spikes outside {r_out:.1} px: {:.4e} in focus, \
         {:.4e} defocused, ratio {measured:.4}, spike_share {expected:.4}",
        lit_area[1], flare_outside[0], flare_outside[1]
    );
    assert_eq!(lit_area[0], 1, "in focus the light is one pixel");
    assert!(flare_outside[0] > 0.0);
    assert!((lit_area[1] as f64 / disc_area - 1.0).abs() < 0.2, "lit {} px, disc {disc_area:.0} px", lit_area[1]);
    assert!((measured / expected - 1.0).abs() < 0.03, "ratio {measured} vs spike_share {expected}");
    assert!((measured / spike_share(disc_area) - 1.0).abs() < 0.1, "ratio {measured} vs the disc's share");
    // The in-focus light keeps its whole star: share 1, the spikes as drawn before.
    assert_eq!(spike_share(lit_area[0] as f64), 1.0);
}
