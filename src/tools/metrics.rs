//! Image error measures used by `realcam compare` and the accuracy tools.

/// Differences between a test image and a reference (RGB of RGBA, alpha ignored).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// Root mean square difference over all RGB values.
    pub rmse: f64,
    /// Mean absolute difference.
    pub mean_abs: f64,
    /// 10 log10(peak^2 / MSE), with peak = 1 (display-referred) or the reference's 99.9th
    /// percentile for scene-referred values above 1; infinite for identical images.
    pub psnr_db: f64,
    /// (sum test - sum reference) / sum reference.
    pub relative_energy_error: f64,
    /// RMSE of the values clamped to [0, 1]: the error a display would show, not dominated by
    /// a few HDR highlights.
    pub rmse_display: f64,
    /// RMSE after scaling the test image to the reference's total energy, values then clamped
    /// to [0, MATCHED_CLAMP]: how the depth of field and the motion blur are compared with
    /// ray-traced ground truth (a global exposure difference and the brightest highlights do
    /// not dominate it).
    pub rmse_matched: f64,
}

/// The clamp of [`ImageError::rmse_matched`].
pub const MATCHED_CLAMP: f64 = 4.0;

/// Compare two RGBA images of the same size. Non-finite values count as 0.
pub fn compare_rgba(test: &[f32], reference: &[f32]) -> ImageError {
    let finite = |v: f32| if v.is_finite() { v as f64 } else { 0.0 };
    let (mut se, mut ae, mut sum_t, mut sum_r, mut n) = (0.0, 0.0, 0.0, 0.0, 0usize);
    let mut se_display = 0.0;
    let mut ref_values = Vec::with_capacity(reference.len() / 4 * 3);
    for (t, r) in test.chunks_exact(4).zip(reference.chunks_exact(4)) {
        for c in 0..3 {
            let (a, b) = (finite(t[c]), finite(r[c]));
            se += (a - b) * (a - b);
            ae += (a - b).abs();
            se_display += (a.clamp(0.0, 1.0) - b.clamp(0.0, 1.0)).powi(2);
            sum_t += a;
            sum_r += b;
            ref_values.push(b);
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    let mse = se / n;
    let scale = if sum_t > 0.0 { sum_r / sum_t } else { 1.0 };
    let mut se_matched = 0.0;
    for (t, r) in test.chunks_exact(4).zip(reference.chunks_exact(4)) {
        for c in 0..3 {
            let a = (finite(t[c]) * scale).clamp(0.0, MATCHED_CLAMP);
            let b = finite(r[c]).clamp(0.0, MATCHED_CLAMP);
            se_matched += (a - b) * (a - b);
        }
    }
    ref_values.sort_by(f64::total_cmp);
    let p999 = ref_values.get(((ref_values.len() as f64) * 0.999) as usize).copied().unwrap_or(1.0);
    let peak = p999.max(1.0);
    ImageError {
        rmse: mse.sqrt(),
        mean_abs: ae / n,
        psnr_db: if mse > 0.0 { 10.0 * (peak * peak / mse).log10() } else { f64::INFINITY },
        relative_energy_error: if sum_r != 0.0 { (sum_t - sum_r) / sum_r } else { 0.0 },
        rmse_display: (se_display / n).sqrt(),
        rmse_matched: (se_matched / n).sqrt(),
    }
}

/// Side of the tiles of [`tile_luminance`], px (the tiled depth of field's tile).
pub const TILE_PX: u32 = 16;
/// A tile is "off" when its mean luminance differs from the reference's by more than this share.
pub const TILE_THRESHOLD: f64 = 0.05;
/// The denominator's floor for dark tiles: the relative error of a tile is
/// |mean_test - mean_ref| / max(mean_ref, TILE_FLOOR), so a tile darker than 0.02 (scene
/// value; 8-bit sRGB code 39) is judged on an absolute difference of 0.001.
pub const TILE_FLOOR: f64 = 0.02;
/// Alpha below this where the input is opaque is a hole.
pub const ALPHA_OPAQUE: f32 = 0.999;

/// Linear Rec.709 luminance of an RGBA pixel; non-finite channels count as 0.
pub fn luminance(p: &[f32]) -> f64 {
    let f = |v: f32| if v.is_finite() { v as f64 } else { 0.0 };
    0.2126 * f(p[0]) + 0.7152 * f(p[1]) + 0.0722 * f(p[2])
}

/// The tile whose mean luminance is farthest off the reference's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorstTile {
    /// Tile column and row (tile (0, 0) is the top left).
    pub tile: (u32, u32),
    /// Its top-left pixel.
    pub x: u32,
    pub y: u32,
    pub test_mean: f64,
    pub reference_mean: f64,
    /// Signed: (mean_test - mean_ref) / max(mean_ref, TILE_FLOOR); < 0 darker than the reference.
    pub relative_error: f64,
}

/// The local (per-tile) comparison of [`tile_luminance`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileError {
    /// Tiles compared: ceil(w / 16) x ceil(h / 16); the right and bottom tiles may be partial
    /// (their mean is over the pixels they have).
    pub tiles: usize,
    /// Tiles with |mean_test - mean_ref| / max(mean_ref, TILE_FLOOR) > TILE_THRESHOLD.
    pub tiles_off: usize,
    pub worst: Option<WorstTile>,
}

