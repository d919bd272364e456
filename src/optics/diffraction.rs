//! Diffraction point-spread function of a defocused circular aperture (Lommel functions).
//!
//! Source: Potmesil & Chakravarty 1981, *A Lens and Aperture Camera Model for Synthetic Image
//! Generation*, sec. 2.4, eqs 12-19, which take the result of Lommel (1885) as presented by
//! Born & Wolf, *Principles of Optics*, sec. 8.8 ("The three-dimensional light distribution
//! near focus").
//!
//! # Optical coordinates
//!
//! A thin lens with aperture radius `a` (diameter `d = 2a`) focuses a point at image distance
//! `f` (the paper uses the focal length `F`; for a finite object distance the image distance
//! takes its place). A plane a distance `z` behind (or in front of) that focus and a radius `r`
//! in that plane map to the dimensionless coordinates
//!
//! - `u = k (a/f)^2 z` (defocus, eq 15 and eq 17),
//! - `v = k (a/f) r` (radius, eq 16 and eq 18),
//!
//! with `k = 2π/λ`. See [`optical_coordinates`].
//!
//! # Normalization
//!
//! [`psf_intensity`] is `I(u, v) / I0`: the intensity relative to the focal-point intensity
//! `I0 = I(0, 0)`, so `psf_intensity(0.0, 0.0) == 1`. It is even in `u` and in `v`. Its
//! integral over the plane, `∫ I(u, v) 2π v dv`, is `4π` for every defocus `u`
//! ([`PSF_TOTAL_ENERGY_V2`]); [`encircled_energy`] divides by it.
//!
//! # Geometric circle of confusion
//!
//! For `|u| >> 1` the light fills the geometric shadow of the aperture, a disk whose edge is
//! at `v = |u|`, i.e. `r = a |z| / f` (to first order in `z/f`): the geometric circle of
//! confusion, whose radius is half of `|ThinLens::coc_mm|` (a signed diameter). Inside it (`v < |u|`) the intensity
//! is about `(2/u)^2` with rings; outside it falls off like `v^-3` (in area density).
//!
//! # Numerics
//!
//! The paper gives only the series of eq 14 (Born & Wolf's `U_n`, ratio `u/v`), which
//! converges quickly only outside the circle of confusion (`|u| < v`). Inside it we use the
//! companion series `V_n` (ratio `v/u`) and Lommel's identity
//! `U_n - (-1)^n V_{2-n} = cos(½(u + v²/u) - nπ/2)` (Born & Wolf 8.8).
//! Both series are written in terms of the reduced Bessel function
//! `Ĵ_m(x) = J_m(x) / (x/2)^m`, which removes every `1/u` and `1/v` factor: the intensity is
//! regular on the axis (`v = 0`) and at focus (`u = 0`).

use std::f64::consts::PI;

/// Representative wavelengths of the red, green and blue channels, in nanometres (R, G, B).
pub const WAVELENGTHS_RGB_NM: [f64; 3] = [650.0, 550.0, 450.0];

/// `∫_0^∞ I(u, v) 2π v dv` for the normalization `I(0, 0) = 1`: the same for every `u`
/// (energy conservation); for the Airy pattern `∫ [2 J1(v)/v]^2 2π v dv = 4π`.
pub const PSF_TOTAL_ENERGY_V2: f64 = 4.0 * PI;

/// Arguments at or below this use power series for the Bessel functions (no cancellation
/// worse than a factor `I0(4) ≈ 11`); above it, Miller's backward recurrence.
const SMALL_ARGUMENT: f64 = 4.0;

/// Defocus at or below which [`psf_intensity`] uses the `U` series even inside the circle of
/// confusion: the `V` form subtracts terms of size 1 to get a result of size `u^2`.
const SMALL_DEFOCUS: f64 = 4.0;

/// A series term whose magnitude bound is below this fraction of the largest one is dropped.
const NEGLIGIBLE_TERM: f64 = 1e-19;

/// Miller's recurrence rescales its values by `1/MILLER_RESCALE` once one exceeds this.
const MILLER_RESCALE: f64 = 1e250;

/// Extra orders above the negligible order at which Miller's recurrence starts.
const MILLER_EXTRA_ORDERS: usize = 20;

/// Arguments at or above this may use Hankel's asymptotic expansion for `J_0`, `J_1`
/// (its smallest term is about `e^{-2x}`).
const LARGE_ARGUMENT: f64 = 50.0;

/// Highest order reached by forward recurrence from Hankel's `J_0`, `J_1` (and at most `x/2`,
/// well below the turning point, where forward recurrence is stable).
const FORWARD_MAX_ORDER: f64 = 500.0;

/// Gauss-Legendre nodes per unit-width panel in [`encircled_energy`].
const ENERGY_NODES_PER_PANEL: usize = 10;

// ---------------------------------------------------------------------------------------------
// Bessel functions of the first kind, integer order
// ---------------------------------------------------------------------------------------------

/// Bessel function of the first kind `J_n(x)` for integer order `n >= 0` and real `x`
/// (negative `x` by `J_n(-x) = (-1)^n J_n(x)`).
///
/// Power series for `|x| <= 4`; Hankel's asymptotic expansion plus forward recurrence for
/// `x >= 50` and `n <= min(x/2, 500)`; otherwise Miller's backward recurrence normalized by
/// `J_0 + 2 Σ J_2k = 1`. Absolute accuracy about `1e-15` (measured up to `x = 10^6` and for
/// orders in the thousands); the Miller branch costs `O(max(n, x))`.
pub fn bessel_j(n: u32, x: f64) -> f64 {
    if x < 0.0 {
        return odd_order_sign(n as i64) * bessel_j(n, -x);
    }
    bessel_j_sequence(n as usize, x)[n as usize]
}

/// `[J_0(x), J_1(x), ..., J_{n_max}(x)]` for `x >= 0` (NaN entries for a NaN or negative
/// `x`, zeros beyond order 0 for an infinite one: `J_n(x) -> 0`).
pub fn bessel_j_sequence(n_max: usize, x: f64) -> Vec<f64> {
    if x.is_nan() || x < 0.0 {
        return vec![f64::NAN; n_max + 1];
    }
    if x.is_infinite() {
        return vec![0.0; n_max + 1];
    }
    if x <= SMALL_ARGUMENT {
        bessel_j_sequence_power_series(n_max, x)
    } else if uses_hankel_forward(n_max, x) {
        bessel_j_sequence_hankel_forward(n_max, x)
    } else {
        bessel_j_sequence_miller(n_max, x)
    }
}

