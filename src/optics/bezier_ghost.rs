//! Walch 2017 ch. 6: the measured-ghost primitive. A ghost is a closed shape of four cubic
//! Bezier sides (eq 6.1) whose light is a transfer function (eq 6.4) of the signed distance to
//! its border (sign by eq 6.3): brightest on the border, fading outward to 0 within F_o and
//! inward to I_i within F_i.
//!
//! The shape (Walch sec. 6.3.1, figure 6.2): the centre M, the height h (the assembly points
//! of the left and right sides, straight above and below M), the half-widths of the left and
//! right sides and, per side, where its control points sit on the axis-aligned lines through
//! the assembly points (C_l, C_r: 0 a diamond's straight lines, 0.5523 a quarter ellipse, 1 a
//! box's corner). The upper and lower halves mirror each other; the control points on each
//! side of an assembly point share its horizontal line, so the sides join with one tangent.
//!
//! Coordinates: image pixels, x right, y down. Positive distances lie inside (eq 6.4's d > 0).

/// The number of a primitive's parameters (the order of [`BezierGhost::to_params`]).
pub const PARAMS: usize = 13;

/// The names of the parameters, in [`BezierGhost::to_params`] order (lens files, reports).
pub const PARAM_NAMES: [&str; PARAMS] = [
    "centre_x_px",
    "centre_y_px",
    "height_px",
    "left_px",
    "right_px",
    "left_control",
    "right_control",
    "border",
    "inner",
    "inner_falloff_px",
    "outer_falloff_px",
    "inner_exponent",
    "outer_exponent",
];

/// The range each parameter is kept in ([`PARAM_NAMES`] order): positions free, sizes at least
/// 0.5 px, controls 0..1.2, lights >= 0, fades at least 0.05 px, exponents 0.1..8.
pub const PARAM_RANGES: [(f64, f64); PARAMS] = [
    (f64::NEG_INFINITY, f64::INFINITY),
    (f64::NEG_INFINITY, f64::INFINITY),
    (0.5, f64::INFINITY),
    (0.5, f64::INFINITY),
    (0.5, f64::INFINITY),
    (0.0, 1.2),
    (0.0, 1.2),
    (0.0, f64::INFINITY),
    (0.0, f64::INFINITY),
    (0.05, f64::INFINITY),
    (0.05, f64::INFINITY),
    (0.1, 8.0),
    (0.1, 8.0),
];

/// The control position of four cubic sides that approximate a circle (the ratio of the
/// control arm to the radius, 4/3 (sqrt 2 - 1)).
pub const CIRCLE_CONTROL: f64 = 0.552_284_749_830_793_4;

/// One ghost: shape (sec. 6.3.1) and intensity transfer (eq 6.4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BezierGhost {
    /// M: the centre, between the assembly points of the two sides.
    pub centre_px: [f64; 2],
    /// h: half the distance of the assembly points above and below the centre.
    pub height_px: f64,
    /// How far the left and right sides reach from the centre.
    pub left_px: f64,
    pub right_px: f64,
    /// C_l, C_r: the control points' place along each side's tangent lines (0..1).
    pub left_control: f64,
    pub right_control: f64,
    pub transfer: Transfer,
}

/// Eq 6.4's intensity transfer function of the signed distance d (px, > 0 inside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transfer {
    /// I_b: the light on the border.
    pub border: f64,
    /// I_i: the light deep inside.
    pub inner: f64,
    /// F_i, F_o: the fade ranges inward and outward (px).
    pub inner_falloff_px: f64,
    pub outer_falloff_px: f64,
    /// E_i, E_o: the fades' exponents.
    pub inner_exponent: f64,
    pub outer_exponent: f64,
}