impl TileError {
    /// tiles_off / tiles (0 for an empty image).
    pub fn share_off(&self) -> f64 {
        if self.tiles == 0 {
            0.0
        } else {
            self.tiles_off as f64 / self.tiles as f64
        }
    }

    /// "12.5% (18/144), worst -0.153 at tile (3, 4) (px 48, 64)".
    pub fn summary(&self) -> String {
        let worst = self.worst.map_or(String::new(), |w| {
            format!(", worst {:+.3} at tile ({}, {}) (px {}, {})", w.relative_error, w.tile.0, w.tile.1, w.x, w.y)
        });
        format!("{:.1}% ({}/{}){worst}", 100.0 * self.share_off(), self.tiles_off, self.tiles)
    }
}

/// Mean luminance of each TILE_PX x TILE_PX tile of `test` against `reference` (RGBA of
/// width x height): the tiles whose mean is off by more than TILE_THRESHOLD, relative to
/// max(mean_ref, TILE_FLOOR), and the worst tile. Values are not clamped (a tile's mean is its
/// light), non-finite values count as 0.
pub fn tile_luminance(test: &[f32], reference: &[f32], width: u32, height: u32) -> TileError {
    let (tw, th) = (width.div_ceil(TILE_PX), height.div_ceil(TILE_PX));
    let mut sums = vec![(0.0f64, 0.0f64, 0u32); (tw * th) as usize];
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize * 4;
            let s = &mut sums[((y / TILE_PX) * tw + x / TILE_PX) as usize];
            s.0 += luminance(&test[i..i + 4]);
            s.1 += luminance(&reference[i..i + 4]);
            s.2 += 1;
        }
    }
    let mut result = TileError { tiles: sums.len(), tiles_off: 0, worst: None };
    for (k, &(t, r, n)) in sums.iter().enumerate() {
        let (t, r) = (t / n as f64, r / n as f64);
        let relative_error = (t - r) / r.max(TILE_FLOOR);
        if relative_error.abs() > TILE_THRESHOLD {
            result.tiles_off += 1;
        }
        if result.worst.is_none_or(|w| relative_error.abs() > w.relative_error.abs()) {
            let tile = (k as u32 % tw, k as u32 / tw);
            result.worst = Some(WorstTile {
                tile,
                x: tile.0 * TILE_PX,
                y: tile.1 * TILE_PX,
                test_mean: t,
                reference_mean: r,
                relative_error,
            });
        }
    }
    result
}

/// The output's alpha against the input's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlphaRange {
    pub min: f32,
    pub max: f32,
    /// Pixels whose input alpha is 1 (>= 1 - 1e-6).
    pub opaque_in: usize,
    /// Of those, the pixels whose output alpha is below ALPHA_OPAQUE (0.999): holes.
    pub holes: usize,
}

/// The alpha range of `output` (RGBA) and its holes where `input` (RGBA of the same size) is
/// opaque. Non-finite alpha counts as 0.
pub fn alpha_range(output: &[f32], input: &[f32]) -> AlphaRange {
    let mut r = AlphaRange { min: f32::INFINITY, max: f32::NEG_INFINITY, opaque_in: 0, holes: 0 };
    for (o, i) in output.chunks_exact(4).zip(input.chunks_exact(4)) {
        let a = if o[3].is_finite() { o[3] } else { 0.0 };
        r.min = r.min.min(a);
        r.max = r.max.max(a);
        if i[3] >= 1.0 - 1e-6 {
            r.opaque_in += 1;
            if a < ALPHA_OPAQUE {
                r.holes += 1;
            }
        }
    }
    r
}

/// sRGB 8-bit of linear RGBA (values clamped to [0, 1]), for FLIP's LDR form.
fn srgb8(rgba: &[f32]) -> Vec<u8> {
    rgba.chunks_exact(4)
        .flat_map(|p| {
            [p[0], p[1], p[2]].map(|v| {
                let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
                let s = if v <= 0.0031308 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
                (s * 255.0 + 0.5) as u8
            })
        })
        .collect()
}

