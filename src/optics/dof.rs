//! Depth of field: the near and far limits of acceptable sharpness
//! (Potmesil & Chakravarty 1981 sec 2.2, eqs 2-6 and Table 1), and a printable report.

use super::lens::{OpticsError, ThinLens};
use super::sensor::Sensor;
use std::fmt::{self, Write};

/// What counts as "acceptably sharp".
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CocCriterion {
    /// Angular: a patch of diameter (distance / ratio) at the focus plane still reads as a
    /// point. Potmesil & Chakravarty use 1000 (the eye resolves about 1 mrad).
    AngularRatio(f64),
    /// A fixed circle-of-confusion diameter on the film in mm, e.g. 0.03 for 135 film.
    ImageMm(f64),
}

impl CocCriterion {
    /// The criterion of Potmesil & Chakravarty 1981: patch = distance / 1000.
    pub const POTMESIL_1981: CocCriterion = CocCriterion::AngularRatio(1000.0);

    /// Parses `1/1000` (angular ratio) or `0.03mm` (film CoC in mm).
    pub fn parse(text: &str) -> Result<CocCriterion, OpticsError> {
        let key = text.trim().to_ascii_lowercase();
        let number = |s: &str| s.trim().parse::<f64>().ok();
        let criterion = if let Some(ratio) = key.strip_prefix("1/") {
            number(ratio).map(CocCriterion::AngularRatio)
        } else if let Some(mm) = key.strip_suffix("mm") {
            number(mm).map(CocCriterion::ImageMm)
        } else {
            None
        };
        let invalid = |reason| OpticsError::InvalidCocCriterion { text: text.to_string(), reason };
        criterion
            .ok_or_else(|| invalid("expected 1/RATIO (e.g. 1/1000) or a film CoC such as 0.03mm"))?
            .validate()
            .map_err(|_| invalid("the number must be finite and positive"))
    }

    /// Checks that the ratio or diameter is finite and positive.
    pub fn validate(self) -> Result<CocCriterion, OpticsError> {
        let (CocCriterion::AngularRatio(x) | CocCriterion::ImageMm(x)) = self;
        if x.is_finite() && x > 0.0 {
            Ok(self)
        } else {
            Err(OpticsError::InvalidCocCriterion {
                text: format!("{self}"),
                reason: "the number must be finite and positive",
            })
        }
    }
}

impl fmt::Display for CocCriterion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CocCriterion::AngularRatio(k) => write!(f, "patch of distance/{k} at the focus plane"),
            CocCriterion::ImageMm(c) => write!(f, "{c} mm circle of confusion on the film"),
        }
    }
}

/// Limits of acceptable sharpness around the focus distance, all in mm from the lens.
#[derive(Clone, Copy, Debug)]
pub struct DofLimits {
    pub near_mm: f64,
    /// `f64::INFINITY` when focused at or beyond the hyperfocal distance.
    pub far_mm: f64,
    /// far - near; infinite when `far_mm` is.
    pub depth_mm: f64,
    /// Focus distance whose far limit is at infinity.
    pub hyperfocal_mm: f64,
}

/// Near and far limits of the depth of field of `lens` under `criterion` (assumed valid, see
/// [`CocCriterion::validate`]).
///
/// `AngularRatio(k)` follows Potmesil & Chakravarty: H = k f/N. In image terms the
/// criterion is a film CoC of v/k (the patch S/k imaged at magnification v/S), and the limits
/// are exactly where eq 5.3 of Kyaw 2013 (P = 1) reaches that size.
///
/// `ImageMm(c)` uses the usual thin-lens forms H = f^2/(N c) + f, near = S (H - f)/(H + S - 2f),
/// far = S (H - f)/(H - S). These solve |C| = c in eq 5.3 with the effective aperture N' exactly
/// (not eq 5.4 with N): 1/u = 1/S -+ c N (S - f)/(S f^2). They ignore the pupil magnification,
/// so for P != 1 they are the symmetric-lens approximation.
pub fn dof_limits(lens: &ThinLens, criterion: CocCriterion) -> DofLimits {
    let (f, s) = (lens.focal_length_mm, lens.focus_distance_mm);
    let (hyperfocal_mm, near_mm, far_mm) = match criterion {
        CocCriterion::AngularRatio(k) => {
            // Potmesil & Chakravarty 1981: H = 1000 F/n (observation 1 after eq 4), then
            // U+ = U H / (H - U) for H > U, else infinity (eq 5), U- = U H / (H + U) (eq 6).
            let h = k * lens.entrance_pupil_diameter_mm();
            let far = if h > s { s * h / (h - s) } else { f64::INFINITY };
            (h, s * h / (h + s), far)
        }
        CocCriterion::ImageMm(c) => {
            // Standard thin-lens forms; equal to |Kyaw 2013 eq 5.3| = c for P = 1 (see above).
            let h = f * f / (lens.f_number * c) + f;
            let near = s * (h - f) / (h + s - 2.0 * f);
            let far = if s < h { s * (h - f) / (h - s) } else { f64::INFINITY };
            (h, near, far)
        }
    };
    DofLimits { near_mm, far_mm, depth_mm: far_mm - near_mm, hyperfocal_mm }
}

