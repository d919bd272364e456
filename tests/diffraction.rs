//! The focus processor of Potmesil & Chakravarty 1981 (diffraction depth of field) on the GPU
//! (lavapipe in CI, validation and synchronization validation on) against its CPU f64
//! reference and the optics it implements.

mod support;

use ash::vk;
use realcam::gpu::{Gpu, Recorder};
use realcam::optics::diffraction::{encircled_energy, WAVELENGTHS_RGB_NM};
use realcam::optics::focus_processor::{build_tables, process_cpu, FocusGeometry, PsfTableSettings, PsfTables};
use realcam::optics::ThinLens;
use realcam::passes::dof::diffraction::{Diffraction, DiffractionParams, DiffractionPush, NAME};
use realcam::passes::{FrameImages, Pass};
use support::{assert_validation_clean, energy, gpu};

/// f/16 on 11.2 µm pixels, focused at 0.63 m: the Airy radius (1.22 λ N') is about one pixel,
/// and a point at infinity spreads over a CoC of radius 12 px (u_opt 38..54 by channel: a
/// mostly geometric disk with a visible diffraction edge).
fn lens() -> ThinLens {
    ThinLens::new(50.0, 16.0, 630.0).unwrap()
}
const PITCH_MM: f64 = 0.0112;
const FOCUS_M: f32 = 0.63;
const FAR_M: f32 = 1e10;

fn settings() -> PsfTableSettings {
    PsfTableSettings { depth_levels: 16, subpixel: 2, max_radius_px: 16, ..Default::default() }
}

/// Run the pass once; returns the RGBA output and the pass's GPU time in ms.
fn run_gpu(gpu: &Gpu, rgba: &[f32], depth_m: &[f32], w: u32, h: u32, tables: &PsfTables) -> (Vec<f32>, f64) {
    let pass = Diffraction::new(gpu).expect("pipeline");
    let mut rec = Recorder::new(gpu, "diffraction test").unwrap();
    let color = rec.create_image("color", w, h, vk::Format::R32G32B32A32_SFLOAT).unwrap();
    let depth = rec.create_image("depth", w, h, vk::Format::R32_SFLOAT).unwrap();
    rec.upload_images(&[(&color, rgba), (&depth, depth_m)]).unwrap();
    let mut images = FrameImages::new(color, Some(depth));
    let params =
        DiffractionParams { push: DiffractionPush::new(tables, w, h), tables: std::sync::Arc::new(tables.clone()) };
    pass.record(&mut rec, &mut images, &params).unwrap();
    let download = rec.download_image(images.color(), 4).unwrap();
    let (profile, mut data) = rec.submit().unwrap();
    assert_validation_clean(gpu);
    let ms = profile.pass_ms(NAME).unwrap_or(f64::NAN);
    (std::mem::take(&mut data[download.index()]), ms)
}

/// A single point of `value` in every channel at (x, y) on a black plane at `depth`.
fn point_image(w: u32, h: u32, x: u32, y: u32, value: f32, depth: f32) -> (Vec<f32>, Vec<f32>) {
    let mut rgba = vec![0.0f32; (w * h * 4) as usize];
    let i = (y * w + x) as usize * 4;
    rgba[i..i + 4].copy_from_slice(&[value, value, value, 1.0]);
    (rgba, vec![depth; (w * h) as usize])
}

/// Radius (px) around pixel (x0, y0)'s centre enclosing `fraction` of channel c's energy:
/// pixels taken in order of their centres' distance, linear between consecutive distances
/// (0 when the centre pixel alone holds the fraction).
fn enclosing_radius_px(rgba: &[f32], w: u32, h: u32, x0: u32, y0: u32, c: usize, fraction: f64) -> f64 {
    let mut rings: Vec<(f64, f64)> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let d = ((x as f64 - x0 as f64).powi(2) + (y as f64 - y0 as f64).powi(2)).sqrt();
            (d, rgba[(y * w + x) as usize * 4 + c] as f64)
        })
        .collect();
    rings.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = rings.iter().map(|r| r.1).sum();
    let (mut sum, mut previous_d) = (0.0, 0.0);
    for (d, e) in rings {
        if sum + e >= fraction * total {
            return previous_d + (d - previous_d) * (fraction * total - sum) / e;
        }
        sum += e;
        previous_d = d;
    }
    previous_d
}

/// The radius (px) inside which the continuous pattern (cut and renormalised like the table)
/// holds `fraction` of its energy, by bisection on `encircled_energy`.
fn theoretical_radius_px(u: f64, v_per_px: f64, kept: f64, fraction: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 40.0 * v_per_px.max(1.0) + 2.0 * u.abs());
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if encircled_energy(u, mid) / kept < fraction {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi) / v_per_px
}

