//! Exposure photometry: image illuminance, shutter, ISO speed and natural vignetting
//! (Kyaw 2013 ch. 4).
//!
//! The chain from a rendered (linear, scene-referred) value to a sensor value is
//! scene value -> luminance L (nits) -> image-plane illuminance E (lux) -> exposure H (lux s)
//! -> H / H_sat, where 1.0 is sensor saturation at the chosen ISO speed.

use super::lens::ThinLens;
use std::f64::consts::PI;

/// Image-plane illuminance per unit scene luminance, E/L in lux per nit:
/// V pi T cos^4(theta) / (4 N^2 (1 + m/P)^2), for a principal ray at field angle theta and an
/// extra (optical/mechanical) vignetting factor V in [0, 1].
///
/// Note that eq 4.6 of the same source, E = T L / (4 N^2), lacks the factor pi of eq 4.9;
/// with L in cd/m^2 and E in lux the pi belongs there, so eq 4.9 is used throughout.
pub fn illuminance_per_luminance(lens: &ThinLens, field_angle_rad: f64, vignetting_factor: f64) -> f64 {
    let cos2 = field_angle_rad.cos().powi(2);
    let close_focus = 1.0 + lens.magnification() / lens.pupil_magnification;
    // Kyaw 2013 eq 4.9
    vignetting_factor * PI * lens.transmittance * cos2 * cos2 / (4.0 * (lens.f_number * close_focus).powi(2))
}

/// Exposure H = E t in lux seconds.
pub fn exposure_lux_s(illuminance_lux: f64, shutter_s: f64) -> f64 {
    illuminance_lux * shutter_s // Kyaw 2013 eq 4.1
}

/// The exposure that just saturates a sensor of saturation-based ISO speed S:
/// H_sat = 78 / S lux s (ISO 12232). The standard's mid-grey exposure 10 / S therefore sits
/// at 10/78 = 12.8% of saturation: 18% grey with about half a stop of headroom above a 100%
/// white (0.18 / sqrt 2 = 12.7%).
pub fn saturation_exposure_lux_s(iso: f64) -> f64 {
    78.0 / iso
}

/// Linear gain from scene value to sensor value (1.0 = saturation) on the optical axis
/// (cos theta = 1, V = 1): `nits_per_unit` converts a scene value to luminance, then eq 4.9,
/// eq 4.1 and the ISO saturation exposure. Doubling N quarters it; doubling t doubles it.
pub fn exposure_gain(lens: &ThinLens, shutter_s: f64, iso: f64, nits_per_unit: f64) -> f64 {
    let illuminance_lux = nits_per_unit * illuminance_per_luminance(lens, 0.0, 1.0);
    exposure_lux_s(illuminance_lux, shutter_s) / saturation_exposure_lux_s(iso)
}