/// Whether orders `0 ..= n_max` at `x` come from Hankel's expansion and forward recurrence.
fn uses_hankel_forward(n_max: usize, x: f64) -> bool {
    x >= LARGE_ARGUMENT && n_max as f64 <= (0.5 * x).min(FORWARD_MAX_ORDER)
}

/// `(-1)^n`.
fn odd_order_sign(n: i64) -> f64 {
    if n.rem_euclid(2) == 1 {
        -1.0
    } else {
        1.0
    }
}

/// `m! (2/x)^m J_m(x) = 0F1(; m+1; -x²/4) = Σ_j (-x²/4)^j m! / (j! (m+j)!)`.
///
/// Bounded by 1 in magnitude for real `x`; converges fast for `x <= 4`.
fn bessel_series_factor(m: usize, x: f64) -> f64 {
    let minus_quarter_x2 = -0.25 * x * x;
    let mut term = 1.0;
    let mut sum = 1.0;
    for j in 1..200 {
        term *= minus_quarter_x2 / (j as f64 * (m + j) as f64);
        sum += term;
        if term.abs() <= 1e-18 * sum.abs() {
            break;
        }
    }
    sum
}

/// `J_m(x) = (x/2)^m / m! * 0F1(; m+1; -x²/4)` for every `m <= n_max`, small `x`.
fn bessel_j_sequence_power_series(n_max: usize, x: f64) -> Vec<f64> {
    let half_x = 0.5 * x;
    let mut leading = 1.0; // (x/2)^m / m!, by a running product: no overflow
    let mut out = Vec::with_capacity(n_max + 1);
    for m in 0..=n_max {
        if m > 0 {
            leading *= half_x / m as f64;
        }
        out.push(if leading == 0.0 { 0.0 } else { leading * bessel_series_factor(m, x) });
    }
    out
}

/// Order above which `|J_k(x)|` is below about `1e-20`: past the turning point `k = x` the
/// Bessel function decays like the Airy function `Ai(2^(1/3) (k - x) / x^(1/3))`.
fn bessel_negligible_order(x: f64) -> usize {
    (x + 10.0 * x.cbrt() + 30.0).ceil() as usize
}

/// Receives the unnormalized values of Miller's backward recurrence, highest order first.
trait MillerVisitor {
    /// `value` is `c J_k(x)` for the current (unknown) scale `c`.
    fn visit(&mut self, k: usize, value: f64);
    /// Every value visited so far must be multiplied by `factor` to stay on the current scale.
    fn rescale(&mut self, factor: f64);
}

/// Miller's backward recurrence `J_{k-1} = (2k/x) J_k - J_{k+1}` for `x > 0`, started with an
/// arbitrary tiny value well above both `highest_order` and `x` (where the minimal solution
/// `J` dominates), rescaled against overflow. Visits orders `start ..= 0` and returns the
/// normalization `J_0 + 2 Σ_{k>=1} J_2k` on the final scale (it equals 1 for the true `J`).
fn miller_backward(x: f64, highest_order: usize, visitor: &mut impl MillerVisitor) -> f64 {
    let start = highest_order.max(bessel_negligible_order(x)) + MILLER_EXTRA_ORDERS;
    let start = start + start % 2; // even, so that the even-order sum is complete
    let mut j_above = 0.0; // J_{k+1}
    let mut j_here = 1e-30; // J_k
    let mut even_sum = 0.0; // Σ J_2k for the orders 2k >= 2 visited so far
    for k in (1..=start).rev() {
        visitor.visit(k, j_here);
        if k % 2 == 0 {
            even_sum += j_here;
        }
        let j_below = (2.0 * k as f64 / x) * j_here - j_above;
        j_above = j_here;
        j_here = j_below;
        if j_here.abs() > MILLER_RESCALE {
            let factor = 1.0 / MILLER_RESCALE;
            j_here *= factor;
            j_above *= factor;
            even_sum *= factor;
            visitor.rescale(factor);
        }
    }
    visitor.visit(0, j_here);
    j_here + 2.0 * even_sum
}

/// Collects `J_0 .. J_{n_max}` from [`miller_backward`].
struct BesselSequence {
    values: Vec<f64>,
}

impl MillerVisitor for BesselSequence {
    fn visit(&mut self, k: usize, value: f64) {
        if let Some(slot) = self.values.get_mut(k) {
            *slot = value;
        }
    }
    fn rescale(&mut self, factor: f64) {
        self.values.iter_mut().for_each(|value| *value *= factor);
    }
}

/// `J_0 .. J_{n_max}` by Miller's backward recurrence, normalized by `J_0 + 2 Σ J_2k = 1`.
fn bessel_j_sequence_miller(n_max: usize, x: f64) -> Vec<f64> {
    let mut sequence = BesselSequence { values: vec![0.0; n_max + 1] };
    let norm = miller_backward(x, n_max, &mut sequence);
    sequence.values.iter().map(|value| value / norm).collect()
}

/// `J_0 .. J_{n_max}` for `x >= 50`, `n_max <= x/2`: `J_0`, `J_1` from Hankel's expansion,
/// then forward recurrence `J_{k+1} = (2k/x) J_k - J_{k-1}`. Cost `O(n_max)`, not `O(x)`.
fn bessel_j_sequence_hankel_forward(n_max: usize, x: f64) -> Vec<f64> {
    let (j0, j1) = bessel_j01_hankel(x);
    let mut out = Vec::with_capacity(n_max + 1);
    out.push(j0);
    if n_max >= 1 {
        out.push(j1);
    }
    for k in 1..n_max {
        let next = (2.0 * k as f64 / x) * out[k] - out[k - 1];
        out.push(next);
    }
    out
}