impl Transfer {
    /// Walch eq 6.4: S = |d| / F_o outside (d < 0), |d| / F_i inside; the light is I_b lerped
    /// towards 0 (outside) or I_i (inside) by clamp(S^E, 0, 1).
    ///
    /// At d = 0 the thesis prints S = 1, which would put I_i (not the border's I_b) on the
    /// border itself, unlike the limits from both sides, its text ("the brightest values rest
    /// upon the ghost border") and figure 6.3; here S = |d| / F on the border too, i.e. 0 (I_b).
    /// A fade range of 0 is a step (S = infinity off the border); NaN distances give 0.
    pub fn intensity(&self, d_px: f64) -> f64 {
        if d_px.is_nan() {
            return 0.0;
        }
        let (falloff, exponent, target) = if d_px < 0.0 {
            (self.outer_falloff_px, self.outer_exponent, 0.0)
        } else {
            (self.inner_falloff_px, self.inner_exponent, self.inner)
        };
        let s = if d_px == 0.0 {
            0.0
        } else if falloff > 0.0 {
            d_px.abs() / falloff
        } else {
            f64::INFINITY
        };
        let w = s.powf(exponent.max(1e-6)).clamp(0.0, 1.0);
        self.border + (target - self.border) * w
    }

    /// How far outside the border any light reaches (px).
    pub fn reach_px(&self) -> f64 {
        self.outer_falloff_px.max(0.0)
    }
}

/// A cubic Bezier curve's control points P0..P3 (eq 6.1).
pub type Cubic = [[f64; 2]; 4];

/// Eq 6.1: C(t) = sum_i binom(3, i) t^i (1 - t)^(3 - i) P_i.
pub fn cubic_at(p: &Cubic, t: f64) -> [f64; 2] {
    let s = 1.0 - t;
    let w = [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t];
    [0, 1].map(|a| (0..4).map(|i| w[i] * p[i][a]).sum())
}

/// C'(t), the derivative of eq 6.1.
pub fn cubic_tangent(p: &Cubic, t: f64) -> [f64; 2] {
    let s = 1.0 - t;
    let w = [3.0 * s * s, 6.0 * s * t, 3.0 * t * t];
    [0, 1].map(|a| (0..3).map(|i| w[i] * (p[i + 1][a] - p[i][a])).sum())
}

