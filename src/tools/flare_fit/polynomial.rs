//! Walch 2017 ch. 8: a ghost's per-angle fits (ch. 7) as polynomials of the angle, the stage
//! that both `realcam flare-fit` paths (traced images, [`super::fit_traced_ghosts`], and
//! captures, [`super::capture::folder::fit_samples`]) share ([`fitted_range`]).
//!
//! Eq 6.4's primitive has directions along which its image does not change, so a sample's fit
//! is one of many equally good ones: an inner fade range F_i past the ghost's deepest point
//! draws what a shorter one does with another I_i, and a flat interior is drawn by F_i near 0
//! (I_i everywhere) as well as by a long, steep fade (I_b everywhere). Neighbouring angles
//! settle at different points of those families, and a polynomial through the parameters of
//! the samples need not draw any of them (the clean captures of ghost 4/0: F_i 67, 67, 67,
//! 3645 px, its parabola below 0 at 3 degrees, 5.5x the light there). [`super::fit`] keeps F_i
//! within the primitive's size (no image is lost by that), and here each sample the
//! polynomials miss is fitted again from the polynomials' value at its angle (sec. 7.3's seed
//! with every sample known: a point of its family near its neighbours'), the refit kept
//! where it is about as good as the first, and the polynomials made again.

use super::{
    energy_centroid, energy_error, fit_near, mse, Fit, FitOptions, FittedRange, GreyImage, RESTART_ENERGY_ERROR,
};
use crate::io::lens_file::FittedGhostSpec;
use crate::optics::bezier_ghost::{poly_eval, polyfit, BezierGhost, GhostPolynomials, Transfer};

/// Ch. 8: the fitted range as polynomials of the angle.
pub fn polynomials(samples: &[(f64, GreyImage)], fits: &[Fit], order: usize) -> GhostPolynomials {
    let angles: Vec<f64> = samples.iter().map(|s| s.0).take(fits.len()).collect();
    let ghosts: Vec<BezierGhost> = fits.iter().map(|f| f.ghost).collect();
    GhostPolynomials::fit(&angles, &ghosts, order)
}

/// The light of the polynomials refitted to their own shapes: the coordinate descent trades
/// I_b, I_i and the fades from one sample to the next, and a polynomial through those loses
/// energy (22.5% on the Tessar's 4/0 at 2..5 degrees) although every sample keeps it. The
/// image is linear in I_b and I_i for a given shape and fades (eq 6.4: I_b (1 - w) + I_i w
/// inside, I_b (1 - w) outside), so at each sample the primitive of the polynomials gets the
/// least-squares I_b and I_i of its image (kept >= 0), scaled together so that its energy is
/// the sample's; their polynomials then replace those of I_b and I_i.
pub fn relight(samples: &[(f64, GreyImage)], poly: &GhostPolynomials, order: usize) -> GhostPolynomials {
    let (mut angles, mut borders, mut inners) = (Vec::new(), Vec::new(), Vec::new());
    for (a, image) in samples {
        let g = poly.at(*a);
        let with = |border: f64, inner: f64| {
            image.draw(&BezierGhost { transfer: Transfer { border, inner, ..g.transfer }, ..g })
        };
        let (b1, b2, t) = (with(1.0, 0.0), with(0.0, 1.0), &image.values);
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
        let (a11, a12, a22, r1, r2) = (dot(&b1, &b1), dot(&b1, &b2), dot(&b2, &b2), dot(&b1, t), dot(&b2, t));
        let det = a11 * a22 - a12 * a12;
        let (mut ib, mut ii) = if det > 1e-12 * a11 * a22 {
            ((r1 * a22 - r2 * a12) / det, (r2 * a11 - r1 * a12) / det)
        } else {
            (g.transfer.border, g.transfer.inner)
        };
        // Kept >= 0: the other one alone then.
        if ib < 0.0 {
            (ib, ii) = (0.0, if a22 > 0.0 { (r2 / a22).max(0.0) } else { 0.0 });
        } else if ii < 0.0 {
            (ib, ii) = (if a11 > 0.0 { (r1 / a11).max(0.0) } else { 0.0 }, 0.0);
        }
        let (e1, e2, e_t) = (b1.iter().sum::<f64>(), b2.iter().sum::<f64>(), t.iter().sum::<f64>());
        let drawn = ib * e1 + ii * e2;
        if drawn > 0.0 && drawn.is_finite() {
            let k = e_t / drawn;
            (ib, ii) = (k * ib, k * ii);
        }
        angles.push(*a);
        borders.push(ib);
        inners.push(ii);
    }
    let mut out = poly.clone();
    if !angles.is_empty() {
        out.coefficients[7] = polyfit(&angles, &borders, order);
        out.coefficients[8] = polyfit(&angles, &inners, order);
    }
    out
}

/// Weight of a sample's relative energy error against its relative RMS difference in
/// [`relight_jointly`].
pub const ENERGY_WEIGHT: f64 = 100.0;

