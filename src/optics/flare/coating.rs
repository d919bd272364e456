//! Reflectance of one lens surface: Fresnel's equations for unpolarised light (Walch 2017 eq
//! 3.2: R = (R_s + R_p) / 2, T = 1 - R), bare or with a single-layer anti-reflection coating.
//!
//! The coating is the classic quarter-wave layer: index n1 = sqrt(n0 n2) between the media n0
//! and n2 (at the design wavelength), thickness lambda0 / (4 n1), so that the two reflections
//! (at n0|n1 and n1|n2) are equally strong and half a wave apart at lambda0 and cancel there.
//! Away from lambda0 (and at oblique incidence) they no longer cancel: the residual reflection
//! is what colours the ghosts. The layer's amplitude reflectance is the thin-film (Airy) sum
//!     r = (r01 + r12 e^(2i beta)) / (1 + r01 r12 e^(2i beta)),  beta = 2 pi n1 d cos(theta1) / lambda,
//! for each polarisation, with complex cosines so that total internal reflection and evanescent
//! layers come out right (|r| = 1 when nothing propagates in the exit medium).

use std::ops::{Add, Div, Mul, Sub};

/// A complex number, just what the thin-film sum needs.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Complex {
    re: f64,
    im: f64,
}

impl Complex {
    const ONE: Complex = Complex { re: 1.0, im: 0.0 };

    fn real(re: f64) -> Complex {
        Complex { re, im: 0.0 }
    }

    fn norm_sqr(self) -> f64 {
        self.re * self.re + self.im * self.im
    }

    /// Principal square root (imaginary part >= 0 for negative reals: an evanescent wave decays).
    fn sqrt(self) -> Complex {
        let r = self.norm_sqr().sqrt();
        let re = ((r + self.re) * 0.5).max(0.0).sqrt();
        let im = ((r - self.re) * 0.5).max(0.0).sqrt();
        Complex { re, im: if self.im < 0.0 { -im } else { im } }
    }

    /// e^(i z).
    fn exp_i(z: Complex) -> Complex {
        let m = (-z.im).exp();
        Complex { re: m * z.re.cos(), im: m * z.re.sin() }
    }
}

impl Add for Complex {
    type Output = Complex;
    fn add(self, o: Complex) -> Complex {
        Complex { re: self.re + o.re, im: self.im + o.im }
    }
}

impl Sub for Complex {
    type Output = Complex;
    fn sub(self, o: Complex) -> Complex {
        Complex { re: self.re - o.re, im: self.im - o.im }
    }
}

impl Mul for Complex {
    type Output = Complex;
    fn mul(self, o: Complex) -> Complex {
        Complex { re: self.re * o.re - self.im * o.im, im: self.re * o.im + self.im * o.re }
    }
}

impl Div for Complex {
    type Output = Complex;
    fn div(self, o: Complex) -> Complex {
        let d = o.norm_sqr();
        if d == 0.0 {
            return Complex::ONE;
        }
        Complex { re: (self.re * o.re + self.im * o.im) / d, im: (self.im * o.re - self.re * o.im) / d }
    }
}

/// A single-layer anti-reflection coating.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// The layer's refractive index (no dispersion).
    pub index: f64,
    pub thickness_nm: f64,
}

impl Layer {
    /// The quarter-wave layer for the media `n0` | `n2` (their indices at `design_nm`):
    /// n1 = sqrt(n0 n2), thickness = design_nm / (4 n1).
    pub fn quarter_wave(n0: f64, n2: f64, design_nm: f64) -> Layer {
        let index = (n0 * n2).sqrt();
        Layer { index, thickness_nm: design_nm / (4.0 * index) }
    }
}

/// Amplitude reflection coefficients (s, p) at the interface a | b for the complex cosines of
/// the angles in each medium.
fn fresnel_amplitudes(na: f64, cos_a: Complex, nb: f64, cos_b: Complex) -> (Complex, Complex) {
    let (na, nb) = (Complex::real(na), Complex::real(nb));
    let s = (na * cos_a - nb * cos_b) / (na * cos_a + nb * cos_b);
    let p = (nb * cos_a - na * cos_b) / (nb * cos_a + na * cos_b);
    (s, p)
}

