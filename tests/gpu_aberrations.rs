//! The aberration passes on the GPU (lavapipe) with validation on: distortion and lateral colour
//! against the lens tables (Kyaw 2013 eq 6.8).

mod support;

use realcam::model::frame::Frame;
use realcam::optics::distortion::{DistortionTables, HeightTable};
use realcam::passes::lens::distortion::{distortion_cpu, Distortion};
use support::*;

const W: u32 = 256;
const H: u32 = 144;

/// Distortion growing with the square of the height: `edge_percent` at 4.8 mm (the 9.6 mm wide
/// test sensor's half width).
fn quadratic(edge_percent: f64, red_extra: f64, blue_extra: f64) -> DistortionTables {
    let heights: Vec<f64> = (0..=12).map(|i| i as f64 * 0.5).collect();
    let table = |k: f64| HeightTable {
        image_height_mm: heights.clone(),
        values: heights.iter().map(|h| k * (h / 4.8) * (h / 4.8)).collect(),
    };
    DistortionTables {
        green_percent: table(edge_percent),
        red_extra_percent: table(red_extra),
        blue_extra_percent: table(blue_extra),
    }
}

/// Thin bright horizontal lines (2 px, value 1 on 0) at the given rows, at depth 2 m (in focus).
fn lines_frame(rows: &[u32]) -> Frame {
    let mut color = vec![0.0f32; (W * H * 4) as usize];
    for y in 0..H {
        for x in 0..W {
            let i = ((y * W + x) * 4) as usize;
            color[i + 3] = 1.0;
            if rows.iter().any(|&r| y == r || y == r + 1) {
                color[i..i + 3].copy_from_slice(&[1.0; 3]);
            }
        }
    }
    Frame::new(W, H, color, vec![2.0; (W * H) as usize])
}

fn camera_with(tables: DistortionTables) -> realcam::model::camera::Camera {
    let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
    camera.distortion = Some(tables);
    camera
}

/// Centroid row of channel `c` in column x, over rows lo..hi.
fn column_centroid(rgba: &[f32], x: u32, lo: u32, hi: u32, c: usize) -> f64 {
    let (mut m, mut s) = (0.0, 0.0);
    for y in lo..hi {
        let v = at(rgba, W, x, y, c) as f64;
        m += v * (y as f64 + 0.5);
        s += v;
    }
    m / s
}

#[test]
fn straight_lines_bow_as_the_distortion_table_says() {
    let gpu = gpu();
    let pitch_mm = 9.6 / W as f64;
    // Lines centred at y = 72 (through the centre: stays straight), 30 and 114.
    let rows = [71u32, 29, 113];
    for edge_percent in [-4.0, 4.0] {
        let tables = quadratic(edge_percent, 0.0, 0.0);
        let camera = camera_with(tables.clone());
        let frame = lines_frame(&rows);
        let (rgba, plan, _) = render(&gpu, &frame, &camera);
        assert!(plan.runs("distortion"), "{}", plan.explain());
        for &row in &rows {
            let ideal_y = row as f64 + 1.0; // the 2 px line's centre
            let mut worst = 0.0f64;
            let (mut end_offset, mut mid_offset) = (0.0, 0.0);
            for x in (8..W - 8).step_by(8) {
                // Expected: trace the ideal line's points through eq 6.8 and read the row at x.
                let xc = x as f64 + 0.5 - 128.0;
                let mut best = (f64::MAX, 0.0);
                for k in 0..4000 {
                    let xi = -140.0 + k as f64 * 0.07;
                    let yi = ideal_y - 72.0;
                    let r_mm = (xi * xi + yi * yi).sqrt() * pitch_mm;
                    let s = 1.0 + tables.percent(1, r_mm) / 100.0;
                    let (xr, yr) = (xi * s, yi * s);
                    if (xr - xc).abs() < best.0 {
                        best = ((xr - xc).abs(), yr + 72.0);
                    }
                }
                let expected = best.1;
                let lo = (expected - 8.0).max(0.0) as u32;
                let hi = ((expected + 8.0) as u32).min(H);
                let measured = column_centroid(&rgba, x, lo, hi, 1);
                worst = worst.max((measured - expected).abs());
                if x == 8 {
                    end_offset = measured - 72.0;
                }
                if x == 128 {
                    mid_offset = measured - 72.0;
                }
            }
            println!("D {edge_percent}% line at {ideal_y}: worst deviation from eq 6.8 {worst:.3} px");
            assert!(worst < 0.5, "D {edge_percent}%: line at {ideal_y} off by {worst:.3} px");
            if row == 71 {
                assert!(end_offset.abs() < 0.1 && mid_offset.abs() < 0.1, "the centre line must stay straight");
            } else {
                // Barrel pulls the line's ends toward the centre, pincushion pushes them away.
                let bow = end_offset.abs() - mid_offset.abs();
                assert!(if edge_percent < 0.0 { bow < -0.3 } else { bow > 0.3 }, "D {edge_percent}%: bow {bow}");
            }
        }
    }
}