/// The sign of eq 6.3: +1 where Q lies on the side of the rotated tangent (-B'_y, B'_x) seen
/// from B, i.e. sign(rot_tangent . (B - Q)); the sides run so that this is the inside.
pub fn eq63_sign(b: [f64; 2], tangent: [f64; 2], q: [f64; 2]) -> f64 {
    let rot = [-tangent[1], tangent[0]];
    if rot[0] * (b[0] - q[0]) + rot[1] * (b[1] - q[1]) >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

impl BezierGhost {
    /// The four sides, each P0..P3, running top -> left -> bottom -> right -> top (on screen,
    /// y down, counter-clockwise: eq 6.3's rotated tangent then points inward).
    pub fn sides(&self) -> [Cubic; 4] {
        let [mx, my] = self.centre_px;
        let (h, l, r) = (self.height_px, self.left_px, self.right_px);
        let (cl, cr) = (self.left_control, self.right_control);
        let top = [mx, my - h];
        let bottom = [mx, my + h];
        let left = [mx - l, my];
        let right = [mx + r, my];
        [
            [top, [mx - cl * l, my - h], [mx - l, my - cl * h], left],
            [left, [mx - l, my + cl * h], [mx - cl * l, my + h], bottom],
            [bottom, [mx + cr * r, my + h], [mx + r, my + cr * h], right],
            [right, [mx + r, my - cr * h], [mx + cr * r, my - h], top],
        ]
    }

    /// The parameters in [`PARAM_NAMES`] order.
    pub fn to_params(&self) -> [f64; PARAMS] {
        let t = &self.transfer;
        [
            self.centre_px[0],
            self.centre_px[1],
            self.height_px,
            self.left_px,
            self.right_px,
            self.left_control,
            self.right_control,
            t.border,
            t.inner,
            t.inner_falloff_px,
            t.outer_falloff_px,
            t.inner_exponent,
            t.outer_exponent,
        ]
    }

    pub fn from_params(p: &[f64; PARAMS]) -> BezierGhost {
        BezierGhost {
            centre_px: [p[0], p[1]],
            height_px: p[2],
            left_px: p[3],
            right_px: p[4],
            left_control: p[5],
            right_control: p[6],
            transfer: Transfer {
                border: p[7],
                inner: p[8],
                inner_falloff_px: p[9],
                outer_falloff_px: p[10],
                inner_exponent: p[11],
                outer_exponent: p[12],
            },
        }
    }

    /// The exact signed distance from `q` to the border (> 0 inside): the closest point of
    /// each side (eq 6.2) among the real roots in [0, 1] of the fifth-order polynomial
    /// (C(t) - Q) . C'(t) and the ends; the sign by eq 6.3 at the closest one.
    pub fn signed_distance(&self, q: [f64; 2]) -> f64 {
        let mut best = (f64::INFINITY, 1.0);
        for side in self.sides() {
            let (t, d) = closest_on_cubic(&side, q);
            if d < best.0 {
                best = (d, eq63_sign(cubic_at(&side, t), side_tangent(&side, t), q));
            }
        }
        best.0 * best.1
    }

    /// The light at `q`: eq 6.4 of the exact signed distance.
    pub fn intensity(&self, q: [f64; 2]) -> f64 {
        self.transfer.intensity(self.signed_distance(q))
    }

    /// The box holding every pixel with light (the shape's extent plus the outer fade).
    pub fn bounds_px(&self) -> [f64; 4] {
        let reach = self.transfer.reach_px() + 1.0;
        let [mx, my] = self.centre_px;
        let h = self.height_px.abs();
        [mx - self.left_px.abs() - reach, my - h - reach, mx + self.right_px.abs() + reach, my + h + reach]
    }
}

/// The tangent at t, or where it vanishes (a control point on its end: a diamond's corner),
/// its limit: towards P2 from P0 at the start, from P1 to P3 at the end.
fn side_tangent(p: &Cubic, t: f64) -> [f64; 2] {
    let d = cubic_tangent(p, t);
    if d[0].hypot(d[1]) > 1e-9 {
        return d;
    }
    let (a, b) = if t < 0.5 { (p[0], p[2]) } else { (p[1], p[3]) };
    [b[0] - a[0], b[1] - a[1]]
}

/// The parameter and distance of the point of cubic `p` closest to `q` (eq 6.2), exactly.
pub fn closest_on_cubic(p: &Cubic, q: [f64; 2]) -> (f64, f64) {
    // C(t) - Q = a t^3 + b t^2 + c t + d in the power basis.
    let axis = |k: usize| {
        let (p0, p1, p2, p3) = (p[0][k], p[1][k], p[2][k], p[3][k]);
        [p0 - q[k], 3.0 * (p1 - p0), 3.0 * (p0 - 2.0 * p1 + p2), p3 - p0 + 3.0 * (p1 - p2)]
    };
    let mut g = [0.0; 6];
    for k in 0..2 {
        let c = axis(k);
        let dc = [c[1], 2.0 * c[2], 3.0 * c[3]];
        for (i, ci) in c.iter().enumerate() {
            for (j, dj) in dc.iter().enumerate() {
                g[i + j] += ci * dj;
            }
        }
    }
    let mut best = (0.0, f64::INFINITY);
    let mut consider = |t: f64| {
        let c = cubic_at(p, t);
        let d = (c[0] - q[0]).hypot(c[1] - q[1]);
        if d < best.1 {
            best = (t, d);
        }
    };
    consider(0.0);
    consider(1.0);
    for t in real_roots(&g, 0.0, 1.0) {
        consider(t);
    }
    best
}

fn poly_at(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * t + k)
}