/// Fraction of the light's power reflected at the interface from the medium `n_in` (where the
/// light comes from) into `n_out`, for unpolarised light at incidence cosine `cos_in` (in
/// `n_in`) and wavelength `lambda_nm`; with `layer`, a coating between the two media.
pub fn reflectance(n_in: f64, n_out: f64, cos_in: f64, lambda_nm: f64, layer: Option<Layer>) -> f64 {
    let cos_in = cos_in.abs().min(1.0);
    let sin2 = 1.0 - cos_in * cos_in;
    // Snell: n sin(theta) is the same in every layer; cos = sqrt(1 - (n_in sin_in / n)^2).
    let cos_of = |n: f64| (Complex::ONE - Complex::real(n_in * n_in * sin2 / (n * n))).sqrt();
    let c0 = Complex::real(cos_in);
    let c2 = cos_of(n_out);
    let (rs, rp) = match layer {
        None => fresnel_amplitudes(n_in, c0, n_out, c2),
        Some(l) => {
            let c1 = cos_of(l.index);
            let (s01, p01) = fresnel_amplitudes(n_in, c0, l.index, c1);
            let (s12, p12) = fresnel_amplitudes(l.index, c1, n_out, c2);
            // e^(2 i beta), beta = 2 pi n1 d cos(theta1) / lambda.
            let beta = Complex::real(2.0 * std::f64::consts::PI * l.index * l.thickness_nm / lambda_nm) * c1;
            let phase = Complex::exp_i(Complex::real(2.0) * beta);
            let sum = |r01: Complex, r12: Complex| (r01 + r12 * phase) / (Complex::ONE + r01 * r12 * phase);
            (sum(s01, s12), sum(p01, p12))
        }
    };
    (0.5 * (rs.norm_sqr() + rp.norm_sqr())).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bare_glass_at_normal_incidence_is_the_textbook_value() {
        // ((n2 - n1) / (n2 + n1))^2: 4% for n = 1.5, the same from either side.
        let r = reflectance(1.0, 1.5, 1.0, 550.0, None);
        assert!((r - 0.04).abs() < 1e-15, "{r}");
        assert!((reflectance(1.5, 1.0, 1.0, 550.0, None) - 0.04).abs() < 1e-15);
    }

    #[test]
    fn bare_glass_at_brewster_and_grazing_incidence() {
        // At Brewster's angle tan(theta) = n2/n1 the p wave is not reflected: R = R_s / 2.
        let n = 1.5f64;
        let theta = n.atan();
        let (ci, ct) = (theta.cos(), (1.0 - (theta.sin() / n).powi(2)).sqrt());
        let rs = ((ci - n * ct) / (ci + n * ct)).powi(2);
        let r = reflectance(1.0, n, ci, 550.0, None);
        assert!((r - 0.5 * rs).abs() < 1e-12, "{r} vs {}", 0.5 * rs);
        // Grazing incidence reflects everything; beyond the critical angle, inside the glass, too.
        assert!(reflectance(1.0, n, 1e-9, 550.0, None) > 0.999_999);
        let critical = (1.0 / n).asin();
        assert!((reflectance(n, 1.0, (critical + 0.01).cos(), 550.0, None) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_quarter_wave_layer_cancels_the_reflection_at_its_design_wavelength() {
        let layer = Layer::quarter_wave(1.0, 1.69, 550.0);
        assert!((layer.index - 1.69f64.sqrt()).abs() < 1e-15);
        assert!((layer.thickness_nm - 550.0 / (4.0 * layer.index)).abs() < 1e-12);
        assert!(reflectance(1.0, 1.69, 1.0, 550.0, Some(layer)) < 1e-30);
        // ... from the glass side too.
        assert!(reflectance(1.69, 1.0, 1.0, 550.0, Some(layer)) < 1e-30);
        // At half the design wavelength the layer is half a wave thick: an absentee layer, the
        // bare surface's reflectance.
        let bare = reflectance(1.0, 1.69, 1.0, 275.0, None);
        let at_half = reflectance(1.0, 1.69, 1.0, 275.0, Some(layer));
        assert!((at_half - bare).abs() < 1e-12, "{at_half} vs {bare}");
    }

    #[test]
    fn the_residual_reflection_follows_the_thin_film_formula() {
        // At normal incidence, R = (r01^2 + r12^2 + 2 r01 r12 cos 2b) / (1 + r01^2 r12^2 + 2 r01 r12 cos 2b)
        // with b = 2 pi n1 d / lambda (the Airy sum written out for real coefficients).
        let (n0, n2) = (1.0, 1.6398);
        let layer = Layer::quarter_wave(n0, n2, 550.0);
        for lambda in [400.0, 450.0, 500.0, 600.0, 650.0, 700.0] {
            let r01 = (n0 - layer.index) / (n0 + layer.index);
            let r12 = (layer.index - n2) / (layer.index + n2);
            let c = (4.0 * std::f64::consts::PI * layer.index * layer.thickness_nm / lambda).cos();
            let expected =
                (r01 * r01 + r12 * r12 + 2.0 * r01 * r12 * c) / (1.0 + (r01 * r12).powi(2) + 2.0 * r01 * r12 * c);
            let r = reflectance(n0, n2, 1.0, lambda, Some(layer));
            assert!((r - expected).abs() < 1e-14, "{lambda} nm: {r} vs {expected}");
            // Below the bare surface everywhere in the visible (a single layer never adds to it
            // when n1 lies between n0 and n2), largest at the ends of the spectrum.
            assert!(r < reflectance(n0, n2, 1.0, lambda, None));
        }
        let blue = reflectance(n0, n2, 1.0, 400.0, Some(layer));
        let green = reflectance(n0, n2, 1.0, 550.0, Some(layer));
        assert!(blue > 1e-3 && green < 1e-20, "{blue} {green}");
    }

    #[test]
    fn total_internal_reflection_through_a_coating_is_total() {
        let layer = Layer::quarter_wave(1.0, 1.5, 550.0);
        let beyond_critical = (1.0f64 / 1.5).asin() + 0.05;
        let r = reflectance(1.5, 1.0, beyond_critical.cos(), 550.0, Some(layer));
        assert!((r - 1.0).abs() < 1e-12, "{r}");
    }
}
