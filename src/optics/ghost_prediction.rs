//! Walch 2017 ch. 8-9: placing measured ghosts for a camera and a light, and predicting how
//! much the flare matters. Plain f64.
//!
//! - eq 8.1: the constellation angle between the camera's forward axis and the light;
//! - eq 8.2: the roll of the light about the axis (the flare turns with it);
//! - eq 8.3: the brightness scale between the flare as measured (F) and the scene (R);
//! - ch. 9: the occurrence estimators of a flare image (min, max, sum, average, log-average)
//!   and the contrast the flare leaves (eqs 9.1-9.3).

/// `v` / |v|.
fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if n > 0.0 {
        v.map(|x| x / n)
    } else {
        v
    }
}

/// Eq 8.1: constellation = arccos(|C_forward| . |L_pos - C_pos|), in degrees (0: the light
/// straight ahead).
pub fn constellation_angle_deg(camera_forward: [f64; 3], camera_pos: [f64; 3], light_pos: [f64; 3]) -> f64 {
    let f = unit(camera_forward);
    let l = unit([light_pos[0] - camera_pos[0], light_pos[1] - camera_pos[1], light_pos[2] - camera_pos[2]]);
    (f[0] * l[0] + f[1] * l[1] + f[2] * l[2]).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Eq 8.2: roll = atan2(L_vs,y, L_vs,x), the light's position in view space (x right, y up),
/// radians counter-clockwise.
pub fn roll_rad(light_view: [f64; 3]) -> f64 {
    light_view[1].atan2(light_view[0])
}

/// A camera's exposure as eq 8.3 sees it, and the light it looks at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExposureSetting {
    pub f_number: f64,
    pub iso: f64,
    pub exposure_time_s: f64,
    /// The light's luminance (cd/m^2) and the solid angle it fills (sr).
    pub luminance_cd_m2: f64,
    pub solid_angle_sr: f64,
}

/// Eq 8.3: B_scale = f_F^2 / f_R^2 * ISO_R / ISO_F * EXP_R / EXP_F * (l_R a_R) / (l_F a_F), the
/// factor from the flare as measured (`measured`, F) to the scene's camera and light
/// (`scene`, R). None when a factor is not positive and finite.
pub fn brightness_scale(measured: &ExposureSetting, scene: &ExposureSetting) -> Option<f64> {
    let (f, r) = (measured, scene);
    let b = (f.f_number * f.f_number) / (r.f_number * r.f_number)
        * (r.iso / f.iso)
        * (r.exposure_time_s / f.exposure_time_s)
        * (r.luminance_cd_m2 * r.solid_angle_sr)
        / (f.luminance_cd_m2 * f.solid_angle_sr);
    (b.is_finite() && b > 0.0).then_some(b)
}

/// Ch. 9.1's statistics of a flare image's intensities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimators {
    pub min: f64,
    pub max: f64,
    pub sum: f64,
    pub average: f64,
    /// exp(mean(ln(delta + I))): the key of a tone mapper (Reinhard et al. 2002), stable
    /// against a few bright outliers.
    pub log_average: f64,
}

/// The estimators of `intensities` (non-finite values skipped); `delta` keeps ln away from 0.
pub fn estimators(intensities: &[f64], delta: f64) -> Option<Estimators> {
    let v: Vec<f64> = intensities.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let sum: f64 = v.iter().sum();
    let n = v.len() as f64;
    let log_mean = v.iter().map(|x| (delta + x.max(0.0)).ln()).sum::<f64>() / n;
    Some(Estimators { min, max, sum, average: sum / n, log_average: log_mean.exp() })
}

/// Eq 9.1: K_ideal = (I_max - I_min) / (I_max + I_min).
pub fn ideal_contrast(i_max: f64, i_min: f64) -> f64 {
    (i_max - i_min) / (i_max + i_min)
}

/// Eq 9.2: K_real = (I_max - I_min) / (I_max + I_min + 2 I_flare): the flare adds to both.
pub fn real_contrast(i_max: f64, i_min: f64, i_flare: f64) -> f64 {
    (i_max - i_min) / (i_max + i_min + 2.0 * i_flare)
}