/// The real roots of the polynomial sum c_i t^i in [lo, hi] (and the stationary points where
/// it touches 0): the roots of its derivative split [lo, hi] into monotone pieces, each with
/// at most one root, found by bisection to the last bit.
pub fn real_roots(c: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let mut n = c.len();
    let scale = c.iter().fold(0.0f64, |m, &k| m.max(k.abs()));
    while n > 0 && c[n - 1].abs() <= 1e-14 * scale {
        n -= 1;
    }
    let c = &c[..n];
    if n <= 1 {
        return Vec::new();
    }
    if n == 2 {
        let t = -c[0] / c[1];
        return if (lo..=hi).contains(&t) { vec![t] } else { Vec::new() };
    }
    let derivative: Vec<f64> = c.iter().enumerate().skip(1).map(|(i, &k)| i as f64 * k).collect();
    let mut cuts = vec![lo];
    cuts.extend(real_roots(&derivative, lo, hi));
    cuts.push(hi);
    let mut roots = Vec::new();
    for w in cuts.windows(2) {
        let (mut a, mut b) = (w[0], w[1]);
        let (fa, fb) = (poly_at(c, a), poly_at(c, b));
        if fa == 0.0 {
            roots.push(a);
            continue;
        }
        if fa.signum() == fb.signum() {
            // A stationary point touching 0 is a (double) root; it is a candidate either way.
            if fb.abs() <= 1e-12 * scale {
                roots.push(b);
            }
            continue;
        }
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                break;
            }
            if poly_at(c, m).signum() == fa.signum() {
                a = m;
            } else {
                b = m;
            }
        }
        roots.push(0.5 * (a + b));
    }
    roots
}

/// A least-squares polynomial of the given order through the points (x_i, y_i) (Walch sec.
/// 7.3 and ch. 8): the coefficients c_0..c_order of sum c_k x^k. Fewer points than
/// coefficients lower the order (one point: a constant). The normal equations are solved in x
/// scaled to [-1, 1] about the points' middle, then expanded back.
pub fn polyfit(xs: &[f64], ys: &[f64], order: usize) -> Vec<f64> {
    let n = xs.len().min(ys.len());
    if n == 0 {
        return vec![0.0];
    }
    let order = order.min(n - 1);
    let (lo, hi) = xs[..n].iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo)).max(1e-12);
    let m = order + 1;
    let mut a = vec![vec![0.0; m + 1]; m];
    for i in 0..n {
        let u = (xs[i] - mid) / half;
        let powers: Vec<f64> = (0..m).map(|k| u.powi(k as i32)).collect();
        for r in 0..m {
            for c in 0..m {
                a[r][c] += powers[r] * powers[c];
            }
            a[r][m] += powers[r] * ys[i];
        }
    }
    // Gauss-Jordan with partial pivoting.
    for col in 0..m {
        let pivot = (col..m).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs())).unwrap_or(col);
        a.swap(col, pivot);
        let p = a[col][col];
        if p.abs() < 1e-300 {
            continue;
        }
        let pivot_row = a[col].clone();
        for (r, row) in a.iter_mut().enumerate() {
            if r != col {
                let f = row[col] / p;
                for (v, q) in row.iter_mut().zip(&pivot_row).skip(col) {
                    *v -= f * q;
                }
            }
        }
    }
    let scaled: Vec<f64> = (0..m).map(|k| if a[k][k] != 0.0 { a[k][m] / a[k][k] } else { 0.0 }).collect();
    // sum b_k ((x - mid) / half)^k expanded into powers of x.
    let mut out = vec![0.0; m];
    for (k, b) in scaled.iter().enumerate() {
        // (x - mid)^k by the binomial theorem.
        let mut binom = 1.0;
        for (j, o) in out.iter_mut().enumerate().take(k + 1) {
            *o += b / half.powi(k as i32) * binom * (-mid).powi((k - j) as i32);
            binom = binom * (k - j) as f64 / (j + 1) as f64;
        }
    }
    out
}