/// Natural vignetting, the cos^4 law: cos^4(theta) with theta = atan(r / v) the field angle of
/// an image point r mm from the optical centre on film at image distance v. Computed without
/// trigonometry as 1 / (1 + (r/v)^2)^2, which is exactly cos^4(atan(r/v)).
pub fn natural_vignetting(image_height_mm: f64, image_distance_mm: f64) -> f64 {
    let tan2 = (image_height_mm / image_distance_mm).powi(2);
    1.0 / (1.0 + tan2).powi(2) // Kyaw 2013 eq 4.14, cos^2 = 1 / (1 + tan^2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lens(n: f64) -> ThinLens {
        ThinLens::new(50.0, n, 1e12).unwrap()
    }

    fn rel_eq(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * a.abs().max(b.abs())
    }

    #[test]
    fn one_stop_halves_the_gain() {
        for n in [1.4, 2.0, 5.6, 16.0] {
            let open = exposure_gain(&lens(n), 0.01, 100.0, 1000.0);
            let stopped = exposure_gain(&lens(n * 2f64.sqrt()), 0.01, 100.0, 1000.0);
            assert!(rel_eq(stopped, open / 2.0, 1e-12), "f/{n}");
        }
    }

    #[test]
    fn illuminance_ratio_is_inverse_square_of_f_number() {
        for (n1, n2) in [(2.0, 2.8), (4.0, 11.0), (1.0, 22.0)] {
            let e1 = illuminance_per_luminance(&lens(n1), 0.0, 1.0);
            let e2 = illuminance_per_luminance(&lens(n2), 0.0, 1.0);
            assert!(rel_eq(e1 / e2, n2 * n2 / (n1 * n1), 1e-12)); // eq 4.8
        }
        // On axis at distant focus eq 4.9 reduces to pi T / (4 N^2).
        let l = lens(2.0).with_transmittance(0.9).unwrap();
        assert!(rel_eq(illuminance_per_luminance(&l, 0.0, 1.0), PI * 0.9 / 16.0, 1e-10));
        assert!(rel_eq(illuminance_per_luminance(&l, 0.0, 0.5), PI * 0.45 / 16.0, 1e-10));
    }

    #[test]
    fn shutter_and_reciprocity() {
        let l = lens(4.0);
        let g = exposure_gain(&l, 1.0 / 125.0, 200.0, 1.0);
        assert!(rel_eq(exposure_gain(&l, 2.0 / 125.0, 200.0, 1.0), 2.0 * g, 1e-15));
        assert!(rel_eq(exposure_gain(&l, 1.0 / 125.0, 400.0, 1.0), 2.0 * g, 1e-15));
        assert_eq!(exposure_lux_s(500.0, 0.02), 10.0);
        assert!(rel_eq(saturation_exposure_lux_s(100.0), 0.78, 1e-15));
        // eq 4.13: t1/t2 = N1^2/N2^2 gives the same exposure.
        for (n1, n2, t2) in [(2.0, 8.0, 1.0 / 500.0), (5.6, 2.8, 0.5)] {
            let t1 = t2 * n1 * n1 / (n2 * n2);
            let h1 = exposure_gain(&lens(n1), t1, 100.0, 1.0);
            let h2 = exposure_gain(&lens(n2), t2, 100.0, 1.0);
            assert!(rel_eq(h1, h2, 1e-12));
        }
    }

    #[test]
    fn close_focus_costs_exposure() {
        // Focus at 2f: m = 1, N' = 2N, so a quarter of the light of infinity focus.
        let near = ThinLens::new(50.0, 4.0, 100.0).unwrap();
        assert_eq!(near.magnification(), 1.0);
        assert_eq!(near.effective_f_number(), 8.0);
        let ratio = exposure_gain(&near, 0.01, 100.0, 1.0) / exposure_gain(&lens(4.0), 0.01, 100.0, 1.0);
        assert!(rel_eq(ratio, 0.25, 1e-9));
        // A pupil magnification P > 1 softens the loss: (1 + m/P)^2.
        let retro = near.with_pupil_magnification(2.0).unwrap();
        let ratio = exposure_gain(&retro, 0.01, 100.0, 1.0) / exposure_gain(&lens(4.0), 0.01, 100.0, 1.0);
        assert!(rel_eq(ratio, 1.0 / 2.25, 1e-9));
    }

    #[test]
    fn cos4_law() {
        assert!(rel_eq(natural_vignetting(50.0, 50.0), 0.25, 1e-15));
        let angle = PI / 4.0;
        assert!(rel_eq(illuminance_per_luminance(&lens(1.0), angle, 1.0), PI / 4.0 * 0.25, 1e-9));
        assert_eq!(natural_vignetting(0.0, 50.0), 1.0);
        for r in [1.0, 10.0, 21.6, 100.0] {
            let theta = (r / 35.0f64).atan();
            assert!(rel_eq(natural_vignetting(r, 35.0), theta.cos().powi(4), 1e-14));
        }
        assert_eq!(natural_vignetting(f64::INFINITY, 50.0), 0.0);
    }
}