/// Mean FLIP (0 identical .. 1) of `test` against `reference` (both linear RGBA of
/// width x height), on their sRGB 8-bit previews (values clamped to [0, 1]), at FLIP's default
/// 67 pixels per degree.
pub fn flip_mean(test: &[f32], reference: &[f32], width: u32, height: u32) -> f64 {
    let r = nv_flip::FlipImageRgb8::with_data(width, height, &srgb8(reference));
    let t = nv_flip::FlipImageRgb8::with_data(width, height, &srgb8(test));
    let map = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    nv_flip::FlipPool::from_image(&map).mean() as f64
}

/// What a compositor sees first: the tiles off, FLIP and the alpha.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFidelity {
    pub tiles: TileError,
    pub flip_mean: f64,
    pub alpha: AlphaRange,
}

/// [`tile_luminance`] and [`flip_mean`] of `test` against `reference`, and the [`alpha_range`]
/// of `test` against the frame's `input` (all RGBA of width x height).
pub fn local_fidelity(test: &[f32], reference: &[f32], input: &[f32], width: u32, height: u32) -> LocalFidelity {
    LocalFidelity {
        tiles: tile_luminance(test, reference, width, height),
        flip_mean: flip_mean(test, reference, width, height),
        alpha: alpha_range(test, input),
    }
}

