//! The `ocio` crate (a pure-Rust port of OpenColorIO, issue 16 part 1) against OpenColorIO's own
//! processor: PyOpenColorIO 2.6.0's numbers for the ACES cg config v4.0.0, computed once by
//! `scripts/ocio-reference.py` and copied here. And realcam's own primaries with the Bradford
//! adaptation against the same numbers.

// The reference numbers as the script printed them (7 decimals, more than an f32 holds).
#![allow(clippy::excessive_precision)]

mod support;

use realcam::io::colour_config::ColourConfig;
use realcam::optics::colour::{mul_vec, Chromaticities};
use realcam::pipeline::render::preview_rgba;

const CONFIG: &str = "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5";

/// ACEScg to "Linear Rec.709 (sRGB)" (PyOpenColorIO 2.6.0, scripts/ocio-reference.py).
const TO_REC709: [([f32; 3], [f32; 3]); 7] = [
    ([0.18, 0.18, 0.18], [0.1800000, 0.1800000, 0.1800000]),
    ([1.00, 0.00, 0.00], [1.7050509, -0.1302564, -0.0240034]),
    ([0.00, 1.00, 0.00], [-0.6217921, 1.1408048, -0.1289690]),
    ([0.00, 0.00, 1.00], [-0.0832589, -0.0105483, 1.1529723]),
    ([1.00, 1.00, 1.00], [1.0000000, 1.0000000, 1.0000000]),
    ([0.50, 0.25, 0.10], [0.6887516, 0.2190181, 0.0710533]),
    ([4.00, 2.00, 1.00], [5.4933605, 1.7500355, 0.7990210]),
];

/// ACEScg through the "sRGB - Display" display's "ACES 2.0 - SDR 100 nits (Rec.709)" view
/// (PyOpenColorIO 2.6.0, scripts/ocio-reference.py): sRGB-encoded display values.
const SRGB_ACES2_VIEW: [([f32; 3], [f32; 3]); 7] = [
    ([0.18, 0.18, 0.18], [0.3491874, 0.3491881, 0.3491878]),
    ([1.00, 0.00, 0.00], [0.8771549, 0.0000000, 0.0402514]),
    ([0.00, 1.00, 0.00], [0.0000000, 0.7144405, 0.2748624]),
    ([0.00, 0.00, 1.00], [0.0000000, 0.2105445, 0.6467322]),
    ([1.00, 1.00, 1.00], [0.7066830, 0.7066836, 0.7066833]),
    ([0.50, 0.25, 0.10], [0.6656523, 0.3968449, 0.2320423]),
    ([4.00, 2.00, 1.00], [0.9948077, 0.8136207, 0.7361635]),
];

fn max_diff(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f32::max)
}

fn check(proc: &ocio::CpuProcessor, table: &[([f32; 3], [f32; 3])], tolerance: f32) {
    for &(input, want) in table {
        let mut rgb = input;
        proc.apply_rgb(&mut rgb);
        let d = max_diff(rgb, want);
        assert!(d <= tolerance, "{input:?}: ocio crate {rgb:?}, OpenColorIO {want:?} (off by {d:e})");
    }
}

#[test]
fn the_crates_colour_space_conversion_is_opencolorios() {
    let config = ocio::Config::create_from_file(CONFIG).expect("the built-in ACES cg config");
    let proc = config.get_processor("ACEScg", "Linear Rec.709 (sRGB)").expect("ACEScg to Rec.709");
    check(&proc.default_cpu_processor(), &TO_REC709, 1e-6);
}

#[test]
fn the_crates_aces_display_view_is_opencolorios() {
    let config = ocio::Config::create_from_file(CONFIG).expect("the built-in ACES cg config");
    let proc = config
        .get_display_view_processor("ACEScg", "sRGB - Display", "ACES 2.0 - SDR 100 nits (Rec.709)")
        .expect("the sRGB display's ACES 2.0 view");
    check(&proc.default_cpu_processor(), &SRGB_ACES2_VIEW, 1e-5);
}

