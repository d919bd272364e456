//! The starburst and the halo around a bright light (Walch 2017 sec. 3.2).
//!
//! The starburst is the Fraunhofer diffraction pattern of the aperture: the image of a point is
//! |F(x / (lambda z))|^2 / ((lambda z)^2 area), F the aperture's Fourier transform. For a
//! polygon F has a closed form (the divergence theorem turns the area integral into one over
//! the edges):
//!     F(k) = i / (2 pi |k|^2) sum_e (k . n_e) L_e e^(-2 pi i k . m_e) sinc(pi L_e k . t_e),
//! edge e of length L_e, outward normal n_e, midpoint m_e, direction t_e. Far from the centre
//! each edge's term stands out along its normal: a spike whose light, integrated across it (the
//! sinc^2 integrates to 1 / L_e), is L_e / (4 pi^2 |k|^2) per unit |k|. On the film, with
//! z / (2a) = N (a: the pupil's circumradius, N the working f-number), one spike (one edge, one
//! side) carries
//!     lambda N L1 / (2 pi^2 A1 r^2)  per mm of its length at r mm from the light,
//! per unit of the light's energy, L1 and A1 the edge and area of the unit-circumradius
//! polygon. Every edge makes two spikes 180 degrees apart; for an even blade count opposite
//! edges are parallel and their spikes coincide: n spikes for an even count, 2n for an odd one
//! (Walch sec. 3.2). All spikes together carry lambda N P1 / (pi^2 A1 r) of the light beyond r:
//! for a circle (P1 / A1 = 2) that is 2 lambda N / (pi^2 r), the tail of the Airy pattern's
//! encircled energy, 1 - EE(v) -> 2 / (pi v), v = pi r / (lambda N).
//!
//! A circular aperture (and the rounded part of curved blades) has no spikes: its diffraction
//! is a smooth glow of lambda N / (pi^3 r^3) per mm^2 (the same tail, spread round).
//!
//! The halo is the light the lens's glass scatters near the light (Walch sec. 3.2, after
//! [Cha07]): a share `fraction` of it spread as fraction / (2 pi rho^2) (1 + r^2/rho^2)^(-3/2)
//! per mm^2, normalised over the plane, falling as r^-3 like real veiling glare far out.

use super::AperturePolygon;

/// The share of a spike's light on its centre line for a light whose image covers `area_px`
/// pixels, relative to a light of one pixel (the star as drawn): 1 for one pixel, about
/// 1.33 / D for a large image of diameter D = 2 sqrt(area / pi) px.
///
/// The starburst is the image of a point in focus (the Fraunhofer pattern of the aperture,
/// Walch 2017 sec. 3.2). A point out of focus images as its circle of confusion, the disc of
/// eq 5.3 (Kyaw 2013) that Potmesil & Chakravarty 1981 fill with the diffraction pattern of a
/// defocused aperture (their eq 13-19: the light spreads over the geometric CoC, its edges
/// ringing); in the geometric limit its image is the star convolved with that disc. So is an
/// extended source's image: the star convolved with the source's image. A spike is a line of
/// light density s(r) falling as 1/r^2 along it; convolved with a uniform disc of diameter D it
/// becomes a band whose profile across it is the disc's chord, so that far from the light
/// (r >> D, where s barely changes over D) the band still holds s(r) per unit of length, but
/// the row of pixels on its centre line (1 px wide) holds only the share of the disc's area
/// within |y| <= 1/2:
///     S(D) = (2 / pi) (asin h + h sqrt(1 - h^2)),  h = min(1, 1/D),
/// 1 for D <= 1 and 4 / (pi D) for D >> 1. The star's contrast falls as the light's disc grows.
/// A light of one pixel (D1 = 2 / sqrt(pi)) is what the drawn star stands for, so the drawn
/// spike carries S(D) / S(D1) of its light along its centre line; the rest stays in the
/// light's own pixels (the energy is kept). The round diffraction glow and the halo are smooth
/// in two dimensions: the disc changes them only within a few D of the light, where they are
/// not drawn (they start at the light's own radius), so they are kept as they are.
///
/// The light's area is its pixels over the flare threshold after the depth of field: for a
/// point defocused to a plateau over the threshold, its CoC disc.
pub fn spike_share(area_px: f64) -> f64 {
    let strip = |d: f64| {
        let h = (1.0 / d).min(1.0);
        2.0 / std::f64::consts::PI * (h.asin() + h * (1.0 - h * h).max(0.0).sqrt())
    };
    let diameter = |a: f64| 2.0 * (a.max(1.0) / std::f64::consts::PI).sqrt();
    (strip(diameter(area_px)) / strip(diameter(1.0))).min(1.0)
}