/// sum c_k x^k.
pub fn poly_eval(c: &[f64], x: f64) -> f64 {
    poly_at(c, x)
}

/// A ghost as polynomials of the constellation angle (Walch ch. 8, the angle of eq 8.1): one
/// per parameter of [`PARAM_NAMES`], each valid over `angles_deg`.
#[derive(Clone, Debug, PartialEq)]
pub struct GhostPolynomials {
    /// The fitted range of angles (degrees).
    pub angles_deg: [f64; 2],
    /// Coefficients c_0.. of each parameter, in [`PARAM_NAMES`] order.
    pub coefficients: Vec<Vec<f64>>,
}

impl GhostPolynomials {
    /// Each parameter's least-squares polynomial of `order` over the fitted samples.
    pub fn fit(angles_deg: &[f64], ghosts: &[BezierGhost], order: usize) -> GhostPolynomials {
        let params: Vec<[f64; PARAMS]> = ghosts.iter().map(BezierGhost::to_params).collect();
        let coefficients =
            (0..PARAMS).map(|k| polyfit(angles_deg, &params.iter().map(|p| p[k]).collect::<Vec<_>>(), order)).collect();
        let lo = angles_deg.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = angles_deg.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        GhostPolynomials { angles_deg: [lo, hi], coefficients }
    }