/// `(J_0(x), J_1(x))` by Hankel's asymptotic expansion (Abramowitz & Stegun 9.2.5),
/// `J_ν(x) = sqrt(2/πx) [P cos χ - Q sin χ]`, `χ = x - (ν/2 + 1/4)π`, for `x >= 50`.
/// The phase shifts are applied with exact angle sums, not by rounding `x - π/4`.
fn bessel_j01_hankel(x: f64) -> (f64, f64) {
    let (p0, q0) = hankel_p_q(0.0, x);
    let (p1, q1) = hankel_p_q(1.0, x);
    let (sin_x, cos_x) = x.sin_cos();
    let amplitude = (2.0 / (PI * x)).sqrt() * std::f64::consts::FRAC_1_SQRT_2;
    // χ = x - π/4:  cos χ = (cos x + sin x)/√2, sin χ = (sin x - cos x)/√2
    let j0 = amplitude * (p0 * (cos_x + sin_x) - q0 * (sin_x - cos_x));
    // χ = x - 3π/4: cos χ = (sin x - cos x)/√2, sin χ = -(sin x + cos x)/√2
    let j1 = amplitude * (p1 * (sin_x - cos_x) + q1 * (sin_x + cos_x));
    (j0, j1)
}

/// Hankel's `P(ν, x) = Σ (-1)^k a_2k / x^2k` and `Q(ν, x) = Σ (-1)^k a_2k+1 / x^2k+1`,
/// `a_k = (4ν² - 1²)(4ν² - 3²)...(4ν² - (2k-1)²) / (k! 8^k)`, summed while the terms shrink.
fn hankel_p_q(order: f64, x: f64) -> (f64, f64) {
    let mu = 4.0 * order * order;
    let (mut p, mut q) = (1.0, 0.0);
    let mut term: f64 = 1.0; // a_k / x^k
    for k in 1..200 {
        let odd = (2 * k - 1) as f64;
        let next = term * (mu - odd * odd) / (k as f64 * 8.0 * x);
        if next.abs() >= term.abs() && k > 2 {
            break; // asymptotic series: stop at its smallest term
        }
        term = next;
        let sign = if (k / 2) % 2 == 0 { 1.0 } else { -1.0 };
        if k % 2 == 0 {
            p += sign * term;
        } else {
            q += sign * term;
        }
        if term.abs() < 1e-18 {
            break;
        }
    }
    (p, q)
}

/// Reduced Bessel function `Ĵ_m(x) = J_m(x) / (x/2)^m = 0F1(; m+1; -x²/4) / m!`, `x >= 0`.
fn reduced_bessel(m: usize, x: f64) -> f64 {
    if x <= SMALL_ARGUMENT {
        let inverse_factorial: f64 = (2..=m).map(|i| 1.0 / i as f64).product();
        inverse_factorial * bessel_series_factor(m, x)
    } else {
        bessel_j(m as u32, x) * (2.0 / x).powi(m as i32)
    }
}

// ---------------------------------------------------------------------------------------------
// Lommel functions of two variables
// ---------------------------------------------------------------------------------------------

/// `Σ_{s>=0} (-1)^s q^{m-p} Ĵ_m(x)` with `m = n + 2s` and `Ĵ_m(x) = J_m(x) / (x/2)^m`.
///
/// With `q = u/2` and `x = v` this is `U_n(u, v)` (`p = 0`) or `2 U_n(u, v) / u` (`p = 1`);
/// with `q = v²/(2u)` and `x = v` it is `V_n(u, v)`: `(u/v)^m J_m(v) = (u/2)^m Ĵ_m(v)` and
/// `(v/u)^m J_m(v) = (v²/2u)^m Ĵ_m(v)` (Potmesil & Chakravarty 1981 eq 14).
///
/// Orders `m = -j < 0` (only for `n < 0`, with `p = 0`) swap the roles:
/// `(u/v)^{-j} J_{-j}(v) = (-1)^j (v²/2u)^j Ĵ_j(v)`, so they take `q_mirror`, the `q` of the
/// companion function (`v²/2u` for `U`, `u/2` for `V`). Requires `q >= 0`, `x >= 0`.
fn reduced_lommel_series(n: i64, q: f64, q_mirror: f64, x: f64, p: i32) -> f64 {
    debug_assert!(n >= p as i64 || (n < 0 && p == 0));
    let mut sum = 0.0;
    let mut m = n;
    let mut sign = 1.0;
    while m < 0 {
        let j = m.unsigned_abs() as usize;
        let term = odd_order_sign(m) * q_mirror.powi(j as i32) * reduced_bessel(j, x);
        sum += sign * term;
        sign = -sign;
        m += 2;
    }
    let tail = if x <= SMALL_ARGUMENT {
        reduced_lommel_tail_small(m as usize, q, x, p)
    } else {
        reduced_lommel_tail_large(m as usize, q, x, p)
    };
    sum + sign * tail
}

/// `Σ_{s>=0} (-1)^s q^{m-p} Ĵ_m(x)`, `m = m0 + 2s >= p`, for `x <= 4`: the terms are bounded
/// by `q^{m-p} / m!` since `|m! Ĵ_m(x)| <= 1`.
fn reduced_lommel_tail_small(m0: usize, q: f64, x: f64, p: i32) -> f64 {
    let mut bound = q.powi(m0 as i32 - p); // q^{m-p} / m!
    for i in 2..=m0 {
        bound /= i as f64;
    }
    let mut largest_bound: f64 = 0.0;
    let mut sum = 0.0;
    let mut sign = 1.0;
    let mut m = m0;
    loop {
        largest_bound = largest_bound.max(bound.abs());
        sum += sign * bound * bessel_series_factor(m, x);
        let past_peak = m as f64 > q;
        if bound == 0.0 || (past_peak && bound.abs() <= NEGLIGIBLE_TERM * largest_bound) {
            break;
        }
        bound *= q * q / ((m + 1) as f64 * (m + 2) as f64);
        sign = -sign;
        m += 2;
    }
    sum
}

/// `Σ_{s>=0} (-1)^s t^{m-p} (2/x)^p J_m(x)`, `m = m0 + 2s >= p`, `t = 2q/x <= 1` (the ratio
/// `u/v` or `v/u`), for `x > 4`. Few orders at a large argument: one Hankel-plus-forward
/// sequence; otherwise the sum is accumulated inside Miller's recurrence (no `O(x)` storage).
fn reduced_lommel_tail_large(m0: usize, q: f64, x: f64, p: i32) -> f64 {
    let ratio = 2.0 * q / x;
    debug_assert!(ratio <= 1.0 + 1e-9, "t = {ratio}: the series would cancel catastrophically");
    let last_order = lommel_last_order(m0, ratio, x);
    let sum = if uses_hankel_forward(last_order, x) {
        let bessel = bessel_j_sequence_hankel_forward(last_order, x);
        let mut sum = 0.0;
        for (m, &j_m) in bessel.iter().enumerate().skip(m0).step_by(2) {
            sum += lommel_term_sign(m, m0) * lommel_weight(ratio, m, p) * j_m;
        }
        sum
    } else {
        let mut sum = LommelSum { first_order: m0, last_order, ratio, p, sum: 0.0 };
        let norm = miller_backward(x, last_order, &mut sum);
        sum.sum / norm
    };
    sum * (2.0 / x).powi(p)
}