#[test]
fn gpu_focus_processor_matches_the_cpu_f64_reference() {
    let gpu = gpu();
    let tables = build_tables(&lens(), PITCH_MM, 0.4, FAR_M as f64, &settings());
    let (w, h) = (48u32, 32u32);
    let mut rgba = Vec::new();
    let mut depth = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = (x as f32 / w as f32, y as f32 / h as f32);
            rgba.extend([0.2 + 0.6 * fx, 0.3 + 0.4 * fy, 0.5 + 0.3 * (7.0 * fx).sin() * fy, 1.0 - fy]);
            // depth from 0.45 m (left) through the focus distance to far away (right)
            depth.push(0.45 / (1.0 - 0.95 * fx));
        }
    }
    // Highlights at the far plane, on the focus distance, in front, and depths that clamp.
    let highlights: [(u32, u32, f32, f32); 8] = [
        (10, 10, 50.0, FAR_M),
        (30, 16, 20.0, FOCUS_M),
        (40, 25, 30.0, 0.4),
        (5, 28, 5.0, 0.0),            // clamps to the nearest level
        (20, 4, 8.0, 0.03),           // nearer than the focal length: clamps too
        (44, 6, 12.0, f32::INFINITY), // the far end
        (24, 27, 3.0, 0.9),
        (16, 18, 15.0, 0.55),
    ];
    for (x, y, value, d) in highlights {
        let i = (y * w + x) as usize;
        rgba[4 * i..4 * i + 3].copy_from_slice(&[value, 0.7 * value, 0.4 * value]);
        depth[i] = d;
    }
    let cpu = process_cpu(&rgba, &depth, w, h, &tables);
    let (out, ms) = run_gpu(&gpu, &rgba, &depth, w, h, &tables);
    assert!(out.iter().all(|v| v.is_finite()));
    let max_in = rgba.iter().fold(0.0f32, |m, v| m.max(v.abs())) as f64;
    let (mut max_abs, mut max_rel) = (0.0f64, 0.0f64);
    for (g, c) in out.iter().zip(&cpu) {
        let err = (*g as f64 - *c as f64).abs();
        max_abs = max_abs.max(err);
        max_rel = max_rel.max(err / (c.abs() as f64).max(1e-3));
    }
    // The GPU sums the (2R+1)^2 taps in f32, the CPU in f64 (both from the same f32 tables);
    // the level coordinate is f32 on the GPU. Worst case for an f32 sum of N terms of magnitude
    // at most max|input| with weights summing to 1: N * 2^-24 * max|input|.
    let taps = tables.entries() as f64;
    let bound = taps * f32::EPSILON as f64 * 0.5 * max_in;
    println!(
        "GPU vs CPU f64, {w}x{h}, R = {} ({} levels): max abs error {max_abs:.3e} (max input {max_in}), max rel \
         {max_rel:.3e}, bound {bound:.2e}; diffraction pass {ms:.3} ms on {}",
        tables.radius_px,
        tables.levels(),
        gpu.info()
    );
    assert!(max_abs <= bound, "max abs error {max_abs:e} > {bound:e}");
    // alpha passes through
    for (g, c) in out.chunks_exact(4).zip(rgba.chunks_exact(4)) {
        assert_eq!(g[3], c[3]);
    }
}

#[test]
fn energy_is_preserved_away_from_the_borders() {
    let gpu = gpu();
    // Depths 0.5 .. 1 m: CoC radii up to 4.4 px, table radius 11: content farther than 2R
    // from the borders, so no pixel it reaches misses a sample from outside the frame.
    let tables = build_tables(&lens(), PITCH_MM, 0.5, 1.0, &settings());
    let r = tables.radius_px;
    let (w, h) = (4 * r + 24, 4 * r + 16);
    let mut rgba = vec![0.0f32; (w * h * 4) as usize];
    let mut depth = vec![0.75f32; (w * h) as usize];
    let mut seed = 12345u32;
    let mut random = move || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    for y in 2 * r..h - 2 * r {
        for x in 2 * r..w - 2 * r {
            let i = (y * w + x) as usize;
            let bright = if random() < 0.05 { 20.0 } else { 1.0 };
            for c in 0..3 {
                rgba[4 * i + c] = bright * random();
            }
            rgba[4 * i + 3] = 1.0;
        }
    }
    // Two depth planes as well as the background's: the left half of the content at 0.5 m,
    // the right at 1 m (in focus is 0.63 m).
    for y in 0..h {
        for x in 0..w {
            depth[(y * w + x) as usize] = if x < w / 2 { 0.5 } else { 1.0 };
        }
    }
    let (out, _) = run_gpu(&gpu, &rgba, &depth, w, h, &tables);
    let (before, after) = (energy(&rgba), energy(&out));
    let error = (after - before).abs() / before;
    println!("energy {before:.4} -> {after:.4}: relative error {error:.3e} ({w}x{h}, R = {r})");
    assert!(error < 0.005, "energy changed by {:.3}%", error * 100.0);

    // One depth everywhere: the normalised sum is then a plain convolution, energy exact.
    depth.iter_mut().for_each(|d| *d = 0.5);
    let (out, _) = run_gpu(&gpu, &rgba, &depth, w, h, &tables);
    let single = (energy(&out) - before).abs() / before;
    println!("one depth plane: relative error {single:.3e}");
    assert!(single < 1e-5);
}

