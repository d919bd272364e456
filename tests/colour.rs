//! Colour spaces on the GPU (issue 16, part 1): a frame stored in ACEScg and the same frame
//! converted to linear Rec.709 render to the same light, because every luminance the passes
//! compare is taken with the frame's own weights (the Y row of its RGB to XYZ matrix).

mod support;

use realcam::model::frame::Frame;
use realcam::optics::colour::{mul_vec, Chromaticities};
use realcam::pipeline::planner::plan;
use realcam::tools::synth::{SynthHighlight, SynthPlane, SynthScene};

/// A textured plane at 8 m with coloured highlights, far out of focus (CoC about 11 px at f/2
/// focused at 1 m on 0.1 mm pixels): the tiled path draws the highlights as sprites, whose
/// threshold and background compare luminance.
fn scene() -> SynthScene {
    let (w, h) = (96, 64);
    let hl = |x, y, rgb| SynthHighlight { x, y, depth_m: 8.0, rgb };
    SynthScene {
        width: w,
        height: h,
        background_depth_m: 8.0,
        background_rgb: [0.1, 0.1, 0.1],
        planes: vec![SynthPlane::flat(0, 0, w, h, 8.0, [0.18, 0.12, 0.05]).checker(6, [0.04, 0.1, 0.2])],
        // A saturated blue one weighs 0.0537 in AP1's luminance and 0.0722 in Rec.709's.
        highlights: vec![
            hl(20, 20, [0.2, 0.2, 40.0]),
            hl(60, 18, [30.0, 2.0, 0.5]),
            hl(40, 44, [3.0, 25.0, 3.0]),
            hl(78, 46, [6.0, 6.0, 6.0]),
        ],
    }
}

/// `rgba`'s colours through `m` (alpha kept).
fn convert(rgba: &[f32], m: &[[f64; 3]; 3]) -> Vec<f32> {
    rgba.chunks_exact(4)
        .flat_map(|px| {
            let c = mul_vec(m, [px[0], px[1], px[2]].map(f64::from)).map(|v| v as f32);
            [c[0], c[1], c[2], px[3]]
        })
        .collect()
}

/// The largest difference of `a` and `b` relative to max(1, |b|).
fn worst(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(x, y)| f64::from((x - y).abs()) / f64::from(y.abs()).max(1.0)).fold(0.0, f64::max)
}

#[test]
fn an_acescg_frame_and_its_rec709_conversion_render_the_same_light() {
    let gpu = support::gpu();
    let camera = support::dof_camera(50.0, 2.0, 1.0, 6);
    let (color, depth) = scene().render();
    let (w, h) = (color.width, color.height);
    // The scene's values are ACEScg; the same light in linear Rec.709 (same XYZ).
    let ap1_to_709 = Chromaticities::ACES_AP1.rgb_to(&Chromaticities::REC709);
    let ap1 =
        Frame { working_space: Chromaticities::ACES_AP1, ..Frame::new(w, h, color.data.clone(), depth.data.clone()) };
    let rec709 = Frame {
        working_space: Chromaticities::REC709,
        ..Frame::new(w, h, convert(&color.data, &ap1_to_709), depth.data)
    };

    let (out_ap1, plan_ap1, _) = support::render(&gpu, &ap1, &camera);
    let (out_709, _, _) = support::render(&gpu, &rec709, &camera);
    assert!(plan_ap1.explain().contains("[run ] bokeh_tiled"), "{}", plan_ap1.explain());
    let converted = convert(&out_ap1, &ap1_to_709);
    let error = worst(&converted, &out_709);
    assert!(error <= 1e-4, "ACEScg rendered and converted differs from Rec.709 rendered by {error:.2e}");
    // The light moved: the highlights became discs (the centre pixel lost most of its light).
    let centre = |rgba: &[f32]| rgba[(20 * w as usize + 20) * 4 + 2];
    assert!(centre(&out_ap1) < 0.2 * 40.0, "blue highlight kept {}", centre(&out_ap1));

    // Compared with Rec.709's weights (the ACEScg values read as if they were Rec.709), the
    // sprites take another share of the highlights: more than 1e-3 apart.
    let misread = Frame { working_space: Chromaticities::REC709, ..ap1.clone() };
    let tiled = plan(&misread, &camera);
    let (out_misread, _) = support::render_plan(&gpu, &misread, &tiled);
    let error = worst(&convert(&out_misread, &ap1_to_709), &out_709);
    assert!(error > 1e-3, "the weights made no difference ({error:.2e}): the test does not reach the sprites");
}

/// The chromatic effects take the working space's channel wavelengths (the primaries' dominant
/// wavelengths, src/optics/wavelengths.rs): a lens with longitudinal colour (red, the C line,
/// 0.4 mm behind green; blue, the F line, 0.3 mm in front) offsets an ACEScg frame's red and
/// blue CoC by its values at 628.8 / 533.0 / 467.2 nm and a Rec.709 frame's at 611.4 / 549.1 /
/// 464.2 nm; the diffraction patterns are computed at the same wavelengths.
#[test]
fn the_chromatic_effects_take_the_working_spaces_wavelengths() {
    let mut camera = support::dof_camera(50.0, 2.0, 1.0, 6);
    camera.longitudinal_color_mm = Some([0.4, -0.3]);
    let (color, depth) = scene().render();
    let frame = |space| Frame {
        working_space: space,
        ..Frame::new(color.width, color.height, color.data.clone(), depth.data.clone())
    };
    for (space, nm, line) in [
        (Chromaticities::ACES_AP1, [628.8, 533.0, 467.2], "(at 629/533/467 nm)"),
        (Chromaticities::REC709, [611.4, 549.1, 464.2], "(at 611/549/464 nm)"),
    ] {
        let frame = frame(space);
        let got = frame.channel_wavelengths_nm();
        assert!((0..3).all(|c| (got[c] - nm[c]).abs() < 0.06), "{got:?}");
        let planned = plan(&frame, &camera);
        assert!(planned.explain().contains(line), "{}", planned.explain());
        let pitch_mm = planned.facts.pixel_pitch_mm;
        let want = camera.longitudinal_color_coc_px(pitch_mm, got).unwrap();
        let offsets = planned.facts.channel_offsets_px.unwrap();
        assert_eq!(offsets, want);
        camera.bokeh = realcam::model::camera::BokehMode::Diffraction;
        // A small frame in focus keeps the diffraction tables small.
        let small = Frame { working_space: space, ..Frame::new(8, 8, vec![0.1; 256], vec![1.0; 64]) };
        let diffraction = plan(&small, &camera).explain();
        camera.bokeh = realcam::model::camera::BokehMode::Tiled;
        assert!(diffraction.contains(&format!("at {}", &line[4..15])), "{diffraction}");
    }
}