/// `(-1)^s` for the order `m = m0 + 2s`.
fn lommel_term_sign(m: usize, m0: usize) -> f64 {
    if (m - m0).is_multiple_of(4) {
        1.0
    } else {
        -1.0
    }
}

/// `t^{m-p}` (`0^0 = 1`), for `t <= 1`: underflows harmlessly to 0.
fn lommel_weight(ratio: f64, m: usize, p: i32) -> f64 {
    let exponent = m as i64 - p as i64;
    match i32::try_from(exponent) {
        Ok(exponent) => ratio.powi(exponent),
        Err(_) => ratio.powf(exponent as f64),
    }
}

/// Accumulates `Σ (-1)^s t^{m-p} J_m` over `m = first_order, first_order + 2, ..,
/// <= last_order` inside [`miller_backward`].
struct LommelSum {
    first_order: usize,
    last_order: usize,
    ratio: f64,
    p: i32,
    sum: f64,
}

impl MillerVisitor for LommelSum {
    fn visit(&mut self, k: usize, value: f64) {
        let in_series = k >= self.first_order && (k - self.first_order).is_multiple_of(2);
        if in_series && k <= self.last_order {
            let weight = lommel_weight(self.ratio, k, self.p);
            self.sum += lommel_term_sign(k, self.first_order) * weight * value;
        }
    }
    fn rescale(&mut self, factor: f64) {
        self.sum *= factor;
    }
}

/// Highest order `m` worth summing in `Σ t^m J_m(x)` from `m0`, `t <= 1`: where `t^m`
/// (`|J_m| <= 1`) or `J_m(x)` itself (past the turning point `m = x`) is below `1e-19`.
fn lommel_last_order(m0: usize, ratio: f64, x: f64) -> usize {
    let bessel_limit = bessel_negligible_order(x);
    let limit = if ratio >= 1.0 {
        bessel_limit
    } else if ratio == 0.0 {
        m0 + 2
    } else {
        let geometric_limit = m0 + 2 + (44.0 / -ratio.ln()).ceil() as usize;
        bessel_limit.min(geometric_limit)
    };
    limit.max(m0)
}

/// `cos(φ - nπ/2)` for integer `n`, without rounding `π/2`.
fn cos_minus_quarter_turns(phase: f64, n: i64) -> f64 {
    match n.rem_euclid(4) {
        0 => phase.cos(),
        1 => phase.sin(),
        2 => -phase.cos(),
        _ => -phase.sin(),
    }
}

/// Lommel's phase `½ (u + v²/u)` for `u > 0`.
fn lommel_phase(u: f64, v: f64) -> f64 {
    0.5 * u + 0.5 * v * v / u
}

/// Lommel function `U_n(u, v) = Σ_{s>=0} (-1)^s (u/v)^{n+2s} J_{n+2s}(v)`
/// (Potmesil & Chakravarty 1981 eq 14, which prints it as `V_n`; Born & Wolf 8.8).
///
/// Summed directly where it converges fast (`|u| <= |v|`, or `|u| <= 4`); elsewhere from
/// `U_n = cos(½(u + v²/u) - nπ/2) + (-1)^n V_{2-n}` (Born & Wolf 8.8), since the direct series
/// then has terms far larger than its sum. `U_n(-u, v) = (-1)^n U_n(u, v)`,
/// `U_n(u, -v) = U_n(u, v)`; `U_n(u, 0) = Σ (-1)^s (u/2)^{n+2s} / (n+2s)!`.
pub fn lommel_u(n: u32, u: f64, v: f64) -> f64 {
    let sign = if u < 0.0 { odd_order_sign(n as i64) } else { 1.0 };
    let (u, v) = (u.abs(), v.abs());
    let n = n as i64;
    let (q_u, q_v) = (0.5 * u, 0.5 * v * v / u);
    let value = if u <= v || u <= SMALL_DEFOCUS {
        reduced_lommel_series(n, q_u, q_v, v, 0)
    } else {
        let v_companion = reduced_lommel_series(2 - n, q_v, q_u, v, 0);
        cos_minus_quarter_turns(lommel_phase(u, v), n) + odd_order_sign(n) * v_companion
    };
    sign * value
}

/// Lommel function `V_n(u, v) = Σ_{s>=0} (-1)^s (v/u)^{n+2s} J_{n+2s}(v)` (Born & Wolf 8.8;
/// the companion of Potmesil & Chakravarty 1981 eq 14), for `u != 0` (NaN at `u = 0`, where
/// it has no limit).
///
/// Summed directly for `|v| <= |u|`; elsewhere from
/// `V_n = (-1)^n [U_{2-n} - cos(½(u + v²/u) - (2-n)π/2)]`.
/// `V_n(-u, v) = (-1)^n V_n(u, v)`, `V_n(u, -v) = V_n(u, v)`.
pub fn lommel_v(n: u32, u: f64, v: f64) -> f64 {
    if u == 0.0 {
        return f64::NAN;
    }
    let sign = if u < 0.0 { odd_order_sign(n as i64) } else { 1.0 };
    let (u, v) = (u.abs(), v.abs());
    let n = n as i64;
    let (q_u, q_v) = (0.5 * u, 0.5 * v * v / u);
    let value = if v <= u {
        reduced_lommel_series(n, q_v, q_u, v, 0)
    } else {
        let u_companion = reduced_lommel_series(2 - n, q_u, q_v, v, 0);
        odd_order_sign(n) * (u_companion - cos_minus_quarter_turns(lommel_phase(u, v), 2 - n))
    };
    sign * value
}

// ---------------------------------------------------------------------------------------------
// Point-spread function
// ---------------------------------------------------------------------------------------------