#[test]
fn lateral_colour_displaces_red_and_blue_by_the_tabled_amounts() {
    let gpu = gpu();
    // A small white square (4x4 px) around (224, 72): 96 px right of the centre = 3.6 mm.
    let mut color = vec![0.0f32; (W * H * 4) as usize];
    for y in 70..74 {
        for x in 222..226 {
            let i = ((y * W + x) * 4) as usize;
            color[i..i + 3].copy_from_slice(&[1.0; 3]);
        }
    }
    let frame = Frame::new(W, H, color, vec![2.0; (W * H) as usize]);
    let tables = quadratic(0.0, 1.5, -1.5);
    let camera = camera_with(tables.clone());
    let (rgba, _, _) = render(&gpu, &frame, &camera);
    // The lens file's red (C line) and blue (F line) at Rec.709's channel wavelengths (611,
    // 549, 464 nm), against green: the parabola through the lines gives red 0.7625 and blue
    // -0.6951 of the lens file's +-1.5 (src/optics/wavelengths.rs).
    let tables = tables.at_wavelengths(frame.channel_wavelengths_nm());
    // At 6 mm the lens file's tables are +-1.5 % times (6 / 4.8)^2 (quadratic()).
    let edge = |t: &HeightTable| t.values[12] / (6.0f64 / 4.8).powi(2);
    assert!((edge(&tables.red_extra_percent) / 1.5 - 0.7625).abs() < 1e-3, "{tables:?}");
    assert!((edge(&tables.blue_extra_percent) / 1.5 + 0.6951).abs() < 1e-3, "{tables:?}");
    let centroid_x = |c: usize| {
        let (mut m, mut s) = (0.0, 0.0);
        for y in 60..84 {
            for x in 200..250 {
                let v = at(&rgba, W, x, y, c) as f64;
                m += v * (x as f64 + 0.5);
                s += v;
            }
        }
        m / s
    };
    let (r, g, b) = (centroid_x(0), centroid_x(1), centroid_x(2));
    let pitch_mm = 9.6 / W as f64;
    let ideal_px = 224.0 - 128.0;
    let expect = |c: usize| tables.real_height_mm(c, ideal_px * pitch_mm) / pitch_mm - ideal_px;
    println!("red {:+.3} px (table {:+.3}), blue {:+.3} px (table {:+.3})", r - g, expect(0), b - g, expect(2));
    assert!((g - 224.0).abs() < 0.05, "green stays: {g}");
    assert!((r - g - expect(0)).abs() < 0.2, "red shift {} vs table {}", r - g, expect(0));
    assert!((b - g - expect(2)).abs() < 0.2, "blue shift {} vs table {}", b - g, expect(2));
}

#[test]
fn distortion_pass_matches_its_cpu_twin() {
    let gpu = gpu();
    let tables = quadratic(-3.0, 0.4, -0.3);
    let camera = camera_with(tables.clone());
    let frame = lines_frame(&[20, 50, 90, 130]);
    let (rgba, plan, _) = render(&gpu, &frame, &camera);
    let params = &plan.params::<Distortion>().unwrap().push;
    let cpu = distortion_cpu(&frame.color, params, &tables.at_wavelengths(frame.channel_wavelengths_nm()));
    let worst = rgba.iter().zip(&cpu).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(worst < 2e-3, "GPU vs CPU distortion differ by {worst}");
    // Tables that are all zero: the pass is not recorded.
    let (_, plan, profile) = render(&gpu, &frame, &camera_with(quadratic(0.0, 0.0, 0.0)));
    assert!(!plan.runs("distortion") && profile.pass_ms("distortion").is_none());
}