/// A human-readable summary of the lens, its field of view on `sensor` and its depth of field.
pub fn dof_report(lens: &ThinLens, sensor: &Sensor, criterion: CocCriterion) -> String {
    fn mm(x: f64) -> String {
        if x.is_infinite() {
            "infinity".to_string()
        } else {
            format!("{x:.2} mm")
        }
    }
    fn row(out: &mut String, label: &str, value: impl fmt::Display) {
        let _ = writeln!(out, "  {label:<30}{value}");
    }
    let dof = dof_limits(lens, criterion);
    let out = &mut String::new();
    let _ = writeln!(out, "Lens");
    row(out, "focal length f", mm(lens.focal_length_mm));
    row(out, "f-number N", format!("f/{}", lens.f_number));
    row(out, "focus distance S", mm(lens.focus_distance_mm));
    row(out, "image distance v", mm(lens.image_distance_mm()));
    row(out, "magnification |m|", format!("{:.5}", lens.magnification()));
    row(out, "effective f-number N'", format!("f/{:.3}", lens.effective_f_number()));
    row(out, "entrance pupil diameter", mm(lens.entrance_pupil_diameter_mm()));
    row(out, "pupil magnification P", lens.pupil_magnification);
    row(out, "transmittance T", lens.transmittance);
    let _ = writeln!(out, "Field of view on {sensor}");
    row(out, "", format!("{:>10}  {:>11}", "focused", "at infinity"));
    for (label, k_mm) in
        [("horizontal", sensor.width_mm), ("vertical", sensor.height_mm), ("diagonal", sensor.diagonal_mm())]
    {
        let (near, far) = (lens.fov_deg(k_mm), lens.fov_at_infinity_deg(k_mm));
        row(out, label, format!("{near:>6.2} deg  {far:>7.2} deg"));
    }
    let _ = writeln!(out, "Depth of field ({criterion})");
    row(out, "hyperfocal distance", mm(dof.hyperfocal_mm));
    row(out, "near limit", mm(dof.near_mm));
    row(out, "far limit", mm(dof.far_mm));
    row(out, "total depth of field", mm(dof.depth_mm));
    row(out, "CoC of an object at infinity", format!("{:.4} mm", lens.coc_mm(f64::INFINITY)));
    std::mem::take(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Potmesil & Chakravarty 1981 Table 1 (seed 002, lines ~716-730): f-number, focus U,
    /// U+, U-, depth of field, all in mm, for a 55 mm lens. The OCR reads "56" for 5.6.
    const TABLE_1: [(f64, f64, f64, f64, f64); 12] = [
        (5.6, 2000.0, 2511.0, 1662.0, 849.0),
        (5.6, 980.0, 1089.0, 891.0, 198.0),
        (5.6, 550.0, 583.0, 521.0, 62.0),
        (5.6, 290.0, 299.0, 282.0, 17.0),
        (11.0, 2000.0, 3333.0, 1429.0, 1904.0),
        (11.0, 980.0, 1219.0, 819.0, 400.0),
        (11.0, 550.0, 618.0, 495.0, 123.0),
        (11.0, 290.0, 308.0, 274.0, 34.0),
        (22.0, 2000.0, 10000.0, 1111.0, 8889.0),
        (22.0, 980.0, 1612.0, 704.0, 908.0),
        (22.0, 550.0, 705.0, 451.0, 254.0),
        (22.0, 290.0, 328.0, 260.0, 68.0),
    ];

    fn rel_eq(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * a.abs().max(b.abs())
    }

    #[test]
    fn reproduces_potmesil_chakravarty_table_1() {
        for (n, focus_mm, far_mm, near_mm, depth_mm) in TABLE_1 {
            let lens = ThinLens::new(55.0, n, focus_mm).unwrap();
            let dof = dof_limits(&lens, CocCriterion::POTMESIL_1981);
            let row = format!("f/{n} at {focus_mm} mm: {dof:?}");
            assert!((dof.far_mm - far_mm).abs() <= 1.0, "U+ {row}");
            assert!((dof.near_mm - near_mm).abs() <= 1.0, "U- {row}");
            assert!((dof.depth_mm - depth_mm).abs() <= 1.0, "depth {row}");
        }
    }

    /// Angular criterion: the limits are where eq 5.3 (P = 1) gives a film CoC of v/k, since
    /// C = (f/N) v |1/S - 1/u| = v/k  <=>  1/u = 1/S -+ 1/H with H = k f/N.
    #[test]
    fn angular_limits_are_where_the_coc_is_v_over_k() {
        for (n, focus_mm, ..) in TABLE_1 {
            let lens = ThinLens::new(55.0, n, focus_mm).unwrap();
            let dof = dof_limits(&lens, CocCriterion::AngularRatio(1000.0));
            let c_mm = lens.image_distance_mm() / 1000.0;
            assert!(rel_eq(-lens.coc_mm(dof.near_mm), c_mm, 1e-9));
            if dof.far_mm.is_finite() {
                assert!(rel_eq(lens.coc_mm(dof.far_mm), c_mm, 1e-9));
            }
        }
    }

    /// Film criterion: with P = 1 the standard forms put |eq 5.3| = c exactly at both limits,
    /// at distant and at close focus, because they use v f / N = v^2 / N' (the effective
    /// aperture). Eq 5.4 (N instead of N') overstates the CoC there by 1 + m.
    #[test]
    fn film_limits_are_where_the_coc_is_c() {
        let c_mm = 0.03;
        for (f, n, focus_mm) in [(50.0, 2.8, 5000.0), (24.0, 1.4, 10_000.0), (35.0, 8.0, 4000.0), (100.0, 4.0, 300.0)] {
            let lens = ThinLens::new(f, n, focus_mm).unwrap();
            let dof = dof_limits(&lens, CocCriterion::ImageMm(c_mm));
            assert!(dof.far_mm.is_finite() && dof.near_mm < focus_mm && dof.far_mm > focus_mm);
            assert!(rel_eq(lens.coc_mm(dof.near_mm), -c_mm, 1e-9), "near, f {f} S {focus_mm}");
            assert!(rel_eq(lens.coc_mm(dof.far_mm), c_mm, 1e-9), "far, f {f} S {focus_mm}");
            let m = lens.magnification();
            assert!(rel_eq(lens.coc_eq54_mm(dof.far_mm), c_mm * (1.0 + m), 1e-9));
        }
    }

    #[test]
    fn hyperfocal_focus_reaches_infinity() {
        for criterion in [CocCriterion::ImageMm(0.03), CocCriterion::AngularRatio(1000.0)] {
            let probe = ThinLens::new(50.0, 8.0, 1000.0).unwrap();
            let h_mm = dof_limits(&probe, criterion).hyperfocal_mm;
            let lens = ThinLens::new(50.0, 8.0, h_mm).unwrap();
            let dof = dof_limits(&lens, criterion);
            assert_eq!(dof.far_mm, f64::INFINITY);
            assert_eq!(dof.depth_mm, f64::INFINITY);
            assert!(rel_eq(dof.near_mm, h_mm / 2.0, 1e-12), "{criterion}");
            // Beyond the hyperfocal distance the far limit stays at infinity.
            let beyond = ThinLens::new(50.0, 8.0, 2.0 * h_mm).unwrap();
            assert_eq!(dof_limits(&beyond, criterion).far_mm, f64::INFINITY);
        }
        // At the film hyperfocal distance an object at infinity blurs to exactly c.
        let lens = ThinLens::new(50.0, 8.0, 50.0 * 50.0 / (8.0 * 0.03) + 50.0).unwrap();
        assert!(rel_eq(lens.coc_mm(f64::INFINITY), 0.03, 1e-12));
    }

    #[test]
    fn stopping_down_and_focusing_farther_deepen_the_field() {
        let depth = |n, s| dof_limits(&ThinLens::new(55.0, n, s).unwrap(), CocCriterion::ImageMm(0.03)).depth_mm;
        assert!(depth(5.6, 980.0) < depth(11.0, 980.0) && depth(11.0, 980.0) < depth(22.0, 980.0));
        assert!(depth(11.0, 290.0) < depth(11.0, 550.0) && depth(11.0, 550.0) < depth(11.0, 980.0));
    }

    #[test]
    fn parses_and_validates_criteria() {
        assert_eq!(CocCriterion::parse("1/1000").unwrap(), CocCriterion::AngularRatio(1000.0));
        assert_eq!(CocCriterion::parse(" 0.03 MM").unwrap(), CocCriterion::ImageMm(0.03));
        for text in ["0.03", "1/0", "-0.03mm", "1/inf", "nanmm", "abc"] {
            let err = CocCriterion::parse(text).unwrap_err().to_string();
            assert!(err.contains(&format!("{text:?}")), "{err}");
        }
        assert!(CocCriterion::ImageMm(f64::NAN).validate().is_err());
        assert!(CocCriterion::AngularRatio(1500.0).validate().is_ok());
    }

    #[test]
    fn report_lists_every_quantity() {
        let lens = ThinLens::new(50.0, 8.0, 20_000.0).unwrap();
        let report = dof_report(&lens, &Sensor::FULL_FRAME, CocCriterion::ImageMm(0.03));
        for needle in [
            "focal length f",
            "50.00 mm",
            "f/8",
            "20000.00 mm",
            "image distance v",
            "magnification |m|",
            "effective f-number N'",
            "entrance pupil diameter",
            "6.25 mm",
            "horizontal",
            "vertical",
            "diagonal",
            "at infinity",
            "0.03 mm circle of confusion",
            "hyperfocal distance",
            "10466.67 mm",
            "near limit",
            "far limit",
            "infinity",
            "total depth of field",
            "CoC of an object at infinity",
        ] {
            assert!(report.contains(needle), "missing {needle:?} in\n{report}");
        }
        let angular = dof_report(&lens, &Sensor::FULL_FRAME, CocCriterion::POTMESIL_1981);
        assert!(angular.contains("distance/1000"), "{angular}");
    }
}