/// Eq 9.3: K_real / K_ideal = (I_max + I_min) / (I_max + I_min + 2 I_flare), exactly (the
/// thesis's approximation 1 - 2 I_flare / (I_max + I_min) holds for a faint flare).
pub fn contrast_ratio(i_max: f64, i_min: f64, i_flare: f64) -> f64 {
    (i_max + i_min) / (i_max + i_min + 2.0 * i_flare)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq_8_1_and_8_2_angles_against_hand_values() {
        // A light 1 m right and 1 m ahead of a camera looking down -z: 45 degrees.
        assert!((constellation_angle_deg([0.0, 0.0, -2.0], [0.0; 3], [1.0, 0.0, -1.0]) - 45.0).abs() < 1e-12);
        // Straight ahead from elsewhere: 0; behind: 180.
        assert!(constellation_angle_deg([0.0, 0.0, -1.0], [3.0, 1.0, 0.0], [3.0, 1.0, -9.0]).abs() < 1e-6);
        assert!((constellation_angle_deg([0.0, 0.0, -1.0], [0.0; 3], [0.0, 0.0, 5.0]) - 180.0).abs() < 1e-12);
        // atan2(1, sqrt 3) = 30 degrees; straight up: 90; left: 180.
        assert!((roll_rad([3f64.sqrt(), 1.0, -4.0]).to_degrees() - 30.0).abs() < 1e-12);
        assert!((roll_rad([0.0, 2.0, -5.0]).to_degrees() - 90.0).abs() < 1e-12);
        assert!((roll_rad([-1.0, 0.0, -5.0]).to_degrees() - 180.0).abs() < 1e-12);
    }

    #[test]
    fn eq_8_3_brightness_scale_against_hand_values() {
        let measured = ExposureSetting {
            f_number: 2.8,
            iso: 100.0,
            exposure_time_s: 1.0 / 60.0,
            luminance_cd_m2: 1.0e5,
            solid_angle_sr: 1.0e-4,
        };
        // Two stops down (f/5.6: a quarter), ISO 400 (x4), 1/30 s (x2): 2.
        let scene = ExposureSetting { f_number: 5.6, iso: 400.0, exposure_time_s: 1.0 / 30.0, ..measured };
        assert!((brightness_scale(&measured, &scene).unwrap() - 2.0).abs() < 1e-12);
        // f/2 against f/2.8: (2.8 / 2)^2 = 1.96; a light 3x as bright filling half the angle: 1.5.
        let wide = ExposureSetting { f_number: 2.0, ..measured };
        assert!((brightness_scale(&measured, &wide).unwrap() - 1.96).abs() < 1e-12);
        let light = ExposureSetting { luminance_cd_m2: 3.0e5, solid_angle_sr: 0.5e-4, ..measured };
        assert!((brightness_scale(&measured, &light).unwrap() - 1.5).abs() < 1e-12);
        // The same setting: 1; a zero exposure time or NaN: none.
        assert_eq!(brightness_scale(&measured, &measured), Some(1.0));
        assert_eq!(brightness_scale(&measured, &ExposureSetting { exposure_time_s: 0.0, ..measured }), None);
        assert_eq!(brightness_scale(&ExposureSetting { iso: f64::NAN, ..measured }, &measured), None);
    }

    #[test]
    fn eq_9_3_contrast_ratio_and_the_estimators_against_hand_values() {
        // I_max 1000, I_min 10, flare 5: K_ideal = 990/1010, K_real = 990/1020, their ratio
        // 1010/1020 = 0.9901961; the thesis's approximation 1 - 10/1010 = 0.9900990.
        assert!((ideal_contrast(1000.0, 10.0) - 990.0 / 1010.0).abs() < 1e-15);
        assert!((real_contrast(1000.0, 10.0, 5.0) - 990.0 / 1020.0).abs() < 1e-15);
        let ratio = contrast_ratio(1000.0, 10.0, 5.0);
        assert!((ratio - 0.990_196_078_431_372_5).abs() < 1e-15);
        assert!((ratio - real_contrast(1000.0, 10.0, 5.0) / ideal_contrast(1000.0, 10.0)).abs() < 1e-15);
        assert!((ratio - (1.0 - 10.0 / 1010.0)).abs() < 1e-4);
        // No flare: 1; a flare as bright as the scene's mean: 1/2.
        assert_eq!(contrast_ratio(1000.0, 10.0, 0.0), 1.0);
        assert_eq!(contrast_ratio(1000.0, 10.0, 505.0), 0.5);
        // Estimators of 1, 4, 16, 64 (and a NaN skipped): log-average 8 with delta 0.
        let e = estimators(&[1.0, 4.0, f64::NAN, 16.0, 64.0], 0.0).unwrap();
        assert_eq!((e.min, e.max, e.sum, e.average), (1.0, 64.0, 85.0, 21.25));
        assert!((e.log_average - 8.0).abs() < 1e-12);
        assert_eq!(estimators(&[f64::NAN], 1e-6), None);
    }
}