/// The diffraction of a lens's aperture at a working f-number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Starburst {
    pub aperture: AperturePolygon,
    pub working_f_number: f64,
}

/// A spike: its direction (unit, x right, y down) and how many edges' spikes coincide in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spike {
    pub direction: [f64; 2],
    pub edges: f64,
}

impl Starburst {
    /// Edge length and area of the unit-circumradius polygon.
    fn unit_polygon(&self) -> (f64, f64) {
        let n = self.aperture.blades as f64;
        (2.0 * (std::f64::consts::PI / n).sin(), 0.5 * n * (2.0 * std::f64::consts::PI / n).sin())
    }

    /// The share of the light diffracted by straight blade edges (1 - curvature); 0 for a circle.
    fn straight_share(&self) -> f64 {
        if self.aperture.blades >= 3 {
            (1.0 - self.aperture.curvature).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The spikes: along every edge normal and its opposite, coinciding pairs merged.
    pub fn spikes(&self) -> Vec<Spike> {
        if self.straight_share() <= 0.0 {
            return Vec::new();
        }
        let mut spikes: Vec<Spike> = Vec::new();
        for n in self.aperture.edge_normals() {
            for d in [n, [-n[0], -n[1]]] {
                match spikes.iter_mut().find(|s| (s.direction[0] - d[0]).abs() + (s.direction[1] - d[1]).abs() < 1e-9) {
                    Some(s) => s.edges += 1.0,
                    None => spikes.push(Spike { direction: d, edges: 1.0 }),
                }
            }
        }
        spikes
    }

    /// Light per mm of one edge's spike at `r_mm` from the light, per unit of its energy.
    pub fn spike_line_density(&self, lambda_nm: f64, r_mm: f64) -> f64 {
        self.spike_coefficient(lambda_nm) / (r_mm * r_mm)
    }

    /// `spike_line_density` times r^2 (mm).
    pub fn spike_coefficient(&self, lambda_nm: f64) -> f64 {
        if self.straight_share() <= 0.0 {
            return 0.0;
        }
        let (l1, a1) = self.unit_polygon();
        self.straight_share() * lambda_nm * 1e-6 * self.working_f_number * l1
            / (2.0 * std::f64::consts::PI.powi(2) * a1)
    }

    /// Share of the light in all spikes between `r0_mm` and `r1_mm` from it.
    pub fn spike_fraction(&self, lambda_nm: f64, r0_mm: f64, r1_mm: f64) -> f64 {
        2.0 * self.aperture.blades as f64 * self.spike_coefficient(lambda_nm) * (1.0 / r0_mm - 1.0 / r1_mm.max(r0_mm))
    }

    /// Light per mm^2 of the smooth (circular) diffraction at `r_mm`, per unit of the energy.
    pub fn glow_density(&self, lambda_nm: f64, r_mm: f64) -> f64 {
        self.glow_coefficient(lambda_nm) / r_mm.powi(3)
    }

    /// `glow_density` times r^3 (mm).
    pub fn glow_coefficient(&self, lambda_nm: f64) -> f64 {
        (1.0 - self.straight_share()) * lambda_nm * 1e-6 * self.working_f_number / std::f64::consts::PI.powi(3)
    }

    /// Share of the light in the smooth diffraction between `r0_mm` and `r1_mm`.
    pub fn glow_fraction(&self, lambda_nm: f64, r0_mm: f64, r1_mm: f64) -> f64 {
        2.0 * std::f64::consts::PI * self.glow_coefficient(lambda_nm) * (1.0 / r0_mm - 1.0 / r1_mm.max(r0_mm))
    }
}

/// The lens's scattering around a light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Halo {
    /// Share of the light scattered into the halo (over the whole plane).
    pub fraction: f64,
    /// Its radius rho (mm on the film).
    pub radius_mm: f64,
}

impl Halo {
    /// Light per mm^2 at `r_mm`, per unit of the light's energy.
    pub fn density(&self, r_mm: f64) -> f64 {
        let rho2 = self.radius_mm * self.radius_mm;
        self.fraction / (2.0 * std::f64::consts::PI * rho2) * (1.0 + r_mm * r_mm / rho2).powf(-1.5)
    }

