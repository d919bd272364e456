//! Issue 32 item 4: Walch 2017 ch. 9's occurrence estimators over a grid or a path of lights
//! (`realcam flare-predict --grid/--path`), with sec. 9.2's statistics and bins. The ghost is
//! a box whose light can be counted by hand: 10 x 6 px of light 2 in one channel (2/3 on the
//! mean of three channels), edges on pixel borders, its centre at x = 10 + 1 px per degree of
//! the light's angle (fitted 0..30 degrees, clamped beyond), turned by the light's roll about
//! the centre (20, 10) of a 40 x 20 frame. No GPU is needed.

use realcam::io::lens_file::FittedGhostSpec;
use realcam::optics::ghost_prediction::ExposureSetting;
use realcam::tools::flare_predict::range::{predict_range, Estimator, Range, RangeError, RangeRequest};
use realcam::tools::flare_predict::{predict, report, PredictError, PredictRequest};
use std::path::PathBuf;
use std::process::Command;

fn box_ghost() -> FittedGhostSpec {
    realcam::tools::flare_predict::box_ghost(1)
}

fn base() -> PredictRequest {
    let s = ExposureSetting {
        f_number: 4.0,
        iso: 100.0,
        exposure_time_s: 0.01,
        luminance_cd_m2: 1.0e4,
        solid_angle_sr: 1.0e-5,
    };
    PredictRequest { light_view: [0.0, 0.0, -1.0], scene: s, measured: s, scene_max: 1.0, scene_min: 0.0 }
}

/// The field of view whose half has a tangent of 1.5: a 3-column grid's side cells then look
/// at x = -1 and +1 (45 degrees), a 3-row one's top and bottom at y = +0.5 and -0.5.
fn fov_deg() -> f64 {
    2.0 * 1.5f64.atan().to_degrees()
}

fn request(range: Range, estimator: Estimator, threshold: Option<f64>) -> RangeRequest {
    RangeRequest { range, base: base(), estimator, threshold, bins: 5, sample_px: 1 }
}

/// Eq 9.3 with I_max 1, I_min 0 and the flare's average `sum` / 800 px.
fn ratio(sum: f64) -> f64 {
    1.0 / (1.0 + 2.0 * sum / 800.0)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1.0)
}