/// Intensity of the defocused diffraction pattern of a circular aperture, relative to the
/// focal-point intensity: `I(u, v) / I0`, so that `psf_intensity(0, 0) = 1`.
///
/// Potmesil & Chakravarty 1981 eq 13, `I(u, v) = (2/u)^2 [U_1^2 + U_2^2] I0`, and its
/// companion form `(2/u)^2 [1 + V_0^2 + V_1^2 - 2 V_0 cos φ - 2 V_1 sin φ] I0`,
/// `φ = ½(u + v²/u)`, written as the sum of squares `(2/u)^2 [(cos φ - V_0)^2 + (sin φ - V_1)^2]`.
/// Limits: eq 13 at `u = 0` is the Airy pattern `[2 J1(v)/v]^2` (eq 12, observation 1),
/// and on the axis `I(u, 0) = [sin(u/4) / (u/4)]^2` (eq 19), zero at `u = ±4π`.
///
/// `u` is the defocus and `v` the radius in optical units (eqs 15-18, [`optical_coordinates`]).
/// Even in both; finite and in `[0, 1]` (up to rounding) for all finite inputs; `0` when
/// either is infinite; NaN only for a NaN input.
pub fn psf_intensity(u: f64, v: f64) -> f64 {
    let (u, v) = (u.abs(), v.abs());
    if u.is_nan() || v.is_nan() {
        return f64::NAN;
    }
    if u.is_infinite() || v.is_infinite() {
        return 0.0;
    }
    if u < v || u <= SMALL_DEFOCUS {
        intensity_from_u_series(u, v)
    } else {
        intensity_from_v_series(u, v)
    }
}

/// Potmesil & Chakravarty 1981 eq 13: `(2/u)^2 [U_1^2 + U_2^2]`, with `2 U_n / u` summed as
/// `Σ (-1)^s (u/2)^{n+2s-1} Ĵ_{n+2s}(v)`: regular at `u = 0` (the Airy pattern, eq 12) and at
/// `v = 0`. For `|u| < v` or small `|u|`.
fn intensity_from_u_series(u: f64, v: f64) -> f64 {
    let half_u = 0.5 * u;
    let two_u1_over_u = reduced_lommel_series(1, half_u, 0.0, v, 1);
    let two_u2_over_u = reduced_lommel_series(2, half_u, 0.0, v, 1);
    two_u1_over_u * two_u1_over_u + two_u2_over_u * two_u2_over_u
}

/// Companion form of Potmesil & Chakravarty 1981 eq 13 (Born & Wolf 8.8):
/// `(2/u)^2 [(cos φ - V_0)^2 + (sin φ - V_1)^2]`, `φ = ½(u + v²/u)`. For `u >= v`, `u > 4`.
fn intensity_from_v_series(u: f64, v: f64) -> f64 {
    let q = 0.5 * v * v / u;
    let v0 = reduced_lommel_series(0, q, 0.0, v, 0);
    let v1 = reduced_lommel_series(1, q, 0.0, v, 0);
    let phase = lommel_phase(u, v);
    let (cos_part, sin_part) = (phase.cos() - v0, phase.sin() - v1);
    let two_over_u = 2.0 / u;
    two_over_u * two_over_u * (cos_part * cos_part + sin_part * sin_part)
}

/// Airy pattern `[2 J1(v)/v]^2` (Potmesil & Chakravarty 1981 eq 12; eq 13 at `u = 0`).
pub fn airy_intensity(v: f64) -> f64 {
    psf_intensity(0.0, v)
}

/// On-axis intensity `[sin(u/4) / (u/4)]^2` (Potmesil & Chakravarty 1981 eq 19).
pub fn on_axis_intensity(u: f64) -> f64 {
    let quarter_u = 0.25 * u;
    if quarter_u == 0.0 {
        1.0
    } else {
        let sinc = quarter_u.sin() / quarter_u;
        sinc * sinc
    }
}

/// Fraction of the point's energy inside radius `v_max` (optical units) at defocus `u`:
/// `∫_0^{v_max} I(u, v) 2π v dv / 4π` ([`PSF_TOTAL_ENERGY_V2`]).
///
/// Composite 10-point Gauss-Legendre on unit panels `[j, j+1]` (the last one cut at `v_max`);
/// the intensity is band-limited in `v` (period at least π), so this is accurate to about
/// `1e-14`. Non-decreasing in `v_max`, `0` for `v_max <= 0`, `1` for `v_max = ∞`. At `u = 0` it
/// is Rayleigh's `1 - J0(v_max)^2 - J1(v_max)^2`; far out, `1 - E ≈ 2 / (π v_max)`.
/// Costs `10 v_max` intensity evaluations; each is cheap except within a few percent of the
/// geometric edge `v = |u|`, where it costs `O(|u|)`.
pub fn encircled_energy(u: f64, v_max: f64) -> f64 {
    if u.is_nan() || v_max.is_nan() {
        return f64::NAN;
    }
    if v_max <= 0.0 {
        return 0.0;
    }
    if v_max.is_infinite() {
        return 1.0;
    }
    let (nodes, weights) = gauss_legendre_rule(ENERGY_NODES_PER_PANEL);
    let mut integral_v_dv = 0.0; // ∫ I v dv
    let mut panel_start = 0.0;
    while panel_start < v_max {
        let panel_end = (panel_start + 1.0).min(v_max);
        let (mid, half_width) = (0.5 * (panel_start + panel_end), 0.5 * (panel_end - panel_start));
        let mut panel_sum = 0.0;
        for (node, weight) in nodes.iter().zip(&weights) {
            let v = mid + half_width * node;
            panel_sum += weight * psf_intensity(u, v) * v;
        }
        integral_v_dv += half_width * panel_sum;
        panel_start += 1.0;
    }
    2.0 * PI * integral_v_dv / PSF_TOTAL_ENERGY_V2
}

/// Gauss-Legendre nodes and weights on `[-1, 1]` (Newton's method on `P_n`).
pub fn gauss_legendre_rule(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut derivative = 1.0;
        for _ in 0..100 {
            let (p_n, dp_n) = legendre_with_derivative(n, x);
            derivative = dp_n;
            let step = p_n / dp_n;
            x -= step;
            if step.abs() <= 1e-16 {
                derivative = legendre_with_derivative(n, x).1;
                break;
            }
        }
        let weight = 2.0 / ((1.0 - x * x) * derivative * derivative);
        nodes[i] = -x;
        nodes[n - 1 - i] = x;
        weights[i] = weight;
        weights[n - 1 - i] = weight;
    }
    (nodes, weights)
}

/// `(P_n(x), P_n'(x))` by the three-term recurrence.
fn legendre_with_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p_prev, mut p) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let k = k as f64;
        let p_next = ((2.0 * k - 1.0) * x * p - (k - 1.0) * p_prev) / k;
        p_prev = p;
        p = p_next;
    }
    let derivative = n as f64 * (x * p - p_prev) / (x * x - 1.0);
    (p, derivative)
}