/// OpenColorIO's ACES configs adapt the ACES white (about D60) to D65 by Bradford: realcam's AP1
/// and Rec.709 primaries with `rgb_to_adapted` give its matrix. Keeping XYZ instead
/// (`rgb_to`, what realcam's Rec.709 preview does today) leaves ACES's white warm.
#[test]
fn bradford_from_the_primaries_gives_the_aces_configs_matrix() {
    let adapted = Chromaticities::ACES_AP1.rgb_to_adapted(&Chromaticities::REC709);
    for &(input, want) in &TO_REC709 {
        let got = mul_vec(&adapted, input.map(f64::from)).map(|v| v as f32);
        let d = max_diff(got, want);
        assert!(d <= 2e-4 * want.iter().fold(1.0f32, |m, v| m.max(v.abs())), "{input:?}: {got:?} vs {want:?}");
    }
    let kept_xyz = mul_vec(&Chromaticities::ACES_AP1.rgb_to(&Chromaticities::REC709), [1.0; 3]);
    assert!(kept_xyz[0] > 1.02 && kept_xyz[2] < 0.95, "ACES white kept as XYZ in Rec.709: {kept_xyz:?}");
    let same_white = Chromaticities::REC2020.rgb_to_adapted(&Chromaticities::REC709);
    let plain = Chromaticities::REC2020.rgb_to(&Chromaticities::REC709);
    for i in 0..3 {
        for j in 0..3 {
            assert!((same_white[i][j] - plain[i][j]).abs() < 1e-12);
        }
    }
}

/// The PNG preview through the config's default display and view (the sRGB display's ACES 2.0
/// output transform) gives OpenColorIO's display values of the seven ACEScg colours; HDR, NaN,
/// infinite and negative values come out as finite display values, in [0, 1] within 1e-5 (the
/// PNG clamps).
#[test]
fn the_preview_through_the_configs_view_is_opencolorios() {
    let config = ColourConfig::load(CONFIG).unwrap();
    let view = config.display_view("ACEScg", None, None).unwrap();
    let camera = support::dof_camera(50.0, 2.0, 3.0, 0);
    let rgba: Vec<f32> = SRGB_ACES2_VIEW.iter().flat_map(|(rgb, _)| [rgb[0], rgb[1], rgb[2], 1.0]).collect();
    let preview = preview_rgba(&camera, &Chromaticities::ACES_AP1, &rgba, 7, Some(&view));
    for (px, (input, want)) in preview.chunks_exact(4).zip(SRGB_ACES2_VIEW) {
        let d = max_diff([px[0], px[1], px[2]], want);
        assert!(d <= 1e-5, "{input:?}: preview {px:?}, OpenColorIO {want:?}");
    }
    // A frame large enough to be split over the cores: every pixel as alone.
    let large: Vec<f32> = rgba.iter().copied().cycle().take(4 * 7 * 5000).collect();
    let split = preview_rgba(&camera, &Chromaticities::ACES_AP1, &large, 7, Some(&view));
    assert!(split.chunks_exact(28).all(|row| row == preview.as_slice()));
    let hard = [1e6, 1e6, 1e6, 1.0, f32::NAN, 0.2, 0.2, 1.0, f32::INFINITY, 0.0, 0.0, 1.0, -1.0, 0.5, 0.5, 1.0];
    let preview = preview_rgba(&camera, &Chromaticities::ACES_AP1, &hard, 4, Some(&view));
    for px in preview.chunks_exact(4) {
        assert!(px[..3].iter().all(|v| (-1e-5..=1.0 + 1e-5).contains(v)), "{px:?}");
    }
}

/// Without a config the preview converts to Rec.709 with the white adapted by Bradford, as
/// OpenColorIO does: through the linear film it is the config's "Un-tone-mapped" view (the
/// conversion and the sRGB curve) within 1e-5 for colours inside Rec.709.
#[test]
fn the_preview_without_a_config_is_the_untone_mapped_view() {
    let config = ColourConfig::load(CONFIG).unwrap();
    let view = config.display_view("ACEScg", Some("sRGB - Display"), Some("Un-tone-mapped")).unwrap();
    let camera = support::dof_camera(50.0, 2.0, 3.0, 0);
    let rgba = [0.18, 0.18, 0.18, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5, 0.25, 0.1, 1.0, 0.3, 0.3, 0.5, 1.0];
    let ours = preview_rgba(&camera, &Chromaticities::ACES_AP1, &rgba, 4, None);
    let theirs = preview_rgba(&camera, &Chromaticities::ACES_AP1, &rgba, 4, Some(&view));
    for (a, b) in ours.chunks_exact(4).zip(theirs.chunks_exact(4)) {
        assert!(max_diff([a[0], a[1], a[2]], [b[0], b[1], b[2]]) <= 1e-5, "{a:?} vs OpenColorIO {b:?}");
    }
    // ACES's white shows white (kept as XYZ it would be warm: 1.0, 0.99, 0.93 or so).
    assert!(ours[4..7].iter().all(|v| (v - 1.0).abs() < 1e-5), "{:?}", &ours[4..7]);
}