#[test]
fn a_row_of_three_lights_against_hand_values() {
    // Left (45 deg, clamped to 30, roll 180): the box turned to x -5..5, 30 px in; ahead (0
    // deg): x 5..15, all 60 px; right (30, roll 0): x 35..45, 30 px. Sums 20, 40, 20.
    let range = Range::Grid { cols: 3, rows: 1, fov_deg: fov_deg() };
    let r = predict_range(&[box_ghost()], &request(range, Estimator::ContrastRatio, None)).unwrap();
    assert_eq!(r.positions.len(), 3);
    let sums = [20.0, 40.0, 20.0];
    let rolls = [180.0, 0.0, 0.0];
    for (i, p) in r.positions.iter().enumerate() {
        let (q, e) = (&p.prediction, &p.prediction.estimators);
        assert_eq!(p.light.cell, [i as u32, 0]);
        assert!(close(p.light.frame_px.unwrap()[0], (i as f64 + 0.5) * 40.0 / 3.0));
        assert!(close(q.angle_deg, if i == 1 { 0.0 } else { 45.0 }), "{i}: {}", q.angle_deg);
        assert!(close(q.roll_deg, rolls[i]), "{i}: roll {}", q.roll_deg);
        assert_eq!(e.min, 0.0);
        assert!(close(e.max, 2.0 / 3.0) && close(e.sum, sums[i]) && close(e.average, sums[i] / 800.0), "{e:?}");
        assert!(close(q.contrast_ratio, ratio(sums[i])) && close(p.value, ratio(sums[i])));
    }
    // Sec. 9.2: the extremes and where they lie, the mean.
    let c = r.chosen();
    assert!(close(c.min, ratio(40.0)) && close(c.max, ratio(20.0)));
    assert_eq!((c.at_min, c.at_max), (1, 0));
    assert!(close(c.mean, (2.0 * ratio(20.0) + ratio(40.0)) / 3.0));
    let sum = r.statistics.iter().find(|s| s.estimator == Estimator::Sum).unwrap();
    assert!(close(sum.min, 20.0) && close(sum.max, 40.0) && close(sum.mean, 80.0 / 3.0));
    // Five bins from 1/1.1 to 1/1.05: the ahead light in the first, the side ones in the last.
    assert_eq!(r.bins.counts, vec![1, 0, 0, 0, 2]);
    assert_eq!(r.positions.iter().map(|p| p.bin).collect::<Vec<_>>(), vec![4, 0, 4]);
    // The default threshold, a contrast lost by 5% (0.95): 1/1.1 = 0.909 reaches it,
    // 1/1.05 = 0.952 not. At 0.96 all three do.
    assert_eq!((r.threshold, r.reaching), (Some(0.95), 1));
    assert!(close(r.share(), 1.0 / 3.0));
    let all = predict_range(&[box_ghost()], &request(range, Estimator::ContrastRatio, Some(0.96))).unwrap();
    assert_eq!(all.reaching, 3);
    // The average rises with the flare: at or above 0.049 only ahead (0.05, the sides 0.025);
    // the sum has no default.
    let avg = predict_range(&[box_ghost()], &request(range, Estimator::Average, Some(0.049))).unwrap();
    assert_eq!(avg.positions.iter().map(|p| p.reaches).collect::<Vec<_>>(), vec![false, true, false]);
    let sum = predict_range(&[box_ghost()], &request(range, Estimator::Sum, None)).unwrap();
    assert_eq!((sum.threshold, sum.reaching), (None, 0));
    assert!(report::text(&sum).contains("no --threshold for sum: no share reported"));
    // Every second pixel (pixels 1, 3, 5, ... across and down): the box ahead covers columns
    // 5..14 and rows 7..12, sampled at 5 of 20 columns and 3 of 10 rows, 15 of 200 samples of
    // 2/3: average 0.05 and sum 0.05 x 800 = 40, as every pixel gives.
    let sampled = RangeRequest { sample_px: 2, ..request(range, Estimator::Sum, None) };
    let s = predict_range(&[box_ghost()], &sampled).unwrap();
    let ahead = s.positions[1].prediction.estimators;
    assert!(close(ahead.sum, 40.0) && close(ahead.average, 0.05) && close(ahead.max, 2.0 / 3.0), "{ahead:?}");
    let zero = RangeRequest { sample_px: 0, ..sampled };
    assert_eq!(predict_range(&[box_ghost()], &zero), Err(RangeError::SamplePx(0)));
}

#[test]
fn a_three_by_three_grid_is_hand_counted_on_its_axes_and_symmetric_in_its_corners() {
    let range = Range::Grid { cols: 3, rows: 3, fov_deg: fov_deg() };
    let r = predict_range(&[box_ghost()], &request(range, Estimator::Sum, Some(30.0))).unwrap();
    assert_eq!(r.positions.len(), 9);
    let sum = |c: u32, row: u32| r.positions[(row * 3 + c) as usize].prediction.estimators.sum;
    // Top and bottom middle: 26.6 deg, roll +-90: the box turned to x 17..23 and y above or
    // below the frame: no flare. The middle row as the row of three.
    assert_eq!((sum(1, 0), sum(1, 2)), (0.0, 0.0));
    assert!((r.positions[1].prediction.roll_deg - 90.0).abs() < 1e-9);
    assert!(close(sum(0, 1), 20.0) && close(sum(1, 1), 40.0) && close(sum(2, 1), 20.0));
    // The corners (30 deg, rolls +-26.6 and +-153.4) are the same box mirrored in the frame's
    // axes: one sum (to the f32 drawing's rounding); each is predict's for that light.
    let corner = sum(0, 0);
    for (c, row) in [(2, 0), (0, 2), (2, 2)] {
        assert!((sum(c, row) / corner - 1.0).abs() < 1e-6, "{c},{row}: {} vs {corner}", sum(c, row));
    }
    assert!(corner > 0.0 && corner < 40.0, "{corner}");
    for p in &r.positions {
        let one = predict(&[box_ghost()], &PredictRequest { light_view: p.light.view, ..base() }).unwrap();
        assert_eq!(one, p.prediction);
    }
    // Cell centres over the frame, row 0 at the top (y up in view space).
    assert_eq!(r.positions[5].light.cell, [2, 1]);
    let px = r.positions[6].light.frame_px.unwrap();
    assert!(close(px[0], 40.0 / 6.0) && close(px[1], 100.0 / 6.0));
    assert!(r.positions[6].light.view[1] < 0.0 && r.positions[0].light.view[1] > 0.0);
    // The threshold of the sum, 30: the middle alone (and a corner only if it exceeds 30).
    let expected = 1 + if corner >= 30.0 { 4 } else { 0 };
    assert_eq!(r.reaching, expected);
}

