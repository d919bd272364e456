//! Spherical aberration in the bokeh (Kyaw 2013 sec 6.3.1, sec 7.3, appendix 11.2-11.3), from a
//! ray model instead of painted textures.
//!
//! Longitudinal spherical aberration moves the focus of each pupil zone by an amount growing
//! with the square of the zone's radius rho (0 at the axis, 1 at the rim). For a defocused point
//! the ray through zone rho lands on the film at a radius made of the defocus term (linear in
//! rho) plus the focus shift seen at the film (cubic in rho):
//!     r(rho) = rho (1 + s rho^2) / (1 + s),         normalised so the rim lands at r = 1,
//! where s is the ratio of the aberration to the defocus at the rim. The pupil is lit
//! uniformly, so the light of the annulus rho..rho+drho lands on r..r+dr:
//!     I(r) 2 pi r dr = 2 pi rho drho   =>   I(r) = (1 + s)^2 / ((1 + s rho^2)(1 + 3 s rho^2)),
//! which keeps the disk's energy exactly (I = 1 for s = 0).
//! Behind the focus plane the defocus has one sign, in front the other, so s flips sign: an
//! under-corrected lens (s > 0 behind) gives the background a bright core fading outwards and
//! the foreground a dark core with a bright rim; over-correction swaps them.

/// The CoC diameter on the film (mm) at which an amount reaches its full strength: 64 px of a
/// 1920 px wide full-frame image, where it was set; on the film, so that the look does not
/// change with the resolution.
pub const FULL_STRENGTH_COC_MM: f64 = 1.2;

/// Largest |s|: at s = -1/3 the rim rays cross (a caustic), so the model stays below it.
pub const MAX_STRENGTH: f64 = 0.3;

/// s for a sample with signed CoC `coc_px`: like the appendix shader, the amount grows with the
/// CoC diameter relative to the largest CoC (`max_coc_px`), is clamped to [-1, 1], and is negated
/// in front of the focus plane; then scaled to the model's range.
pub fn strength(amount: f64, coc_px: f64, max_coc_px: f64) -> f64 {
    let sa = (amount * coc_px.abs() / max_coc_px.max(1e-9)).clamp(-1.0, 1.0);
    let signed = if coc_px < 0.0 { -sa } else { sa };
    signed * MAX_STRENGTH
}

/// s from a traced lens: the zone rho focuses LSA rho^2 from the paraxial focus, so at a film
/// defocus Delta its ray lands at rho (Delta - LSA rho^2) (in units of the rim's defocus blur),
/// i.e. s = -LSA / Delta. In CoC terms (both seen as blur diameters on the film, px) that is
/// s = lsa_coc_px / coc_px with lsa_coc_px = -LSA / (N' P pitch): the aberration matters less as
/// the defocus grows, has the CoC's sign (so it flips in front of the focus plane by itself), and
/// is clamped to the model's range near focus, where the aberration would exceed the defocus
/// (the rim rays cross: a caustic the model does not represent).
pub fn strength_traced(lsa_coc_px: f64, coc_px: f64) -> f64 {
    if coc_px == 0.0 {
        return 0.0;
    }
    (lsa_coc_px / coc_px).clamp(-MAX_STRENGTH, MAX_STRENGTH)
}

/// Film radius (0..1) of the ray through pupil zone `rho` (0..1).
pub fn landing_radius(s: f64, rho: f64) -> f64 {
    rho * (1.0 + s * rho * rho) / (1.0 + s)
}

/// The pupil zone whose rays land at film radius `r` (0..1): Newton on the cubic, monotonic
/// for |s| < 1/3.
pub fn pupil_zone(s: f64, r: f64) -> f64 {
    let r = r.clamp(0.0, 1.0);
    let mut rho = r;
    for _ in 0..8 {
        let f = rho + s * rho * rho * rho - (1.0 + s) * r;
        let df = 1.0 + 3.0 * s * rho * rho;
        rho = (rho - f / df).clamp(0.0, 1.0);
    }
    rho
}

/// Relative intensity at film radius `r` (0..1) of the disk; its mean over the disk is 1.
pub fn intensity(s: f64, r: f64) -> f64 {
    let rho = pupil_zone(s, r);
    (1.0 + s) * (1.0 + s) / ((1.0 + s * rho * rho) * (1.0 + 3.0 * s * rho * rho))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_aberration_is_uniform() {
        for r in [0.0, 0.3, 0.99] {
            assert_eq!(intensity(0.0, r), 1.0);
        }
    }

    #[test]
    fn disk_energy_is_kept() {
        // Integral of I(r) 2 pi r dr over the unit disk = pi for every s.
        for s in [-0.3, -0.1, 0.1, 0.3] {
            let n = 20000;
            let total: f64 = (0..n)
                .map(|i| {
                    let r = (i as f64 + 0.5) / n as f64;
                    intensity(s, r) * 2.0 * std::f64::consts::PI * r / n as f64
                })
                .sum();
            assert!((total / std::f64::consts::PI - 1.0).abs() < 2e-3, "s {s}: {total}");
        }
    }

    #[test]
    fn pupil_zone_inverts_the_landing_radius() {
        for s in [-0.3, 0.0, 0.3] {
            for rho in [0.0, 0.25, 0.5, 0.9, 1.0] {
                assert!((pupil_zone(s, landing_radius(s, rho)) - rho).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn under_corrected_background_has_a_bright_core_and_foreground_a_bright_rim() {
        let background = strength(1.0, 40.0, 40.0);
        let foreground = strength(1.0, -40.0, 40.0);
        assert!(background > 0.0 && foreground < 0.0);
        assert!(intensity(background, 0.0) > intensity(background, 0.9));
        assert!(intensity(foreground, 0.9) > intensity(foreground, 0.0));
        // Over-correction swaps them.
        let over_background = strength(-1.0, 40.0, 40.0);
        assert!(intensity(over_background, 0.9) > intensity(over_background, 0.0));
        // The amount grows with the CoC like the appendix shader: half the CoC, half of s.
        assert!((strength(1.0, 20.0, 40.0) - 0.5 * background).abs() < 1e-15);
    }
}