#[test]
fn vignetting_follows_the_relative_illumination_table() {
    // A uniform frame through a lens whose relative illumination falls to 55% at 5.4 mm: the
    // output at each image height equals the table within 1%.
    let gpu = gpu();
    let table = HeightTable { image_height_mm: vec![0.0, 2.0, 4.0, 5.5], values: vec![1.0, 0.95, 0.75, 0.55] };
    let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
    camera.vignetting = true;
    camera.relative_illumination = Some(table.clone());
    let mut color = vec![0.5f32; (W * H * 4) as usize];
    for a in color.chunks_exact_mut(4) {
        a[3] = 1.0;
    }
    let frame = Frame::new(W, H, color, vec![2.0; (W * H) as usize]);
    let (rgba, plan, _) = render(&gpu, &frame, &camera);
    assert!(plan.runs("vignette"), "{}", plan.explain());
    let pitch_mm = 9.6 / W as f64;
    let mut worst = 0.0f64;
    for y in (0..H).step_by(7) {
        for x in (0..W).step_by(7) {
            let h_mm = ((x as f64 + 0.5 - 128.0).powi(2) + (y as f64 + 0.5 - 72.0).powi(2)).sqrt() * pitch_mm;
            let expected = 0.5 * table.at(h_mm);
            let got = at(&rgba, W, x, y, 1) as f64;
            worst = worst.max((got / expected - 1.0).abs());
        }
    }
    assert!(worst < 0.01, "vignetting off the table by {:.3}%", worst * 100.0);
    // Without the table: cos^4 of the field angle (Kyaw 2013 eq 4.14) at the corner.
    camera.relative_illumination = None;
    let (rgba, _, _) = render(&gpu, &frame, &camera);
    let corner_mm = ((0.5f64 - 128.0).powi(2) + (0.5f64 - 72.0).powi(2)).sqrt() * pitch_mm;
    let v = camera.lens.image_distance_mm();
    let cos4 = realcam::optics::exposure::natural_vignetting(corner_mm, v);
    let got = at(&rgba, W, 0, 0, 1) as f64 / 0.5;
    assert!((got / cos4 - 1.0).abs() < 1e-4, "corner {got} vs cos^4 {cos4}");
}

#[test]
fn astigmatism_smears_points_along_the_tabled_direction_only() {
    // A point 72 px right of the centre (the radius is horizontal there). A tangential-only
    // table smears it vertically by the tabled length (a box of L px has variance L^2/12), not
    // horizontally; a sagittal-only table the other way round.
    let gpu = gpu();
    let pitch_mm = 9.6 / W as f64;
    let length_px = 9.0;
    let heights = vec![0.0, 2.0, 6.0];
    let zero = HeightTable { image_height_mm: heights.clone(), values: vec![0.0; 3] };
    let blur = HeightTable { image_height_mm: heights.clone(), values: vec![length_px * pitch_mm; 3] };
    let mut color = vec![0.0f32; (W * H * 4) as usize];
    let (px, py) = (200u32, 72u32);
    let i = ((py * W + px) * 4) as usize;
    color[i..i + 3].copy_from_slice(&[100.0; 3]);
    let frame = Frame::new(W, H, color, vec![2.0; (W * H) as usize]);
    for (tangential, sagittal, name) in
        [(blur.clone(), zero.clone(), "tangential"), (zero.clone(), blur.clone(), "sagittal")]
    {
        let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
        camera.astigmatism = Some((tangential, sagittal));
        let (rgba, plan, profile) = render(&gpu, &frame, &camera);
        assert!(plan.runs("astigmatism") && profile.pass_ms("astigmatism_sagittal").is_some());
        let (e, _, _, var_radial, var_tangential) = moments(&rgba, px, py, 30);
        println!("{name}: radial variance {var_radial:.2} px^2, tangential {var_tangential:.2} px^2, energy {e:.2}");
        let expected = length_px * length_px / 12.0;
        let (along, across) =
            if name == "tangential" { (var_tangential, var_radial) } else { (var_radial, var_tangential) };
        assert!((along / expected - 1.0).abs() < 0.2, "{name}: variance along {along:.2} vs box {expected:.2}");
        assert!(across < 0.35, "{name}: variance across {across:.2} should stay a pixel's");
        // A gather along each pixel's own radius is a scatter only to first order: the radii fan
        // out, so a point sees slightly more pixels outside than inside (O(L / r), 1.5% here).
        assert!((e / 100.0 - 1.0).abs() < 0.02, "{name}: energy {e}");
    }
}