#[test]
fn a_path_across_the_axis_against_hand_values() {
    // x from -1 to 1 at z = -1 in 5 steps: 45 (30), 26.57, 0, 26.57, 45 (30) deg. At 26.57
    // deg the box's centre is 16.57 px from the frame's centre: turned by 180 degrees it
    // spans x -1.57..8.43 (8 columns of pixel centres in the frame), by 0 x 31.57..41.57 (8
    // columns): 48 px each, sum 32.
    let range = Range::Path { from: [-1.0, 0.0, -1.0], to: [1.0, 0.0, -1.0], steps: 5 };
    let r = predict_range(&[box_ghost()], &request(range, Estimator::ContrastRatio, None)).unwrap();
    let sums: Vec<f64> = r.positions.iter().map(|p| p.prediction.estimators.sum).collect();
    for (got, want) in sums.iter().zip([20.0, 32.0, 40.0, 32.0, 20.0]) {
        assert!(close(*got, want), "{sums:?}");
    }
    assert!(close(r.positions[1].prediction.angle_deg, 0.5f64.atan().to_degrees()));
    assert_eq!(r.positions[3].light.view, [0.5, 0.0, -1.0]);
    assert!(r.positions.iter().all(|p| p.light.frame_px.is_none()));
    let sum = r.statistics.iter().find(|s| s.estimator == Estimator::Sum).unwrap();
    assert!(close(sum.mean, 144.0 / 5.0) && (sum.at_min, sum.at_max) == (0, 2));
    // Contrast ratios 1/1.05, 1/1.08, 1/1.1, ...: 1/1.08 lies 0.389 of the way up from 1/1.1
    // to 1/1.05: the second of five bins.
    assert_eq!(r.positions.iter().map(|p| p.bin).collect::<Vec<_>>(), vec![4, 1, 0, 1, 4]);
    assert_eq!(r.bins.counts, vec![1, 2, 0, 0, 2]);
    assert_eq!(r.reaching, 3);
    // A path through the camera names its step.
    let through = Range::Path { from: [-1.0, 0.0, 0.0], to: [1.0, 0.0, 0.0], steps: 3 };
    let e = predict_range(&[box_ghost()], &request(through, Estimator::Sum, None)).unwrap_err();
    assert_eq!(
        e,
        RangeError::Predict { at: "--path: step 2 of 3 at (0, 0, 0)".into(), source: PredictError::LightAtCamera }
    );
    assert_eq!(e.to_string(), "--path: step 2 of 3 at (0, 0, 0): the light is at the camera: it has no direction");
    assert_eq!(
        predict_range(&[], &request(through, Estimator::Sum, None)),
        Err(RangeError::Lens(PredictError::NoGhosts))
    );
}

// ---- the command line ----

struct Dir(PathBuf);