// ---------------------------------------------------------------------------------------------
// Physical units
// ---------------------------------------------------------------------------------------------

/// Optical coordinates `(u, v)` of a point at radius `radius_mm` in a plane `defocus_mm` away
/// from the focus of a thin lens with aperture radius `aperture_radius_mm` focusing at
/// `image_distance_mm`, for light of wavelength `wavelength_nm`:
/// `u = (2π/λ) (a/f)^2 Δz` and `v = (2π/λ) (a/f) r` (Potmesil & Chakravarty 1981 eqs 15-18,
/// with `d = 2a` and the image distance `f` in place of the focal length `F`).
///
/// The sign of `u` follows `defocus_mm`; the intensity does not depend on it. The geometric
/// circle of confusion has radius `v = |u|`, i.e. `r = a |Δz| / f`. One unit of `v` is
/// `λ f / (2π a)` millimetres; the Airy disk's first dark ring is at `v = 3.8317`.
pub fn optical_coordinates(
    defocus_mm: f64,
    radius_mm: f64,
    aperture_radius_mm: f64,
    image_distance_mm: f64,
    wavelength_nm: f64,
) -> (f64, f64) {
    let wavenumber_per_mm = 2.0 * PI / (wavelength_nm * 1e-6);
    let aperture_slope = aperture_radius_mm / image_distance_mm; // a / f
    let u = wavenumber_per_mm * aperture_slope * aperture_slope * defocus_mm;
    let v = wavenumber_per_mm * aperture_slope * radius_mm;
    (u, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `J0(x)` by the trapezoid rule on Bessel's integral `(1/π) ∫_0^π cos(x sin θ) dθ`: the
    /// integrand is π-periodic and analytic, so `M` points are exact up to
    /// `2 Σ_l J_{2lM}(x)`, negligible once `2M` is past the turning point `x`.
    fn reference_j0(x: f64) -> f64 {
        let points = (0.5 * x + 5.0 * x.cbrt() + 20.0).ceil() as usize;
        let step = PI / points as f64;
        let sum: f64 = (0..points).map(|j| (x * (step * j as f64).sin()).cos()).sum();
        sum / points as f64
    }

    /// Fresnel diffraction integral of the circular pupil, independent of the Lommel series:
    /// `I(u, v) = |2 ∫_0^1 J0(v ρ) exp(-i u ρ²/2) ρ dρ|^2` by composite 20-point
    /// Gauss-Legendre with panels short enough for the `~(|u| + v)/2π` oscillations.
    fn reference_intensity(u: f64, v: f64) -> f64 {
        let panels = ((u.abs() + v) / 4.0).ceil() as usize + 4;
        let (nodes, weights) = gauss_legendre_rule(20);
        let half_width = 0.5 / panels as f64;
        let (mut re, mut im) = (0.0, 0.0);
        for panel in 0..panels {
            let mid = (panel as f64 + 0.5) / panels as f64;
            for (node, weight) in nodes.iter().zip(&weights) {
                let rho = mid + half_width * node;
                let amplitude = weight * half_width * reference_j0(v * rho) * rho;
                let phase = -0.5 * u * rho * rho;
                re += amplitude * phase.cos();
                im += amplitude * phase.sin();
            }
        }
        4.0 * (re * re + im * im)
    }

    /// Relative error where the reference exceeds 1e-6, else `None` after checking the
    /// absolute error is below 1e-9.
    fn check_against_reference(u: f64, v: f64) -> Option<f64> {
        let (value, reference) = (psf_intensity(u, v), reference_intensity(u, v));
        assert!(value.is_finite(), "I({u}, {v}) = {value}");
        if reference > 1e-6 {
            let relative = (value - reference).abs() / reference;
            assert!(relative < 1e-6, "I({u}, {v}) = {value}, reference {reference}");
            Some(relative)
        } else {
            let absolute = (value - reference).abs();
            assert!(absolute < 1e-9, "I({u}, {v}) = {value}, reference {reference}");
            None
        }
    }

    fn max_relative_error(points: &[(f64, f64)]) -> f64 {
        let errors = points.iter().filter_map(|&(u, v)| check_against_reference(u, v));
        errors.fold(0.0, f64::max)
    }

    #[test]
    fn gauss_legendre_is_exact_for_polynomials_and_sums_weights_to_two() {
        for n in [1, 2, 5, 10, 20] {
            let (nodes, weights) = gauss_legendre_rule(n);
            assert!((weights.iter().sum::<f64>() - 2.0).abs() < 1e-14);
            for degree in 0..2 * n as i32 {
                let numeric: f64 = nodes.iter().zip(&weights).map(|(x, w)| w * x.powi(degree)).sum();
                let exact = if degree % 2 == 0 { 2.0 / (degree + 1) as f64 } else { 0.0 };
                assert!((numeric - exact).abs() < 1e-14, "n {n}, degree {degree}");
            }
        }
    }

    #[test]
    fn reference_j0_matches_known_values() {
        assert!((reference_j0(1.0) - 0.7651976865579666).abs() < 1e-15);
        assert!((reference_j0(100.0) - 0.019985850304223122).abs() < 1e-15);
        assert!((reference_j0(2000.0) - 0.007098341833199617).abs() < 1e-14);
    }

    #[test]
    fn bessel_j_matches_known_values() {
        let known = [
            (0, 1.0, 0.7651976865579666),
            (1, 1.0, 0.4400505857449335),
            (0, 100.0, 0.019985850304223122),
            (1, 1000.0, 0.004728311907089523),
            (100, 100.0, 0.09636667329586156),
            (0, 2000.0, 0.007098341833199617),
            (2000, 2000.0, 0.03550278686223428),
            (1, 3000.0, 0.012306980664764856),
        ];
        for (n, x, expected) in known {
            let value = bessel_j(n, x);
            assert!((value - expected).abs() < 1e-14, "J_{n}({x}) = {value}, expected {expected}");
        }
        assert_eq!(bessel_j(0, 0.0), 1.0);
        assert_eq!(bessel_j(3, 0.0), 0.0);
        assert_eq!(bessel_j(3000, 10.0), 0.0); // ~1e-3000: underflows, no NaN
        assert!((bessel_j(1, -1.0) + 0.4400505857449335).abs() < 1e-16);
    }

    #[test]
    fn bessel_j_satisfies_the_three_term_recurrence_at_large_arguments() {
        for x in [4.0, 4.5, 37.3, 500.5, 1234.5, 2000.0, 3000.0] {
            let top = (x as usize) + 200;
            let j = bessel_j_sequence(top + 1, x);
            for n in [1, 2, 10, 100, top / 2, x as usize, top] {
                let residual = j[n - 1] + j[n + 1] - 2.0 * n as f64 / x * j[n];
                assert!(residual.abs() < 1e-14, "x {x}, n {n}: residual {residual}");
            }
            let sum_identity = j[0] + 2.0 * j.iter().skip(2).step_by(2).sum::<f64>();
            assert!((sum_identity - 1.0).abs() < 1e-13, "x {x}");
        }
    }

    #[test]
    fn bessel_j_at_huge_arguments_uses_hankel_and_matches_known_values() {
        let known = [
            (0, 1e6, 0.00033104301373987376),
            (1, 1e6, -0.000725968356813763),
            (100, 1e6, 0.0003346687040378612),
            (499, 12345.5, -0.00634692617423811),
            (7, 1e12, 7.91380268382604e-07),
        ];
        for (n, x, expected) in known {
            let value = bessel_j(n, x);
            assert!((value - expected).abs() < 1e-16, "J_{n}({x}) = {value}, expected {expected}");
        }
    }

    #[test]
    fn hankel_forward_and_miller_agree_where_both_apply() {
        for x in [50.0_f64, 77.7, 333.3, 2000.0, 4321.0] {
            let n_max = (0.5 * x).min(FORWARD_MAX_ORDER) as usize;
            let forward = bessel_j_sequence_hankel_forward(n_max, x);
            let miller = bessel_j_sequence_miller(n_max, x);
            for (n, (a, b)) in forward.iter().zip(&miller).enumerate() {
                assert!((a - b).abs() < 1e-15, "x {x}, n {n}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn bessel_j_is_continuous_across_the_power_series_switch() {
        for n in [0, 1, 2, 7, 30] {
            let below = bessel_j(n, SMALL_ARGUMENT);
            let above = bessel_j(n, SMALL_ARGUMENT * (1.0 + 1e-15));
            assert!((below - above).abs() < 1e-14, "n {n}: {below} vs {above}");
        }
    }

    #[test]
    fn lommel_functions_match_high_precision_series() {
        // (n, u, v, U_n, V_n) from the defining series in 50-digit arithmetic
        let known = [
            (1, 7.0, 1.0, -0.47952899998670656, 0.06280734823320684),
            (2, 50.0, 30.0, 0.7290927991150398, 0.03310949208852526),
            (3, 50.0, 30.0, -0.8423834152461027, 0.04413165386173353),
            (0, 2.0, 3.0, -0.4509929481874871, -0.8031886827949926),
            (1, 30.0, 50.0, -0.08660646930174266, 0.20433173090374132),
            (2, 0.5, 0.25, 0.03092564264223717, 0.001942338605443333),
            (1, 100.0, 120.0, 0.0038452054491608053, 0.49486794844723325),
        ];
        for (n, u, v, expected_u, expected_v) in known {
            let (value_u, value_v) = (lommel_u(n, u, v), lommel_v(n, u, v));
            assert!((value_u - expected_u).abs() < 1e-13, "U_{n}({u}, {v}) = {value_u}");
            assert!((value_v - expected_v).abs() < 1e-13, "V_{n}({u}, {v}) = {value_v}");
            let sign = if n % 2 == 1 { -1.0 } else { 1.0 };
            assert!((lommel_u(n, -u, v) - sign * value_u).abs() < 1e-15);
            assert!((lommel_v(n, -u, -v) - sign * value_v).abs() < 1e-15);
        }
        assert!(lommel_v(1, 0.0, 1.0).is_nan());
    }

    #[test]
    fn lommel_functions_of_high_order_use_negative_order_companions() {
        // the identity paths need V_{2-n}, U_{2-n} with 2 - n < 0
        let known = [
            (lommel_v(3, 2.0, 5.0), -1.7938215170124756),
            (lommel_v(4, 10.0, 30.0), 1.7667561198402584),
            (lommel_u(5, 60.0, 40.0), -1.3643920030266101),
            (lommel_u(3, 10.0, 1e-3), 5.958923685480047),
            (lommel_u(3, 10.0, 0.0), 5.0 - 5f64.sin()), // x - sin x, x = u/2
            (lommel_u(4, 10.0, 0.0), 5f64.cos() - 1.0 + 12.5), // cos x - 1 + x²/2
        ];
        for (i, (value, expected)) in known.into_iter().enumerate() {
            assert!((value - expected).abs() < 1e-13, "case {i}: {value} vs {expected}");
        }
    }

    #[test]
    fn eq_13_u_form_equals_v_form() {
        for (u, v) in [(7.0, 1.0), (50.0, 30.0), (30.0, 50.0), (100.0, 120.0), (9.0, 9.0)] {
            let (u1, u2) = (lommel_u(1, u, v), lommel_u(2, u, v));
            let (v0, v1) = (lommel_v(0, u, v), lommel_v(1, u, v));
            let phase = 0.5 * (u + v * v / u);
            let u_form = (2.0 / u).powi(2) * (u1 * u1 + u2 * u2);
            let v_form =
                (2.0 / u).powi(2) * (1.0 + v0 * v0 + v1 * v1 - 2.0 * v0 * phase.cos() - 2.0 * v1 * phase.sin());
            assert!((u_form - v_form).abs() < 1e-14, "({u}, {v})");
            assert!((psf_intensity(u, v) - u_form).abs() < 1e-14, "({u}, {v})");
        }
    }

    #[test]
    fn psf_limits_airy_and_on_axis() {
        assert_eq!(psf_intensity(0.0, 0.0), 1.0);
        for v in [1e-9, 0.3, 3.8317059702075125, 10.0, 250.0] {
            let airy = (2.0 * bessel_j(1, v) / v).powi(2);
            assert!((airy_intensity(v) - airy).abs() < 1e-15, "v {v}");
        }
        assert!(airy_intensity(3.8317059702075125) < 1e-28); // first dark ring
        for u in [1e-9, 0.7, 4.0, 4.0 * PI, 20.0, 333.3, 1000.0] {
            let expected = on_axis_intensity(u);
            assert!((psf_intensity(u, 0.0) - expected).abs() < 1e-15, "u {u}");
            assert_eq!(psf_intensity(-u, 0.0), psf_intensity(u, 0.0));
        }
        assert!(psf_intensity(4.0 * PI, 0.0) < 1e-30); // eq 19: first on-axis zero
        for (u, v) in [(1.0, 1e12), (1e12, 1.0), (1e6, 1.1e6), (1.1e6, 1e6), (2e5, 2e5)] {
            let value = psf_intensity(u, v);
            assert!(value.is_finite() && (0.0..=1e-10).contains(&value), "I({u}, {v}) = {value}");
        }
        assert!(psf_intensity(f64::INFINITY, 1.0) == 0.0 && psf_intensity(1.0, f64::INFINITY) == 0.0);
    }

    #[test]
    fn psf_matches_fresnel_integral_at_hard_points() {
        let samples = [1e-8, 0.5, 10.0, 100.0, 300.0, 1000.0];
        let mut points: Vec<(f64, f64)> = Vec::new();
        for &u in &samples {
            for &v in &samples {
                points.push((u, v));
            }
        }
        let zero = 4.0 * PI;
        for v in [0.0, 1e-8, 0.5, 3.0, 10.0, zero, 100.0] {
            for u in [0.0, zero, zero - 1e-6, zero + 1e-6, zero + 1e-7] {
                points.push((u, v));
            }
        }
        for d in [1e-8, 0.5, 3.999, 4.0, 4.001, 10.0, 100.0, 300.0, 999.9, 1000.0] {
            points.extend([(d, d), (d, d * (1.0 + 1e-9)), (d * (1.0 + 1e-9), d), (-d, d)]);
        }
        for (u, v) in [(4.0, 3.5), (4.0 + 1e-12, 3.5), (3.0, 4.0), (3.0, 4.0 + 1e-12)] {
            points.push((u, v)); // both sides of the series / power-series switches
        }
        points.extend([(1e-12, 1234.5), (1500.0, 1400.0), (1400.0, 1500.0)]);
        let worst = max_relative_error(&points);
        println!("psf vs Fresnel integral: max relative error {worst:.2e} over {} points", points.len());
        assert!(worst < 1e-10, "measured 1e-13 when written");
    }

    #[test]
    fn psf_matches_high_precision_values() {
        for (u, v, expected) in [
            (50.0, 30.0, 0.0015150582672194511),
            (300.0, 299.0, 1.1019978695213314e-5),
            (1000.0, 1000.0, 9.727353524850073e-7),
        ] {
            let value = psf_intensity(u, v);
            assert!((value - expected).abs() < 1e-12 * expected, "({u}, {v}): {value}");
        }
    }

    #[test]
    fn psf_is_finite_and_bounded_on_a_dense_grid() {
        let mut u_values: Vec<f64> = (0..371).map(|i| 2.7 * i as f64).collect();
        u_values.extend([1e-300, 1e-12, 1e-6, 1e-3, 4.0, 4.0 * PI]);
        let mut v_values: Vec<f64> = (0..323).map(|i| 3.1 * i as f64).collect();
        v_values.extend([1e-300, 1e-12, 1e-6, 1e-3, 4.0]);
        let check = |u: f64, v: f64| {
            let value = psf_intensity(u, v);
            assert!(value.is_finite() && (-1e-12..=1.0 + 1e-12).contains(&value), "I({u}, {v}) = {value}");
        };
        for &u in &u_values {
            for &v in &v_values {
                check(u, v);
            }
            for v in [u * (1.0 - 1e-12), u, u * (1.0 + 1e-12), u - 0.01, u + 0.01] {
                check(u, v.max(0.0));
            }
        }
    }

    #[test]
    fn encircled_energy_at_focus_is_rayleighs_formula() {
        for v in [0.5, 3.8317059702075125, 7.0155866698156, 20.3, 100.7] {
            let (j0, j1) = (bessel_j(0, v), bessel_j(1, v));
            let rayleigh = 1.0 - j0 * j0 - j1 * j1;
            let value = encircled_energy(0.0, v);
            assert!((value - rayleigh).abs() < 1e-12, "v {v}: {value} vs {rayleigh}");
        }
        assert_eq!(encircled_energy(3.0, 0.0), 0.0);
        assert_eq!(encircled_energy(3.0, f64::INFINITY), 1.0);
    }

    #[test]
    fn encircled_energy_tends_to_one() {
        for u in [0.0, 3.0, 4.0 * PI, 40.0, 150.0] {
            let v_max = 10.0 * u + 1000.0;
            let energy = encircled_energy(u, v_max);
            let tail = 2.0 / (PI * v_max); // 1 - E for v_max >> u
            assert!((1.0 - energy).abs() < 1e-3, "u {u}: E = {energy}");
            assert!((1.0 - energy - tail).abs() < 0.1 * tail, "u {u}: 1 - E = {}", 1.0 - energy);
        }
    }

    #[test]
    fn encircled_energy_is_monotone_in_radius() {
        for u in [0.0, 7.0, 40.0] {
            let mut previous = 0.0;
            for i in 1..=180 {
                let energy = encircled_energy(u, 0.7 * i as f64);
                assert!(energy >= previous - 1e-15 && energy <= 1.0 + 1e-12, "u {u}, step {i}");
                previous = energy;
            }
        }
    }

    #[test]
    fn optical_coordinates_put_the_coc_edge_at_v_equals_u() {
        let (aperture_radius_mm, image_distance_mm, defocus_mm) = (10.0, 50.0, 0.2);
        let coc_radius_mm = aperture_radius_mm * defocus_mm / image_distance_mm;
        for wavelength_nm in WAVELENGTHS_RGB_NM {
            let (u, v) =
                optical_coordinates(defocus_mm, coc_radius_mm, aperture_radius_mm, image_distance_mm, wavelength_nm);
            assert!((u - v).abs() < 1e-9 * u, "λ {wavelength_nm}");
            let wavenumber_per_mm = 2.0 * PI / (wavelength_nm * 1e-6);
            assert!((v - wavenumber_per_mm * 0.2 * coc_radius_mm).abs() < 1e-9 * v);
        }
        // Airy first dark ring at 1.22 λ N (N = f / 2a): v = 3.8317
        let (_, v) = optical_coordinates(0.0, 1.21967 * 550e-6 * 2.5, 10.0, 50.0, 550.0);
        assert!((v - 3.8317).abs() < 1e-3);
    }
}