/// Second moments of channel 1 around (px, py) over a window: (energy, mean dx, mean dy,
/// variance x, variance y).
fn moments(rgba: &[f32], px: u32, py: u32, win: i32) -> (f64, f64, f64, f64, f64) {
    let (mut e, mut mx, mut my, mut vx, mut vy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for y in (py as i32 - win).max(0)..(py as i32 + win).min(H as i32) {
        for x in (px as i32 - win).max(0)..(px as i32 + win).min(W as i32) {
            let v = at(rgba, W, x as u32, y as u32, 1) as f64;
            let (dx, dy) = (x as f64 - px as f64, y as f64 - py as f64);
            e += v;
            mx += v * dx;
            my += v * dy;
            vx += v * dx * dx;
            vy += v * dy * dy;
        }
    }
    (e, mx / e, my / e, vx / e - (mx / e).powi(2), vy / e - (my / e).powi(2))
}

#[test]
fn coma_draws_a_comet_of_the_tabled_size_pointing_along_the_radius() {
    // Third-order coma sends pupil point (rho, theta) to C rho^2 (2 + cos 2theta, sin 2theta)
    // (radial, tangential). Over a uniform pupil: mean radial shift C, radial variance C^2/2,
    // tangential variance C^2/6, and nothing inside the chief ray's image. A point 72.5 px
    // right of the centre with a tangential coma (3C) of 9 px in the table: C = 3 px. Bilinear
    // reading adds 1/6 px^2 to each variance.
    let gpu = gpu();
    let (px, py) = (200u32, 72u32);
    let h0_px = px as f64 + 0.5 - W as f64 / 2.0;
    let mut color = vec![0.0f32; (W * H * 4) as usize];
    let i = ((py * W + px) * 4) as usize;
    color[i..i + 3].copy_from_slice(&[100.0; 3]);
    let frame = Frame::new(W, H, color, vec![2.0; (W * H) as usize]);
    for sign in [1.0, -1.0] {
        // Coma proportional to height: 9 px (tangential) at the point.
        let heights = vec![0.0, 3.0, 6.0];
        let coma = HeightTable {
            image_height_mm: heights.clone(),
            values: heights.iter().map(|h| sign * 9.0 / h0_px * h).collect(),
        };
        let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
        camera.coma = Some(coma);
        let (rgba, plan, profile) = render(&gpu, &frame, &camera);
        assert!(plan.runs("coma") && profile.pass_ms("coma").is_some());
        let (e, mx, my, vx, vy) = moments(&rgba, px, py, 20);
        println!("coma {sign:+}: energy {e:.3}, mean ({mx:.3}, {my:.3}), variance radial {vx:.3} tangential {vy:.3}");
        let c = 3.0;
        assert!((e / 100.0 - 1.0).abs() < 0.01, "energy {e}");
        // The point's centre is 0.5 px below the frame's centre row: its radius tilts by 0.5/72.5.
        let tilt = (py as f64 + 0.5 - H as f64 / 2.0) / h0_px;
        assert!((mx - sign * c).abs() < 0.1, "mean radial shift {mx} vs {}", sign * c);
        assert!((my - sign * c * tilt).abs() < 0.005, "mean tangential shift {my}");
        assert!((vx - (c * c / 2.0 + 1.0 / 6.0)).abs() < 0.25, "radial variance {vx}");
        assert!((vy - (c * c / 6.0 + 1.0 / 6.0)).abs() < 0.15, "tangential variance {vy}");
        // The comet lies on the outer (sign > 0) side of the chief ray's image.
        let behind: f64 = (0..H)
            .flat_map(|y| (0..W).map(move |x| (x, y)))
            .filter(|&(x, _)| sign * (x as f64 - px as f64) < -1.0)
            .map(|(x, y)| at(&rgba, W, x, y, 1) as f64)
            .sum();
        assert!(behind < 1e-3 * e, "{behind} on the wrong side");
    }
}

#[test]
fn coma_pass_matches_its_cpu_twin() {
    use realcam::passes::lens::coma::{coma_cpu, table_data, Coma, ComaPush};
    let (w, h) = (48u32, 32u32);
    let color: Vec<f32> = (0..w * h * 4).map(|i| ((i * 37 % 101) as f32 / 50.0).powi(2)).collect();
    let frame = Frame::new(w, h, color.clone(), vec![2.0; (w * h) as usize]);
    let mut camera = dof_camera(50.0, 2.0, 2.0, 0);
    let coma = HeightTable { image_height_mm: vec![0.0, 1.0, 2.0, 8.0], values: vec![0.0, 0.05, 0.2, 0.4] };
    camera.coma = Some(coma.clone());
    let gpu = gpu();
    let (rgba, plan, _) = render(&gpu, &frame, &camera);
    let pitch_mm = camera.pixel_pitch_mm(w, h);
    let params = ComaPush::new([w, h], [w as f64 / 2.0, h as f64 / 2.0], pitch_mm, &coma);
    assert_eq!(plan.params::<Coma>().map(|p| p.push), Some(params));
    let cpu = coma_cpu(&color, &params, &table_data(&coma));
    let worst = rgba.iter().zip(&cpu).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "GPU vs CPU twin: {worst}");
}
