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
}