    /// Share of the light between `r0_mm` and `r1_mm`.
    pub fn fraction_between(&self, r0_mm: f64, r1_mm: f64) -> f64 {
        let outside = |r: f64| 1.0 / (1.0 + (r / self.radius_mm).powi(2)).sqrt();
        self.fraction * (outside(r0_mm) - outside(r1_mm.max(r0_mm)))
    }

    /// The radius beyond which the density stays below `density` (0 if it never reaches it).
    pub fn radius_below(&self, density: f64) -> f64 {
        let peak = self.density(0.0);
        if density.is_nan() || density <= 0.0 || peak <= density {
            return 0.0;
        }
        self.radius_mm * ((peak / density).powf(2.0 / 3.0) - 1.0).max(0.0).sqrt()
    }
}

/// The Fourier transform F(k) (k in cycles per unit length) of the polygon with `vertices`
/// (counter-clockwise, x right, y up), as (re, im): the edge sum of the module documentation.
pub fn polygon_transform(vertices: &[[f64; 2]], k: [f64; 2]) -> (f64, f64) {
    let k2 = k[0] * k[0] + k[1] * k[1];
    if k2 == 0.0 {
        let area =
            vertices.iter().zip(vertices.iter().cycle().skip(1)).map(|(a, b)| 0.5 * (a[0] * b[1] - a[1] * b[0])).sum();
        return (area, 0.0);
    }
    let (mut re, mut im) = (0.0, 0.0);
    for (a, b) in vertices.iter().zip(vertices.iter().cycle().skip(1)) {
        let t = [b[0] - a[0], b[1] - a[1]];
        let len = (t[0] * t[0] + t[1] * t[1]).sqrt();
        let n = [t[1] / len, -t[0] / len];
        let m = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        let x = std::f64::consts::PI * (k[0] * t[0] + k[1] * t[1]);
        let sinc = if x.abs() < 1e-12 { 1.0 } else { x.sin() / x };
        let amplitude = (k[0] * n[0] + k[1] * n[1]) * len * sinc;
        let phase = -2.0 * std::f64::consts::PI * (k[0] * m[0] + k[1] * m[1]);
        re += amplitude * phase.cos();
        im += amplitude * phase.sin();
    }
    // i / (2 pi k^2) times the sum.
    let s = 1.0 / (2.0 * std::f64::consts::PI * k2);
    (-im * s, re * s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn a_spikes_share_on_its_centre_line_falls_with_the_lights_disc() {
        // The share of a uniform disc of diameter D within a strip 1 px wide through its centre,
        // counted on a fine grid, against the closed form (relative to one pixel's disc).
        let strip_counted = |d: f64| {
            let (n, r) = (2000, 0.5 * d);
            let step = d / n as f64;
            let (mut inside, mut strip) = (0usize, 0usize);
            for i in 0..n {
                for j in 0..n {
                    let (x, y) = (-r + (i as f64 + 0.5) * step, -r + (j as f64 + 0.5) * step);
                    if x * x + y * y <= r * r {
                        inside += 1;
                        strip += (y.abs() <= 0.5) as usize;
                    }
                }
            }
            strip as f64 / inside as f64
        };
        let d1 = 2.0 / PI.sqrt();
        for d in [2.0, 5.0, 24.1] {
            let area = PI * d * d / 4.0;
            let counted = strip_counted(d) / strip_counted(d1);
            assert!((spike_share(area) - counted).abs() < 2e-3, "D {d}: {} vs {counted}", spike_share(area));
        }
        // One pixel keeps its star; a large disc, 4 / (pi D) of one pixel's strip share.
        assert_eq!(spike_share(1.0), 1.0);
        assert_eq!(spike_share(0.25), 1.0);
        let d = 100.0;
        let expected = 4.0 / (PI * d) / (2.0 / PI * ((1.0 / d1).asin() + (1.0 - 1.0 / (d1 * d1)).sqrt() / d1));
        assert!((spike_share(PI * d * d / 4.0) / expected - 1.0).abs() < 1e-4);
        let shares: Vec<f64> = (1..200).map(|a| spike_share(a as f64)).collect();
        assert!(shares.windows(2).all(|w| w[1] < w[0]), "falls with the area");
    }

    fn polygon(n: u32) -> Vec<[f64; 2]> {
        (0..n).map(|k| 0.5 * PI + 2.0 * PI * k as f64 / n as f64).map(|a| [a.cos(), a.sin()]).collect()
    }

    #[test]
    fn the_edge_sum_is_the_fourier_transform() {
        // At k = 0 the area; elsewhere a direct numerical integral over the polygon.
        let hexagon = polygon(6);
        assert!((polygon_transform(&hexagon, [0.0, 0.0]).0 - 1.5 * 3f64.sqrt()).abs() < 1e-12);
        let k = [0.37, -0.21];
        let (mut re, mut im) = (0.0, 0.0);
        let steps = 1000;
        let h = 2.0 / steps as f64;
        let star = Starburst {
            aperture: AperturePolygon { blades: 6, rotation_rad: 0.0, curvature: 0.0 },
            working_f_number: 1.0,
        };
        for i in 0..steps * steps {
            let (x, y) = (-1.0 + ((i % steps) as f64 + 0.5) * h, -1.0 + ((i / steps) as f64 + 0.5) * h);
            // The aperture's sdf takes y down.
            if star.aperture.sdf([x, -y], 1.0) < 0.0 {
                let phase = -2.0 * PI * (k[0] * x + k[1] * y);
                re += phase.cos() * h * h;
                im += phase.sin() * h * h;
            }
        }
        let (fr, fi) = polygon_transform(&hexagon, k);
        assert!((fr - re).abs() < 2e-3 && (fi - im).abs() < 2e-3, "({fr}, {fi}) vs ({re}, {im})");
    }

    #[test]
    fn spikes_n_for_even_blade_counts_2n_for_odd() {
        for (blades, spikes) in [(5, 10), (6, 6), (7, 14), (8, 8)] {
            let star = Starburst {
                aperture: AperturePolygon { blades, rotation_rad: 0.3, curvature: 0.0 },
                working_f_number: 4.0,
            };
            let s = star.spikes();
            assert_eq!(s.len(), spikes, "{blades} blades");
            assert_eq!(s.iter().map(|s| s.edges).sum::<f64>(), 2.0 * blades as f64);
        }
        let round = Starburst { aperture: AperturePolygon::CIRCLE, working_f_number: 4.0 };
        assert!(round.spikes().is_empty());
    }

    #[test]
    fn the_spikes_carry_the_fourier_transforms_light() {
        // |F|^2 / area integrated over the ring 10 < |k| < 20 (unit circumradius) against the
        // spike model's share of the light there, lambda N scaled out: P1 / (2 pi^2 A1)
        // (1/k0 - 1/k1) in frequency units. The off-spike background falls faster (|k|^-4).
        for blades in [5u32, 6] {
            let vertices = polygon(blades);
            let star = Starburst {
                aperture: AperturePolygon { blades, rotation_rad: 0.0, curvature: 0.0 },
                working_f_number: 1.0,
            };
            let area = polygon_transform(&vertices, [0.0, 0.0]).0;
            let (k0, k1) = (10.0, 20.0);
            let (angles, radii) = (8192, 400);
            let mut ring = 0.0;
            for j in 0..radii {
                let k = k0 + (j as f64 + 0.5) * (k1 - k0) / radii as f64;
                for i in 0..angles {
                    let a = 2.0 * PI * (i as f64 + 0.5) / angles as f64;
                    let (re, im) = polygon_transform(&vertices, [k * a.cos(), k * a.sin()]);
                    ring += (re * re + im * im) * k;
                }
            }
            ring *= (k1 - k0) / radii as f64 * 2.0 * PI / angles as f64 / area;
            // The spike model at lambda N = 1 in frequency units: a film radius r is a
            // frequency r / (lambda z) = r / (2 lambda N): scale lambda so that lambda N = 1/2.
            let model = star.spike_fraction(1e6 * 0.5, k0, k1);
            assert!((ring / model - 1.0).abs() < 0.05, "{blades} blades: ring {ring}, spikes {model}");
        }
    }

    #[test]
    fn a_circles_glow_is_the_airy_patterns_tail() {
        // 1 - EE(v) = J0(v)^2 + J1(v)^2 (Rayleigh) -> 2 / (pi v) with v = pi r / (lambda N).
        let star = Starburst { aperture: AperturePolygon::CIRCLE, working_f_number: 2.8 };
        let lambda_nm = 550.0;
        for v in [60.0, 200.0] {
            let r_mm = v * lambda_nm * 1e-6 * 2.8 / PI;
            let tail =
                crate::optics::diffraction::bessel_j(0, v).powi(2) + crate::optics::diffraction::bessel_j(1, v).powi(2);
            let model = star.glow_fraction(lambda_nm, r_mm, f64::INFINITY);
            assert!((model / tail - 1.0).abs() < 0.02, "v {v}: model {model}, Airy {tail}");
        }
        // Straight blades move it all into the spikes; half-curved ones split it.
        let hexagon = AperturePolygon { blades: 6, rotation_rad: 0.0, curvature: 0.0 };
        let spiky = Starburst { aperture: hexagon, working_f_number: 2.8 };
        assert_eq!(spiky.glow_coefficient(550.0), 0.0);
        let half = Starburst { aperture: AperturePolygon { curvature: 0.5, ..hexagon }, working_f_number: 2.8 };
        assert!((half.glow_coefficient(550.0) - 0.5 * star.glow_coefficient(550.0)).abs() < 1e-18);
    }

    #[test]
    fn the_halo_holds_its_share_of_the_light() {
        let halo = Halo { fraction: 0.01, radius_mm: 0.2 };
        assert!((halo.fraction_between(0.0, f64::INFINITY) - 0.01).abs() < 1e-15);
        // The density integrates to the share between two radii (midpoint rule).
        let (r0, r1, steps) = (0.05, 3.0, 20000);
        let h = (r1 - r0) / steps as f64;
        let sum: f64 = (0..steps).map(|i| r0 + (i as f64 + 0.5) * h).map(|r| halo.density(r) * 2.0 * PI * r * h).sum();
        assert!((sum / halo.fraction_between(r0, r1) - 1.0).abs() < 1e-6);
        let r = halo.radius_below(1e-3);
        assert!((halo.density(r) / 1e-3 - 1.0).abs() < 1e-9, "{r}");
        assert_eq!(halo.radius_below(1e9), 0.0);
    }
}