/// The polynomials of I_b and I_i refitted together to every sample's image and energy: for
/// the polynomials' shape and fades at each sample the image is linear in I_b and I_i (eq
/// 6.4), and so in the coefficients of their polynomials; the coefficients minimise the sum
/// over the samples of the squared difference of the images over the sample's own (each sample
/// weighs alike) plus [`ENERGY_WEIGHT`] times the squared relative energy error. Unlike
/// [`relight`] (each sample's lights, then polynomials through them) the polynomials are what
/// is fitted, so a sample's energy is held by the polynomial itself (exactly, with as many
/// coefficients as samples).
pub fn relight_jointly(samples: &[(f64, GreyImage)], poly: &GhostPolynomials, order: usize) -> GhostPolynomials {
    let order = order.min(samples.len().saturating_sub(1));
    let m = order + 1;
    let (lo, hi) = samples.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), s| (l.min(s.0), h.max(s.0)));
    let (mid, half) = (0.5 * (lo + hi), (0.5 * (hi - lo)).max(1e-12));
    // Unknowns: I_b's coefficients of powers of u = (a - mid) / half, then I_i's.
    let n = 2 * m;
    let mut a = vec![vec![0.0; n + 1]; n];
    let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
    for (angle, image) in samples {
        let g = poly.at(*angle);
        let with = |border: f64, inner: f64| {
            image.draw(&BezierGhost { transfer: Transfer { border, inner, ..g.transfer }, ..g })
        };
        let (b, t) = ([with(1.0, 0.0), with(0.0, 1.0)], &image.values);
        let (tt, e_t) = (dot(t, t), t.iter().sum::<f64>());
        if !(tt > 0.0 && e_t > 0.0) {
            continue;
        }
        let e = [b[0].iter().sum::<f64>(), b[1].iter().sum::<f64>()];
        let u = (angle - mid) / half;
        let row = |s: usize, k: usize| (s, k, u.powi(k as i32));
        for (s1, k1, p1) in (0..2).flat_map(|s| (0..m).map(move |k| row(s, k))) {
            for (s2, k2, p2) in (0..2).flat_map(|s| (0..m).map(move |k| row(s, k))) {
                let g = dot(&b[s1], &b[s2]) / tt + ENERGY_WEIGHT * e[s1] * e[s2] / (e_t * e_t);
                a[s1 * m + k1][s2 * m + k2] += g * p1 * p2;
            }
            a[s1 * m + k1][n] += (dot(&b[s1], t) / tt + ENERGY_WEIGHT * e[s1] / e_t) * p1;
        }
    }
    let Some(x) = solve(a) else { return poly.clone() };
    // Back to powers of the angle: each polynomial through m of its own points.
    let nodes: Vec<f64> = (0..m).map(|i| lo + (hi - lo) * i as f64 / (m - 1).max(1) as f64).collect();
    let mut out = poly.clone();
    for (s, k) in [(0, 7), (1, 8)] {
        let c = &x[s * m..(s + 1) * m];
        let values: Vec<f64> = nodes.iter().map(|v| poly_eval(c, (v - mid) / half)).collect();
        out.coefficients[k] = polyfit(&nodes, &values, order);
    }
    out
}

/// The augmented system `a` (n rows of n + 1) solved by Gauss-Jordan with partial pivoting;
/// None where it is singular.
fn solve(mut a: Vec<Vec<f64>>) -> Option<Vec<f64>> {
    let n = a.len();
    let scale = a.iter().flat_map(|r| r[..n].iter()).fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..n {
        let pivot = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        a.swap(col, pivot);
        let p = a[col][col];
        if !(p.abs() > 1e-14 * scale) {
            return None;
        }
        let pivot_row = a[col].clone();
        for (r, row) in a.iter_mut().enumerate() {
            if r != col {
                let f = row[col] / p;
                row.iter_mut().zip(&pivot_row).for_each(|(v, q)| *v -= f * q);
            }
        }
    }
    let x: Vec<f64> = (0..n).map(|k| a[k][n] / a[k][k]).collect();
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The worst, over the samples, of the RMS difference over the traced peak plus the relative
/// energy error of the polynomials' primitive.
pub fn worst_error(samples: &[(f64, GreyImage)], poly: &GhostPolynomials) -> f64 {
    samples
        .iter()
        .map(|(a, image)| {
            let drawn = image.draw(&poly.at(*a));
            let peak = image.values.iter().copied().fold(0.0, f64::max);
            let e_t = energy_centroid(image, &image.values).0;
            mse(&drawn, &image.values).sqrt() / peak + (energy_centroid(image, &drawn).0 / e_t - 1.0).abs()
        })
        .fold(0.0, f64::max)
}

/// The polynomials of `fits`, their lights as they are, refitted by [`relight`] or by
/// [`relight_jointly`]: whichever draws the samples best ([`worst_error`]; a polynomial shape
/// far from a sample's can draw little of it, and scaling that up misleads the others).
fn best_polynomials(samples: &[(f64, GreyImage)], fits: &[Fit], order: usize) -> GhostPolynomials {
    let plain = polynomials(samples, fits, order);
    let relit = relight(samples, &plain, order);
    let jointly = relight_jointly(samples, &plain, order);
    [relit, jointly, plain]
        .into_iter()
        .map(|p| (worst_error(samples, &p), p))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, p)| p)
        .expect("three candidates")
}