#[test]
fn a_far_point_becomes_a_disk_of_the_geometric_coc_and_a_focused_point_an_airy_spot() {
    let gpu = gpu();
    let lens = lens();
    let tables = build_tables(&lens, PITCH_MM, 0.4, FAR_M as f64, &settings());
    let geometry = FocusGeometry::new(&lens, PITCH_MM);
    let (w, h) = (64u32, 64u32);
    let (x0, y0) = (32u32, 32u32);

    // Far plane: |coc|/2 from the thin lens (Kyaw eq 5.3).
    let coc_radius_px = lens.coc_mm(FAR_M as f64 * 1000.0).abs() / 2.0 / PITCH_MM;
    let (rgba, depth) = point_image(w, h, x0, y0, 100.0, FAR_M);
    let (out, ms) = run_gpu(&gpu, &rgba, &depth, w, h, &tables);
    let far_level = tables.levels() - 1;
    for (c, &wavelength_nm) in WAVELENGTHS_RGB_NM.iter().enumerate() {
        let w_per_mm = geometry.defocus_per_mm(FAR_M as f64);
        let (u, v_per_mm) = geometry.optical(w_per_mm, wavelength_nm);
        let v_per_px = v_per_mm * PITCH_MM;
        let kept = tables.energy_kept[far_level][c];
        let theory = theoretical_radius_px(u, v_per_px, kept, 0.9);
        let measured = enclosing_radius_px(&out, w, h, x0, y0, c, 0.9);
        let ratio = measured / coc_radius_px;
        println!(
            "far point, {wavelength_nm} nm: u = {u:.1}, 90% radius {measured:.2} px (continuous pattern {theory:.2} px), \
             |coc|/2 = {coc_radius_px:.2} px, ratio {ratio:.3}; pass {ms:.3} ms"
        );
        // A uniform disk holds 90% inside sqrt(0.9) = 0.949 of its radius. At u_opt ~ 40-55
        // diffraction smears the edge over a few optical units (a fraction of a pixel here)
        // and rings the interior: the continuous pattern's 90% radius (encircled_energy, with
        // the table's cut) is 0.93-0.94 of the geometric radius; 0.8-1.05 leaves room for that
        // and the pixel grid, and the measured radius must match the continuous one to 0.5 px
        // (pixel centres stand for whole pixels).
        assert!((0.8..=1.05).contains(&ratio), "{wavelength_nm} nm: ratio {ratio}");
        assert!((measured - theory).abs() < 0.5, "{wavelength_nm} nm: {measured} vs {theory}");
    }

    // Focus distance: the Airy pattern, about a pixel.
    let (rgba, depth) = point_image(w, h, x0, y0, 100.0, FOCUS_M);
    let (out, _) = run_gpu(&gpu, &rgba, &depth, w, h, &tables);
    let knot = tables.mapping.knot_level;
    for (c, &wavelength_nm) in WAVELENGTHS_RGB_NM.iter().enumerate() {
        let (_, v_per_mm) = geometry.optical(0.0, wavelength_nm);
        let v_per_px = v_per_mm * PITCH_MM;
        let kept = tables.energy_kept[knot][c];
        let total: f64 = out.chunks_exact(4).map(|p| p[c] as f64).sum();
        let block: f64 = (y0 - 1..=y0 + 1)
            .flat_map(|y| (x0 - 1..=x0 + 1).map(move |x| (x, y)))
            .map(|(x, y)| out[(y * w + x) as usize * 4 + c] as f64)
            .sum::<f64>()
            / total;
        // The 3x3 block contains the disk of radius 1.5 px and lies inside that of 1.5 √2 px.
        let lower = encircled_energy(0.0, 1.5 * v_per_px) / kept;
        let upper = encircled_energy(0.0, 1.5 * 2f64.sqrt() * v_per_px) / kept;
        // 0 when the centre pixel alone holds half the energy
        let r50 = enclosing_radius_px(&out, w, h, x0, y0, c, 0.5);
        let centre = out[(y0 * w + x0) as usize * 4 + c] as f64 / total;
        println!(
            "focused point, {wavelength_nm} nm: Airy radius {:.2} px, centre pixel {centre:.3}, 3x3 block {block:.3} \
             in [{lower:.3}, {upper:.3}], 50% radius {r50:.2} px",
            geometry.airy_radius_px(wavelength_nm)
        );
        assert!(block >= lower - 0.01 && block <= upper + 0.01);
        assert!(r50 <= 1.0, "{r50}");
    }
}

