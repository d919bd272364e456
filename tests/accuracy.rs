//! The accuracy report on a tiny scene: finite numbers everywhere, zero error for the reference
//! against itself, and the exact settings of the fast path agreeing with the geometric gather.

mod support;

use realcam::model::camera::{BokehMode, FilmMode};
use realcam::model::frame::Frame;
use support::*;

#[test]
fn accuracy_report_on_a_tiny_scene() {
    let gpu = gpu();
    let (w, h) = (48u32, 32u32);
    let mut color = Vec::new();
    let mut depth = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let checker = if ((x / 4) + (y / 4)) % 2 == 0 { 0.7 } else { 0.2 };
            let highlight = if (x, y) == (12, 10) || (x, y) == (34, 20) { 40.0 } else { 0.0 };
            color.extend([checker + highlight, 0.5 * checker + highlight, 0.3 + highlight, 1.0]);
            depth.push(if x < w / 2 { 0.9 } else { 6.0 });
        }
    }
    let frame = Frame::new(w, h, color, depth);
    let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
    camera.film = FilmMode::Linear;
    camera.bokeh = BokehMode::Reference;
    let results = realcam::tools::accuracy::run(&gpu, &frame, &camera, |_| ()).expect("accuracy run");
    assert_validation_clean(&gpu);
    assert_eq!(results.len(), 8);
    let reference = &results[0];
    assert!(reference.method.starts_with("diffraction"));
    assert_eq!(reference.error.rmse, 0.0);
    assert_eq!(reference.error.relative_energy_error, 0.0);
    assert_eq!(reference.flip_mean, 0.0);
    for r in &results {
        let numbers = [r.dof_ms, r.error.rmse, r.error.rmse_display, r.error.relative_energy_error, r.flip_mean];
        assert!(numbers.iter().all(|v| v.is_finite() && *v > -1.0), "{}: {numbers:?}", r.method);
        assert!(r.dof_ms > 0.0, "{}: no GPU time", r.method);
        assert!(r.flip_mean >= 0.0 && r.flip_mean <= 1.0);
    }
    // The other methods differ from the diffraction reference, but not wildly: same blur sizes.
    for r in &results[1..] {
        assert!(r.error.rmse > 0.0 && r.error.rmse_display < 0.1, "{}: {:?}", r.method, r.error);
    }
    // The local fidelity is against `--bokeh reference`: none of its own tiles off, FLIP 0,
    // alpha 1 everywhere (the input's is); every method's numbers in range.
    assert_eq!(geometric_local(&results).tiles.tiles_off, 0);
    assert_eq!(geometric_local(&results).flip_mean, 0.0);
    assert_eq!(geometric_local(&results).tiles.tiles, 6);
    for r in &results {
        let l = &r.local;
        assert!(l.tiles.tiles_off <= l.tiles.tiles && (0.0..=1.0).contains(&l.flip_mean), "{}: {l:?}", r.method);
        assert_eq!(l.alpha.opaque_in, (w * h) as usize);
    }
    // The fast path with its exact gather up to a radius of 8 px is the geometric gather (every
    // CoC radius is below 8 px here).
    let geometric = &results[1];
    let exact_tiled = results.iter().find(|r| r.method.contains("exact up to 8 px")).unwrap();
    assert!(
        (geometric.error.rmse - exact_tiled.error.rmse).abs() < 1e-4,
        "{:?} vs {:?}",
        geometric.error,
        exact_tiled.error
    );
    let md = realcam::tools::accuracy::markdown("test device", "cmd", &results);
    let csv = realcam::tools::accuracy::csv(&results);
    let svg = realcam::tools::accuracy::svg("test device", &results);
    for r in &results {
        assert!(md.contains(&r.method) && csv.contains(&r.method) && svg.contains(&r.method));
    }
    assert_eq!(csv.lines().count(), 9);
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(md.contains("tiles off > 5%"));
}

fn geometric_local(results: &[realcam::tools::accuracy::MethodResult]) -> realcam::tools::metrics::LocalFidelity {
    results.iter().find(|r| r.method == realcam::tools::accuracy::GEOMETRIC).expect("the geometric gather").local
}