/// The definitions, for reports.
pub fn local_fidelity_legend() -> String {
    format!(
        "Tiles off: the share of the {TILE_PX}x{TILE_PX}-px tiles (edge tiles partial) whose mean Rec.709 luminance differs \
         from the reference's by more than {:.0}%: |mean_test - mean_ref| / max(mean_ref, {TILE_FLOOR}) > {TILE_THRESHOLD} \
         (the floor keeps dark tiles from counting noise); the worst tile's signed relative error and its tile (column, \
         row) and top-left pixel. FLIP: mean of the FLIP map of the sRGB 8-bit previews (0 = identical). Alpha: the \
         output's minimum alpha and the pixels below {ALPHA_OPAQUE} where the input's alpha is 1.",
        100.0 * TILE_THRESHOLD
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_zero_error() {
        let a = vec![0.5f32, 0.25, 2.0, 1.0, 0.1, 0.2, 0.3, 1.0];
        let e = compare_rgba(&a, &a);
        assert_eq!((e.rmse, e.mean_abs, e.relative_energy_error), (0.0, 0.0, 0.0));
        assert!(e.psnr_db.is_infinite());
    }

    #[test]
    fn known_difference() {
        // One pixel, every channel off by 0.1 against a reference of 0.5: RMSE 0.1,
        // PSNR (peak 1) = 20 dB, energy +20%; alpha ignored.
        let e = compare_rgba(&[0.6, 0.6, 0.6, 0.0], &[0.5, 0.5, 0.5, 1.0]);
        assert!((e.rmse - 0.1).abs() < 1e-6 && (e.psnr_db - 20.0).abs() < 1e-4);
        assert!((e.relative_energy_error - 0.2).abs() < 1e-6);
        // Matched: 0.6 scaled by 1.5/1.8 is 0.5, no error left.
        assert!(e.rmse_matched.abs() < 1e-6);
    }

    #[test]
    fn matched_error_scales_to_the_reference_energy_then_clamps_at_4() {
        // Test twice as bright as the reference everywhere: matched error 0. Then a highlight
        // of 100 against 10: both clamp to 4 after matching, only the other pixel differs.
        let e = compare_rgba(&[2.0, 2.0, 2.0, 1.0, 4.0, 4.0, 4.0, 1.0], &[1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 1.0]);
        assert!(e.rmse_matched.abs() < 1e-12);
        let e =
            compare_rgba(&[100.0, 100.0, 100.0, 1.0, 1.0, 1.0, 1.0, 1.0], &[10.0, 10.0, 10.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        // scale = 11 / 101; pixel 2: 11/101 vs 1; pixel 1: min(1100/101, 4) = 4 vs 4.
        let expected = ((1.0f64 - 11.0 / 101.0).powi(2) * 3.0 / 6.0).sqrt();
        assert!((e.rmse_matched - expected).abs() < 1e-9, "{} vs {expected}", e.rmse_matched);
    }
    /// A w x h RGBA image of one grey value, alpha 1.
    fn grey(w: u32, h: u32, v: f32) -> Vec<f32> {
        (0..w * h).flat_map(|_| [v, v, v, 1.0]).collect()
    }

    #[test]
    fn one_tile_darkened_by_10_percent_is_one_tile_off() {
        // 64x48: 4x3 = 12 tiles. Tile (2, 1) darkened by 10%: exactly 1 of 12 off, worst -0.1 there.
        let (w, h) = (64, 48);
        let reference = grey(w, h, 0.5);
        let mut test = reference.clone();
        for y in 16..32 {
            for x in 32..48 {
                for c in 0..3 {
                    test[((y * w + x) * 4 + c) as usize] *= 0.9;
                }
            }
        }
        let e = tile_luminance(&test, &reference, w, h);
        assert_eq!((e.tiles, e.tiles_off), (12, 1));
        assert!((e.share_off() - 1.0 / 12.0).abs() < 1e-12);
        let worst = e.worst.unwrap();
        assert_eq!((worst.tile, worst.x, worst.y), ((2, 1), 32, 16));
        assert!((worst.relative_error + 0.1).abs() < 1e-6, "{worst:?}");
        assert_eq!(tile_luminance(&reference, &reference, w, h).tiles_off, 0);
    }

    #[test]
    fn tiles_within_5_percent_pass_and_partial_edge_tiles_count() {
        // 40x20: 3x2 = 6 tiles, the right column 8 px wide, the bottom row 4 px tall. Every pixel
        // 4% brighter: no tile off. One pixel of the bottom-right tile (8x4 = 32 px) made 3x
        // brighter: its mean rises by 2/32 = 6.25% > 5%.
        let (w, h) = (40, 20);
        let reference = grey(w, h, 0.25);
        let mut test: Vec<f32> =
            reference.iter().enumerate().map(|(i, v)| if i % 4 == 3 { *v } else { v * 1.04 }).collect();
        assert_eq!(tile_luminance(&test, &reference, w, h).tiles_off, 0);
        test = reference.clone();
        let i = ((19 * w + 39) * 4) as usize;
        for c in 0..3 {
            test[i + c] = 0.75;
        }
        let e = tile_luminance(&test, &reference, w, h);
        assert_eq!((e.tiles, e.tiles_off), (6, 1));
        let worst = e.worst.unwrap();
        assert_eq!((worst.tile, worst.x, worst.y), ((2, 1), 32, 16));
        assert!((worst.relative_error - 0.0625).abs() < 1e-6);
    }

    #[test]
    fn dark_tiles_are_judged_against_the_floor() {
        // Reference 0.001, test 0.0019: 90% brighter, but 0.0009 / TILE_FLOOR = 4.5% -> not off.
        // Test 0.0021: 0.0011 / 0.02 = 5.5% -> off. Luminance weights sum to 1 on grey.
        let (w, h) = (16, 16);
        let e = tile_luminance(&grey(w, h, 0.0019), &grey(w, h, 0.001), w, h);
        assert_eq!(e.tiles_off, 0);
        assert!((e.worst.unwrap().relative_error - 0.045).abs() < 1e-6);
        assert_eq!(tile_luminance(&grey(w, h, 0.0021), &grey(w, h, 0.001), w, h).tiles_off, 1);
        // Luminance is Rec.709's: pure green 1 is 0.7152.
        assert!((luminance(&[0.0, 1.0, 0.0, 1.0]) - 0.7152).abs() < 1e-12);
    }

    #[test]
    fn alpha_holes_count_only_where_the_input_is_opaque() {
        // Input: opaque, opaque, transparent. Output alpha 0.5, 0.9995, 0.2: min 0.2, one hole
        // (the first; the third's input was not opaque).
        let input = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        let output = [0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.9995, 0.0, 0.0, 0.0, 0.2];
        let a = alpha_range(&output, &input);
        assert_eq!((a.min, a.max, a.opaque_in, a.holes), (0.2, 0.9995, 2, 1));
    }

    #[test]
    fn flip_is_zero_for_identical_images_and_grows_with_the_difference() {
        let (w, h) = (32, 32);
        let a = grey(w, h, 0.3);
        assert_eq!(flip_mean(&a, &a, w, h), 0.0);
        let small = flip_mean(&grey(w, h, 0.32), &a, w, h);
        let large = flip_mean(&grey(w, h, 0.6), &a, w, h);
        assert!(0.0 < small && small < large && large <= 1.0, "{small} {large}");
        let f = local_fidelity(&grey(w, h, 0.6), &a, &a, w, h);
        assert_eq!((f.tiles.tiles_off, f.alpha.holes), (4, 0));
        assert_eq!(f.flip_mean, large);
    }
}