/// The angles of the samples whose own fit draws their light within [`RESTART_ENERGY_ERROR`]
/// but the polynomials do not: where the polynomials fail to represent the fits.
pub fn missed_angles(samples: &[(f64, GreyImage)], fits: &[Fit], poly: &GhostPolynomials) -> Vec<f64> {
    samples
        .iter()
        .zip(fits)
        .filter(|((a, image), f)| {
            energy_error(image, &f.ghost) <= RESTART_ENERGY_ERROR
                && energy_error(image, &poly.at(*a)) > RESTART_ENERGY_ERROR
        })
        .map(|((a, _), _)| *a)
        .collect()
}

/// The weight of the distance from the polynomials' value in a refit, in units of the sample's
/// first cost ([`super::fit_near`]: a step of 5% of the ghost's size away costs a tenth of it).
pub const ANCHOR_WEIGHT: f64 = 10.0;

/// Passes of [`smooth_fits`] at most.
pub const SMOOTHING_PASSES: usize = 3;

/// How much costlier than a sample's first fit a refit from the polynomials may be and still
/// replace it (as good as far as the light goes: it is also held to the energy tolerance).
pub const REFIT_COST_SLACK: f64 = 1.5;

/// Ch. 8 with the samples made consistent: while the polynomials of `fits` miss a sample whose
/// fit draws its light ([`missed_angles`]), every sample is fitted again from the polynomials'
/// value at its angle, the refit kept where it draws its light within [`RESTART_ENERGY_ERROR`]
/// (or no worse than the first fit) at a cost at most [`REFIT_COST_SLACK`] times the first's;
/// at most [`SMOOTHING_PASSES`] times. The fits are updated; the polynomials returned.
pub fn smooth_fits(
    samples: &[(f64, GreyImage)],
    fits: &mut [Fit],
    order: usize,
    options: &FitOptions,
) -> GhostPolynomials {
    let samples = &samples[..fits.len()];
    let first: Vec<Fit> = fits.to_vec();
    let mut poly = best_polynomials(samples, fits, order);
    for _ in 0..SMOOTHING_PASSES {
        if missed_angles(samples, fits, &poly).is_empty() {
            break;
        }
        for (((a, image), f), f0) in samples.iter().zip(fits.iter_mut()).zip(&first) {
            let near = poly.at(*a);
            let refit = fit_near(image, &near, Some((&near, ANCHOR_WEIGHT * f0.cost)), options);
            let e = energy_error(image, &refit.ghost);
            let good = e <= RESTART_ENERGY_ERROR.max(energy_error(image, &f0.ghost));
            if good && refit.cost <= REFIT_COST_SLACK * f0.cost {
                *f = refit;
            }
        }
        poly = best_polynomials(samples, fits, order);
    }
    poly
}

/// One ghost in one channel fitted over the samples (`fits`, ch. 7) made polynomials of the
/// angle ([`smooth_fits`]) and measured against the samples: the stage both paths share.
pub fn fitted_range(
    samples: &[(f64, GreyImage)],
    mut fits: Vec<Fit>,
    label: &str,
    channel: usize,
    frame_px: [u32; 2],
    order: usize,
    options: &FitOptions,
) -> FittedRange {
    let used = &samples[..fits.len()];
    let poly = smooth_fits(used, &mut fits, order, options);
    let (mut rmse, mut energy, mut moved, mut fit_rmse, mut fit_energy) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for ((a, image), fit1) in used.iter().zip(&fits) {
        let drawn = image.draw(&poly.at(*a));
        let own = image.draw(&fit1.ghost);
        let peak = image.values.iter().copied().fold(0.0, f64::max);
        let (e_t, c_t) = energy_centroid(image, &image.values);
        let (e_f, c_f) = energy_centroid(image, &drawn);
        fit_rmse = fit_rmse.max(mse(&own, &image.values).sqrt() / peak);
        fit_energy = fit_energy.max((energy_centroid(image, &own).0 / e_t - 1.0).abs());
        rmse = rmse.max(mse(&drawn, &image.values).sqrt() / peak);
        energy = energy.max((e_f / e_t - 1.0).abs());
        moved = moved.max((c_t[0] - c_f[0]).hypot(c_t[1] - c_f[1]));
    }
    FittedRange {
        spec: FittedGhostSpec::new(label, channel as u32, frame_px, &poly),
        samples: fits.len(),
        worst_rmse_over_peak: rmse,
        worst_energy_error: energy,
        worst_centroid_px: moved,
        worst_fit_rmse_over_peak: fit_rmse,
        worst_fit_energy_error: fit_energy,
        missed_angles_deg: missed_angles(used, &fits, &poly),
    }
}