impl Dir {
    fn new(name: &str) -> Dir {
        let p = std::env::temp_dir().join(format!("realcam-range-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Dir(p)
    }
    fn arg(&self, name: &str) -> String {
        self.0.join(name).to_str().unwrap().to_string()
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The Tessar's lens file with the box ghost (as tests/cli.rs writes it).
fn lens_with_a_box_ghost(dir: &Dir) -> String {
    let tessar =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/lenses/tessar-walch-lens.toml")).unwrap();
    let ghost = "\n[[fitted_ghost]]\nghost = \"2/1\"\nchannel = 1\nframe_px = [40, 20]\nangles_deg = [0.0, 30.0]\n\
        centre_x_px = [10.0, 1.0]\ncentre_y_px = [10.0]\nheight_px = [3.0]\nleft_px = [5.0]\nright_px = [5.0]\n\
        left_control = [1.0]\nright_control = [1.0]\nborder = [2.0]\ninner = [2.0]\ninner_falloff_px = [0.0]\n\
        outer_falloff_px = [0.0]\ninner_exponent = [1.0]\nouter_exponent = [1.0]\n";
    std::fs::write(dir.0.join("box.toml"), tessar + ghost).unwrap();
    dir.arg("box.toml")
}

/// Runs `realcam flare-predict --lens LENS <args>`: (exit code, stdout, stderr).
fn predict_cli(dir: &Dir, lens: &str, args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(["flare-predict", "--lens", lens])
        .args(args)
        .current_dir(&dir.0)
        .output()
        .expect("running realcam");
    (out.status.code(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

fn fails_with(dir: &Dir, lens: &str, args: &[&str], message: &str) {
    let (code, _, err) = predict_cli(dir, lens, args);
    assert_eq!(code, Some(1), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains(&format!("error: {message}")), "{args:?}: expected\n  error: {message}\nin\n{err}");
}

#[test]
fn the_command_writes_the_table_the_csv_and_a_heat_map_with_one_cell_per_light() {
    let dir = Dir::new("grid");
    let lens = lens_with_a_box_ghost(&dir);
    let fov = fov_deg().to_string();
    let (csv, svg) = (dir.arg("grid.csv"), dir.arg("grid.svg"));
    let args = ["--grid", "3x3", "--fov-deg", &fov, "--csv", &csv, "--svg", &svg, "--threshold", "0.93"];
    let (code, out, err) = predict_cli(&dir, &lens, &args);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.starts_with("flare over a 3x3 grid of lights over the frame"), "{out}");
    // The middle cell (#4), ahead: sum 40, average 0.05, K ratio 1/1.1, the most flare.
    assert!(out.contains("| 4 | 1,1 | 20.0,10.0 | 0.0000,0.0000,-1.0000 | 0.0000 | 0.0000 | 0.000000e0 | 6.666667e-1 | 4.000000e1 | 5.000000e-2 |"), "{out}");
    assert!(out.contains("| 0.909091 | 0 * |"), "{out}");
    assert!(out.contains("| sum | 0.000000e0 | "), "{out}");
    assert!(
        out.contains("contrast-ratio <= 0.93 (the flare at least that strong; * above) at 1 of 9 positions (11.1%)")
    );
    assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), 10);
    let text = std::fs::read_to_string(&svg).unwrap();
    let doc = roxmltree::Document::parse(&text).expect("well-formed SVG");
    let cells: Vec<_> = doc.descendants().filter(|n| n.attribute("class") == Some("cell")).collect();
    assert_eq!(cells.len(), 9);
    assert_eq!(doc.descendants().filter(|n| n.attribute("class") == Some("bin")).count(), 5);
    // The middle cell is the brightest colour of the map, outlined as reaching the threshold;
    // the top middle (no flare, ratio 1) the darkest.
    assert_eq!((cells[4].attribute("fill"), cells[4].attribute("stroke")), (Some("#fde725"), Some("red")));
    assert_eq!((cells[1].attribute("fill"), cells[1].attribute("stroke")), (Some("#440154"), None));
    // No temporaries are left beside the outputs.
    let names: Vec<String> =
        std::fs::read_dir(&dir.0).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    assert_eq!(names.len(), 3, "{names:?}");
}

#[test]
fn the_command_plots_a_path_with_its_threshold_line() {
    let dir = Dir::new("path");
    let lens = lens_with_a_box_ghost(&dir);
    let svg = dir.arg("path.svg");
    let (code, out, err) = predict_cli(&dir, &lens, &["--path", "-1,0,-1:1,0,-1", "--steps", "5", "--svg", &svg]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("contrast-ratio <= 0.95 (the flare at least that strong; * above) at 3 of 5 positions (60.0%)")
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    let doc = roxmltree::Document::parse(&text).expect("well-formed SVG");
    let line = doc.descendants().find(|n| n.attribute("class") == Some("estimator")).unwrap();
    let points: Vec<[f64; 2]> = line
        .attribute("points")
        .unwrap()
        .split(' ')
        .map(|p| {
            let (x, y) = p.split_once(',').unwrap();
            [x.parse().unwrap(), y.parse().unwrap()]
        })
        .collect();
    assert_eq!(points.len(), 5);
    // The plot spans 1/1.1 (bottom) to 1/1.05 (top); the threshold's line lies between, below
    // the ends (1/1.05 > 0.95) and above the middle three (SVG's y grows downwards).
    let threshold = doc.descendants().find(|n| n.attribute("class") == Some("threshold")).unwrap();
    let y: f64 = threshold.attribute("y1").unwrap().parse().unwrap();
    assert!(points[0][1] < y && points[4][1] < y && points[1..4].iter().all(|p| p[1] > y), "{points:?} {y}");
    assert!(points[2][1] > points[1][1]);
    assert_eq!(doc.descendants().filter(|n| n.attribute("class") == Some("point")).count(), 5);
}

#[test]
fn bad_flags_are_named_and_leave_existing_outputs_alone() {
    let dir = Dir::new("errors");
    let lens = lens_with_a_box_ghost(&dir);
    let lens_before = std::fs::read_to_string(&lens).unwrap();
    let p = "-1,0,-1:1,0,-1";
    fails_with(
        &dir,
        &lens,
        &["--grid", "3by3", "--fov-deg", "60"],
        "--grid: \"3by3\" is not COLSxROWS of whole numbers of at least 1 (e.g. 16x9)",
    );
    fails_with(&dir, &lens, &["--grid", "0x3", "--fov-deg", "60"], "--grid: \"0x3\" is not COLSxROWS");
    fails_with(
        &dir,
        &lens,
        &["--grid", "1000x1000", "--fov-deg", "60"],
        "--grid 1000x1000 is 1000000 positions, more than 65536",
    );
    fails_with(
        &dir,
        &lens,
        &["--grid", "3x3"],
        "--grid needs --fov-deg: the horizontal field of view (degrees) of the frame the ghosts were fitted on",
    );
    fails_with(&dir, &lens, &["--grid", "3x3", "--fov-deg", "180"], "--fov-deg must be above 0 and below 180, not 180");
    fails_with(
        &dir,
        &lens,
        &["--path", "1,0,-1:2,0"],
        "--path: \"1,0,-1:2,0\" is not X,Y,Z:X,Y,Z (the line's two ends in view space, finite numbers)",
    );
    fails_with(
        &dir,
        &lens,
        &["--path", p, "--steps", "1"],
        "--steps must be from 2 (the path's two ends) to 65536, not 1",
    );
    fails_with(
        &dir,
        &lens,
        &["--path", p, "--estimator", "peak"],
        "--estimator: \"peak\" is not one of min, max, sum, average, log-average, contrast-ratio",
    );
    fails_with(&dir, &lens, &["--path", p, "--bins", "0"], "--bins must be from 1 to 1000, not 0");
    fails_with(&dir, &lens, &["--path", p, "--sample-px", "0"], "--sample-px must be from 1 to 256, not 0");
    fails_with(&dir, &lens, &["--path", p, "--threshold", "inf"], "--threshold must be a finite number, not inf");
    fails_with(&dir, &lens, &[], "give one of --light X,Y,Z, --grid COLSxROWS or --path X,Y,Z:X,Y,Z");
    fails_with(
        &dir,
        &lens,
        &["--light", "0,0,-1", "--grid", "2x2"],
        "give one of --light X,Y,Z, --grid COLSxROWS or --path X,Y,Z:X,Y,Z, not --light and --grid",
    );
    fails_with(
        &dir,
        &lens,
        &["--light", "0,0,-1", "--csv", "x.csv"],
        "--csv and --svg are written for a range of lights (--grid or --path), not for one --light",
    );
    // An output that is the lens is refused; the lens is left as it was.
    fails_with(&dir, &lens, &["--path", p, "--svg", &lens], "--svg");
    let (_, _, err) = predict_cli(&dir, &lens, &["--path", p, "--svg", &lens]);
    assert!(err.contains("realcam never writes over its inputs"), "{err}");
    assert_eq!(std::fs::read_to_string(&lens).unwrap(), lens_before);
    // A path through the camera fails before anything is written: an existing plot stays.
    let svg = dir.arg("old.svg");
    std::fs::write(&svg, "old").unwrap();
    fails_with(
        &dir,
        &lens,
        &["--path", "-1,0,0:1,0,0", "--steps", "3", "--svg", &svg],
        "--path: step 2 of 3 at (0, 0, 0): the light is at the camera: it has no direction",
    );
    assert_eq!(std::fs::read_to_string(&svg).unwrap(), "old");
    let tessar = concat!(env!("CARGO_MANIFEST_DIR"), "/lenses/tessar-walch-lens.toml");
    fails_with(&dir, tessar, &["--path", p], &format!("--lens {tessar}: the lens has no [[fitted_ghost]] section"));
}