#[test]
fn tables_sum_to_one_and_extreme_depths_stay_finite() {
    let lens = lens();
    let small = PsfTableSettings {
        depth_levels: 6,
        subpixel: 2,
        max_radius_px: 12,
        integration_samples: 3,
        ..Default::default()
    };
    // (min, max): from 0 (clamped), only the focus distance, nearer than the focal length
    // (50 mm), out to 1e10 and infinity.
    let ranges = [(0.0, 1e10), (0.63, 0.63), (0.02, 0.045), (0.03, f64::INFINITY), (1e10, 1e10)];
    for (lo, hi) in ranges {
        let t = build_tables(&lens, PITCH_MM, lo, hi, &small);
        assert!(t.data.iter().all(|v| v.is_finite() && *v >= 0.0), "range {lo}..{hi}");
        assert!(t.depths_m.iter().all(|d| *d > 0.0 && !d.is_nan()), "{:?}", t.depths_m);
        for l in 0..t.levels() {
            for c in 0..3 {
                for o in 0..t.offsets() {
                    let sum: f64 = t.table(l, c, o).iter().map(|&v| v as f64).sum();
                    assert!((sum - 1.0).abs() < 1e-5, "range {lo}..{hi} level {l} channel {c} offset {o}: {sum}");
                }
                assert!(t.energy_kept[l][c] > 0.0 && t.energy_kept[l][c] <= 1.0 + 1e-9);
            }
        }
        println!(
            "range {lo}..{hi} m: levels at {:?} m, CoC radii {:?} px, R = {}, {} clipped, range clamped: {}",
            t.depths_m.iter().map(|d| (d * 1e4).round() / 1e4).collect::<Vec<_>>(),
            t.coc_radius_px.iter().map(|r| (r * 10.0).round() / 10.0).collect::<Vec<_>>(),
            t.radius_px,
            t.clipped_levels,
            t.depth_range_clamped
        );
    }
    // The focus-only range is one Airy table repeated; it needs no clipping.
    let t = build_tables(&lens, PITCH_MM, 0.63, 0.63, &small);
    assert_eq!(t.clipped_levels, 0);
    assert!(t.coc_radius_px.iter().all(|r| r.abs() < 1e-9));

    // Every extreme depth through the GPU and the CPU: finite, and the two agree.
    let gpu = gpu();
    let t = build_tables(&lens, PITCH_MM, 0.0, 1e10, &small);
    let params = DiffractionPush::new(&t, 1, 1);
    let depths = [0.0f32, -1.0, 0.03, 0.05, FOCUS_M, 1e10, f32::INFINITY, f32::NAN, 1e-30, f32::MAX];
    for d in depths {
        let gpu_x = params.level_coordinate(d) as f64;
        let cpu_x = t.mapping.coordinate(d as f64);
        assert!(gpu_x.is_finite() && (gpu_x - cpu_x).abs() < 1e-4, "depth {d}: {gpu_x} vs {cpu_x}");
    }
    let (w, h) = (depths.len() as u32 * 3, 9u32);
    let mut rgba = vec![0.0f32; (w * h * 4) as usize];
    let mut depth = vec![0.0f32; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            depth[i] = depths[(x / 3) as usize];
            rgba[4 * i..4 * i + 4].copy_from_slice(&[1.0 + x as f32, 2.0, if y == 4 { 50.0 } else { 0.5 }, 1.0]);
        }
    }
    let cpu = process_cpu(&rgba, &depth, w, h, &t);
    let (out, _) = run_gpu(&gpu, &rgba, &depth, w, h, &t);
    assert!(out.iter().chain(&cpu).all(|v| v.is_finite()));
    let worst = out.iter().zip(&cpu).map(|(a, b)| (a - b).abs() / b.abs().max(1.0)).fold(0.0f32, f32::max);
    println!("extreme depths: GPU vs CPU worst relative difference {worst:.2e}");
    assert!(worst < 1e-4);
}