    /// The primitive at `angle_deg` (clamped to the fitted range: no extrapolation), each
    /// parameter kept in its valid range ([`PARAM_RANGES`]: a parabola through sizes, fades or
    /// lights near their bound may cross it between the samples).
    pub fn at(&self, angle_deg: f64) -> BezierGhost {
        let a = angle_deg.clamp(self.angles_deg[0], self.angles_deg[1]);
        let mut p = [0.0; PARAMS];
        for (k, c) in self.coefficients.iter().enumerate().take(PARAMS) {
            let (lo, hi) = PARAM_RANGES[k];
            p[k] = poly_eval(c, a).clamp(lo, hi);
        }
        BezierGhost::from_params(&p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn circle(r: f64) -> BezierGhost {
        BezierGhost {
            centre_px: [50.0, 40.0],
            height_px: r,
            left_px: r,
            right_px: r,
            left_control: CIRCLE_CONTROL,
            right_control: CIRCLE_CONTROL,
            transfer: Transfer {
                border: 2.0,
                inner: 0.5,
                inner_falloff_px: 4.0,
                outer_falloff_px: 2.0,
                inner_exponent: 1.0,
                outer_exponent: 2.0,
            },
        }
    }

    #[test]
    fn eq_6_4_transfer_matches_hand_values() {
        let t = circle(10.0).transfer;
        // On the border: I_b.
        assert_eq!(t.intensity(0.0), 2.0);
        // Inside, d = 1: S = 1/4, S^1 = 0.25: 2 + (0.5 - 2) 0.25 = 1.625.
        assert!((t.intensity(1.0) - 1.625).abs() < 1e-12);
        // Inside, d = 3: S = 0.75: 2 - 1.5 * 0.75 = 0.875; past F_i: I_i.
        assert!((t.intensity(3.0) - 0.875).abs() < 1e-12);
        assert_eq!(t.intensity(9.0), 0.5);
        // Outside, d = -1: S = 1/2, S^2 = 0.25: 2 (1 - 0.25) = 1.5; d = -1.5: 2 (1 - 0.5625).
        assert!((t.intensity(-1.0) - 1.5).abs() < 1e-12);
        assert!((t.intensity(-1.5) - 0.875).abs() < 1e-12);
        // Past F_o: 0; a zero fade range is a step; NaN gives 0.
        assert_eq!(t.intensity(-2.5), 0.0);
        let step = Transfer { outer_falloff_px: 0.0, ..t };
        assert_eq!(step.intensity(-1e-9), 0.0);
        assert_eq!(t.intensity(f64::NAN), 0.0);
    }

    #[test]
    fn the_sides_join_and_the_circle_control_makes_a_circle() {
        let g = circle(10.0);
        let s = g.sides();
        for k in 0..4 {
            assert_eq!(s[k][3], s[(k + 1) % 4][0], "side {k} ends where side {} starts", (k + 1) % 4);
            // One tangent line at every join (the control points on both sides lie on it).
            let a = cubic_tangent(&s[k], 1.0);
            let b = cubic_tangent(&s[(k + 1) % 4], 0.0);
            assert!((a[0] * b[1] - a[1] * b[0]).abs() < 1e-9 && a[0] * b[0] + a[1] * b[1] > 0.0);
        }
        // The four-piece circle's radius deviates by at most 0.027% (2.7e-4 r).
        for i in 0..=400 {
            let t = i as f64 / 400.0;
            for side in &s {
                let c = cubic_at(side, t);
                let r = (c[0] - 50.0).hypot(c[1] - 40.0);
                assert!((r / 10.0 - 1.0).abs() < 2.8e-4, "{r}");
            }
        }
    }

    #[test]
    fn inside_is_positive_outside_negative_by_eq_6_3() {
        let g = BezierGhost { left_px: 6.0, right_px: 14.0, left_control: 0.3, right_control: 0.8, ..circle(9.0) };
        assert!(g.signed_distance([50.0, 40.0]) > 5.0);
        assert!(g.signed_distance([50.0 + 13.0, 40.0]) > 0.0);
        assert!((g.signed_distance([50.0 + 16.0, 40.0]) + 2.0).abs() < 1e-9);
        assert!((g.signed_distance([50.0 - 10.0, 40.0]) + 4.0).abs() < 1e-9);
        assert!((g.signed_distance([50.0, 40.0 - 12.0]) + 3.0).abs() < 1e-9);
        // 2 px above the bottom assembly point: inside, the bottom (or the narrower left side
        // bending towards it) at most 2 px away.
        let near_bottom = g.signed_distance([50.0, 40.0 + 7.0]);
        assert!(near_bottom > 0.0 && near_bottom <= 2.0 + 1e-9, "{near_bottom}");
        // A diamond (control 0): the distance to its straight sides.
        let d = BezierGhost { left_control: 0.0, right_control: 0.0, ..circle(10.0) };
        let expect = 10.0 / 2f64.sqrt() - 0.0;
        assert!((d.signed_distance([50.0, 40.0]) - expect).abs() < 1e-9);
        // Outside past a corner: the distance to the corner itself, negative.
        assert!((d.signed_distance([50.0 + 13.0, 40.0]) + 3.0).abs() < 1e-9);
    }

    #[test]
    fn the_exact_distance_matches_dense_sampling() {
        let g = BezierGhost { left_px: 7.0, right_px: 15.0, left_control: 0.2, right_control: 0.9, ..circle(11.0) };
        let sides = g.sides();
        let mut seed = 12345u64;
        let mut rand = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..300 {
            let q = [30.0 + 40.0 * rand(), 20.0 + 40.0 * rand()];
            let brute = sides
                .iter()
                .flat_map(|s| (0..=20000).map(move |i| cubic_at(s, i as f64 / 20000.0)))
                .map(|c| (c[0] - q[0]).hypot(c[1] - q[1]))
                .fold(f64::INFINITY, f64::min);
            let exact = g.signed_distance(q).abs();
            // The dense sampling lies above the exact minimum by at most its spacing's square.
            assert!(exact <= brute + 1e-9 && brute - exact < 2e-4, "{q:?}: exact {exact}, sampled {brute}");
        }
    }

    #[test]
    fn the_roots_of_a_fifth_order_polynomial_are_found_in_the_interval() {
        // (t - 0.1)(t - 0.3)(t - 0.5)(t - 0.7)(t - 2): four roots in [0, 1].
        let mut c = vec![1.0];
        for r in [0.1, 0.3, 0.5, 0.7, 2.0] {
            let mut next = vec![0.0; c.len() + 1];
            for (i, &k) in c.iter().enumerate() {
                next[i + 1] += k;
                next[i] -= r * k;
            }
            c = next;
        }
        let roots = real_roots(&c, 0.0, 1.0);
        assert_eq!(roots.len(), 4, "{roots:?}");
        for (t, r) in roots.iter().zip([0.1, 0.3, 0.5, 0.7]) {
            assert!((t - r).abs() < 1e-12);
        }
    }

    #[test]
    fn an_order_2_polynomial_reproduces_a_quadratic_drift_over_13_samples() {
        // Walch ch. 10 figure 10.8: a ghost's centre over 13 samples drifts left, faster with
        // the angle (x = 812 - 31 a - 0.9 a^2 px at a = 10..22 degrees); order 2 gives it back
        // to 1e-9; order 1 leaves the curvature: 0.9 ((a - 16)^2 - 14) misses by 19.8 px at
        // the ends.
        let angles: Vec<f64> = (0..13).map(|i| 10.0 + i as f64).collect();
        let drift = |a: f64| 812.0 - 31.0 * a - 0.9 * a * a;
        let xs: Vec<f64> = angles.iter().map(|&a| drift(a)).collect();
        let c = polyfit(&angles, &xs, 2);
        assert!((c[0] - 812.0).abs() < 1e-6 && (c[1] + 31.0).abs() < 1e-7 && (c[2] + 0.9).abs() < 1e-9, "{c:?}");
        for a in [10.0, 13.7, 22.0] {
            assert!((poly_eval(&c, a) - drift(a)).abs() < 1e-9);
        }
        // Order 1 cannot: the residual of a line through a parabola over 12 degrees.
        let line = polyfit(&angles, &xs, 1);
        let worst = angles.iter().map(|&a| (poly_eval(&line, a) - drift(a)).abs()).fold(0.0, f64::max);
        assert!((worst - 19.8).abs() < 1e-6, "{worst}");
        // Through the ghost's parameters: the polynomials give every sample back.
        let ghosts: Vec<BezierGhost> = angles
            .iter()
            .map(|&a| BezierGhost {
                centre_px: [drift(a), 300.0 + 0.1 * a],
                height_px: 20.0 + 0.02 * a * a,
                ..circle(10.0)
            })
            .collect();
        let p = GhostPolynomials::fit(&angles, &ghosts, 2);
        for (a, g) in angles.iter().zip(&ghosts) {
            let back = p.at(*a);
            for (x, y) in back.to_params().iter().zip(g.to_params()) {
                assert!((x - y).abs() < 1e-8 * y.abs().max(1.0), "{a}: {x} vs {y}");
            }
        }
        // A least-squares parabola through sizes near their bound dips under it between the
        // samples (heights 2, 0.5, 0.5, 2 px at 0..3 degrees: 0.3125 + 0.75 (a - 1.5)^2, 0.3125
        // at 1.5): the primitive keeps 0.5 px there, the parabola's value elsewhere.
        let near = [2.0, 0.5, 0.5, 2.0].map(|height_px| BezierGhost { height_px, ..circle(10.0) });
        let dip = GhostPolynomials::fit(&[0.0, 1.0, 2.0, 3.0], &near, 2);
        assert!((poly_eval(&dip.coefficients[2], 1.5) - 0.3125).abs() < 1e-9);
        assert_eq!(dip.at(1.5).height_px, 0.5);
        assert!((dip.at(0.5).height_px - 1.0625).abs() < 1e-9);
        // Fewer samples than coefficients: a constant from one, a line from two (sec. 7.3).
        assert_eq!(polyfit(&[3.0], &[7.0], 2), vec![7.0]);
        let two = polyfit(&[1.0, 3.0], &[2.0, 6.0], 2);
        assert!(two.len() == 2 && (poly_eval(&two, 5.0) - 10.0).abs() < 1e-12);
    }
}
