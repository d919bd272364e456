//! The thin-lens camera: conjugate distances, magnification, pupils, effective aperture,
//! field of view and the circle of confusion (Kyaw 2013 ch. 3-5).

/// Why a camera parameter was rejected. Every message names the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OpticsError {
    #[error("{name} must be a finite number, got {value}")]
    NotFinite { name: &'static str, value: f64 },
    #[error("focal length must be positive, got {} mm", super::Num(*.focal_length_mm))]
    NonPositiveFocalLength { focal_length_mm: f64 },
    #[error("f-number must be positive, got f/{}", super::Num(*.f_number))]
    NonPositiveFNumber { f_number: f64 },
    #[error(
        "focus distance {} mm is not beyond the focal length {} mm; \
         a lens can only focus on objects farther away than its focal length",
        super::Num(*.focus_distance_mm), super::Num(*.focal_length_mm)
    )]
    FocusInsideFocalLength { focus_distance_mm: f64, focal_length_mm: f64 },
    #[error("pupil magnification (exit / entrance pupil diameter) must be positive, got {pupil_magnification}")]
    NonPositivePupilMagnification { pupil_magnification: f64 },
    #[error("lens transmittance must be in (0, 1], got {transmittance}")]
    TransmittanceOutOfRange { transmittance: f64 },
    #[error("unknown sensor format {text:?}; give WIDTHxHEIGHT in mm (e.g. 36x24 or 36x20.25mm) or one of: {known}")]
    UnknownSensor { text: String, known: String },
    #[error("sensor size must be positive and finite, got {width_mm} x {height_mm} mm")]
    InvalidSensorSize { width_mm: f64, height_mm: f64 },
    #[error("invalid circle-of-confusion criterion {text:?}: {reason}")]
    InvalidCocCriterion { text: String, reason: &'static str },
    #[error("invalid film curve: {name} = {value} ({requirement})")]
    InvalidFilmCurve { name: &'static str, value: f64, requirement: &'static str },
    #[error("chromaticities (red, green, blue, white xy) {chromaticities:?} are not an RGB space: {why}")]
    InvalidChromaticities { chromaticities: [[f64; 2]; 4], why: String },
}

/// How the circle of confusion follows depth (see [`ThinLens::coc_renderer_mm`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CocModel {
    /// Kyaw 2013 eq 5.3: the film at the image distance v, the exit pupil v/(N' P).
    #[default]
    Physical,
    /// The renderers' thin lens: aperture f/N at the pinhole, image scale f.
    Renderer,
}

pub(crate) fn require_finite(name: &'static str, value: f64) -> Result<f64, OpticsError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(OpticsError::NotFinite { name, value })
    }
}

/// A thin lens focused at a finite distance, with pupil magnification and transmittance.
///
/// Construct with [`ThinLens::new`] (which validates); the fields are public for reading.
/// A lens built by hand with invalid fields gives meaningless (but non-panicking) results.
#[derive(Clone, Copy, Debug)]
pub struct ThinLens {
    /// Effective focal length f.
    pub focal_length_mm: f64,
    /// Relative aperture N = f / e at infinity focus (eq 4.3).
    pub f_number: f64,
    /// Planar distance S from the lens to the plane in focus.
    pub focus_distance_mm: f64,
    /// P = exit pupil diameter / entrance pupil diameter (eq 4.2); 1 for a symmetric lens.
    pub pupil_magnification: f64,
    /// Fraction T of the light the glass transmits (eq 4.6).
    pub transmittance: f64,
}

impl ThinLens {
    /// A symmetric (P = 1), lossless (T = 1) lens. Rejects non-finite values, f <= 0, N <= 0
    /// and focus distances not beyond the focal length (S <= f has no real image).
    pub fn new(focal_length_mm: f64, f_number: f64, focus_distance_mm: f64) -> Result<Self, OpticsError> {
        require_finite("focal length (mm)", focal_length_mm)?;
        require_finite("f-number", f_number)?;
        require_finite("focus distance (mm)", focus_distance_mm)?;
        if focal_length_mm <= 0.0 {
            return Err(OpticsError::NonPositiveFocalLength { focal_length_mm });
        }
        if f_number <= 0.0 {
            return Err(OpticsError::NonPositiveFNumber { f_number });
        }
        if focus_distance_mm <= focal_length_mm {
            return Err(OpticsError::FocusInsideFocalLength { focus_distance_mm, focal_length_mm });
        }
        Ok(Self { focal_length_mm, f_number, focus_distance_mm, pupil_magnification: 1.0, transmittance: 1.0 })
    }

    /// Sets P = exit / entrance pupil diameter (eq 4.2); must be finite and positive.
    pub fn with_pupil_magnification(self, p: f64) -> Result<Self, OpticsError> {
        require_finite("pupil magnification", p)?;
        if p <= 0.0 {
            return Err(OpticsError::NonPositivePupilMagnification { pupil_magnification: p });
        }
        Ok(Self { pupil_magnification: p, ..self })
    }

    /// Sets the transmittance T; must satisfy 0 < T <= 1.
    pub fn with_transmittance(self, t: f64) -> Result<Self, OpticsError> {
        require_finite("transmittance", t)?;
        if t <= 0.0 || t > 1.0 {
            return Err(OpticsError::TransmittanceOutOfRange { transmittance: t });
        }
        Ok(Self { transmittance: t, ..self })
    }

    /// Image distance v at which the focus plane S is sharp.
    pub fn image_distance_mm(&self) -> f64 {
        Self::image_distance_for_object_mm(self.focus_distance_mm, self.focal_length_mm)
    }

    /// Image conjugate v of an object at distance u: v = u f / (u - f).
    /// Infinite for u = f, negative (a virtual image) for u < f.
    pub fn image_distance_for_object_mm(object_distance_mm: f64, focal_length_mm: f64) -> f64 {
        let (u, f) = (object_distance_mm, focal_length_mm);
        u * f / (u - f) // Kyaw 2013 eq 3.6
    }

    /// Object conjugate u of an image at distance v: u = v f / (v - f).
    pub fn object_distance_for_image_mm(image_distance_mm: f64, focal_length_mm: f64) -> f64 {
        let (v, f) = (image_distance_mm, focal_length_mm);
        v * f / (v - f) // Kyaw 2013 eq 3.5
    }

    /// |m| = v / S, the (positive) magnification of the focus plane onto the film.
    pub fn magnification(&self) -> f64 {
        self.image_distance_mm() / self.focus_distance_mm // Kyaw 2013 eq 3.2 (sign dropped)
    }

    /// Entrance pupil diameter e = f / N.
    pub fn entrance_pupil_diameter_mm(&self) -> f64 {
        self.focal_length_mm / self.f_number // Kyaw 2013 eq 4.3
    }

    /// Effective aperture N' = N (1 + m/P). For P = 1 this is exactly v / e (eq 4.5), since
    /// v = f (1 + m) (eq 3.4); the m/P form is the one eq 4.9 uses for asymmetric lenses.
    pub fn effective_f_number(&self) -> f64 {
        // Kyaw 2013 eq 4.5, with N(1 + m/P) for N' as in eq 4.9
        self.f_number * (1.0 + self.magnification() / self.pupil_magnification)
    }

    /// Angle of view across a sensor dimension (width, height or diagonal), in degrees, at the
    /// current focus: the image distance v replaces f, so the view narrows as focus comes
    /// closer ("focus breathing").
    pub fn fov_deg(&self, sensor_dimension_mm: f64) -> f64 {
        // Kyaw 2013 eq 3.8 with f replaced by v (sec 3.1.3)
        2.0 * (sensor_dimension_mm / (2.0 * self.image_distance_mm())).atan().to_degrees()
    }

    /// Angle of view across a sensor dimension, in degrees, when focused at infinity.
    pub fn fov_at_infinity_deg(&self, sensor_dimension_mm: f64) -> f64 {
        2.0 * (sensor_dimension_mm / (2.0 * self.focal_length_mm)).atan().to_degrees()
        // Kyaw 2013 eq 3.8
    }

    /// Signed circle-of-confusion diameter on the film, in mm, of an object at planar
    /// distance u (Kyaw 2013 eq 5.3): positive behind the focus plane (background), negative in
    /// front (foreground), exactly 0 at u = S.
    ///
    /// Written as (v^2 / (N' P)) (1/S - 1/u), which equals eq 5.3 since |S - u| / (u S) =
    /// |1/u - 1/S|. This stays finite for u = +inf (the limit v^2 / (S N' P)) and for u < f;
    /// u = 0 gives -inf (callers clamp). u must be positive for a real object.
    pub fn coc_mm(&self, object_distance_mm: f64) -> f64 {
        let v = self.image_distance_mm();
        let scale_mm2 = v * v / (self.effective_f_number() * self.pupil_magnification);
        scale_mm2 * (1.0 / self.focus_distance_mm - 1.0 / object_distance_mm) // Kyaw 2013 eq 5.3
    }

    /// Signed circle of confusion in mm of the renderers' thin lens: Cycles, Arnold and
    /// RenderMan put a thin lens of aperture diameter A = f/N at the pinhole and keep the
    /// pinhole's image scale, the focal length f (no focus breathing). A point at distance u seen
    /// through a lens focused at S then blurs into C = A f |u - S| / (u S) on the film, written
    /// f^2/N (1/S - 1/u) with the sign of eq 5.3. Eq 5.3 (physical: the film at v, exit pupil
    /// v/(N' P)) is (v/f)^2 (N/(N' P)) times larger: about 5% in diameter at S = 40 f.
    pub fn coc_renderer_mm(&self, object_distance_mm: f64) -> f64 {
        let f = self.focal_length_mm;
        f * f / self.f_number * (1.0 / self.focus_distance_mm - 1.0 / object_distance_mm)
    }

    /// Unsigned circle of confusion by the simplified eq 5.4 (N for N', P = 1), in mm. It is
    /// (1 + m) times larger than eq 5.3, so it is only a good approximation for distant focus.
    pub fn coc_eq54_mm(&self, object_distance_mm: f64) -> f64 {
        let v = self.image_distance_mm();
        let inv_distance_per_mm = 1.0 / self.focus_distance_mm - 1.0 / object_distance_mm;
        v * v / self.f_number * inv_distance_per_mm.abs() // Kyaw 2013 eq 5.4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel_eq(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * a.abs().max(b.abs())
    }

    #[test]
    fn the_renderers_coc_is_the_pinhole_thin_lens_and_eq_5_3_is_larger_by_v_over_f() {
        // Scene A's camera: 50 mm at f/2 focused at 2 m. A point at 8 m: the renderers' disc is
        // A f |u - S| / (u S) with A = f/N = 25 mm: 25 * 50 * 6000 / (8000 * 2000) = 0.46875 mm.
        let lens = ThinLens::new(50.0, 2.0, 2000.0).unwrap();
        let renderer = lens.coc_renderer_mm(8000.0);
        assert!(rel_eq(renderer, 0.46875, 1e-12), "{renderer}");
        // In front of the focus plane it is negative, exactly 0 at the focus distance.
        assert!(rel_eq(lens.coc_renderer_mm(1000.0), -25.0 * 50.0 * 1000.0 / (1000.0 * 2000.0), 1e-12));
        assert_eq!(lens.coc_renderer_mm(2000.0), 0.0);
        // Eq 5.3 puts the film at v = 1/(1/50 - 1/2000) = 51.282 mm behind an exit pupil of
        // v / N' with the working f-number N' = N v / f (P = 1): v^2 / N' = v f / N, so the
        // physical disc is v / f = 2.6% larger in diameter, 5.2% in area.
        let v = 1.0 / (1.0 / 50.0 - 1.0 / 2000.0);
        let physical = lens.coc_mm(8000.0);
        assert!(rel_eq(physical / renderer, v / 50.0, 1e-12), "{physical} / {renderer}");
        assert!((physical / renderer - 1.02564).abs() < 1e-5);
    }

    #[test]
    fn new_rejects_bad_values_with_the_value_in_the_message() {
        let cases = [
            (f64::NAN, 2.8, 1000.0, "focal length (mm) must be a finite number, got NaN"),
            (50.0, f64::INFINITY, 1000.0, "f-number must be a finite number, got inf"),
            (50.0, 2.8, f64::INFINITY, "focus distance (mm) must be a finite number, got inf"),
            (-50.0, 2.8, 1000.0, "focal length must be positive, got -50 mm"),
            (50.0, 0.0, 1000.0, "f-number must be positive, got f/0"),
            (50.0, 2.8, 50.0, "focus distance 50 mm is not beyond the focal length 50 mm"),
            (50.0, 2.8, 20.0, "focus distance 20 mm is not beyond"),
            (50.0, 2.8, -100.0, "focus distance -100 mm is not beyond"),
        ];
        for (f, n, s, message) in cases {
            let err = ThinLens::new(f, n, s).unwrap_err().to_string();
            assert!(err.contains(message), "{err:?} should contain {message:?}");
        }
        let lens = ThinLens::new(50.0, 2.8, 1000.0).unwrap();
        assert!(lens.with_pupil_magnification(0.0).is_err());
        assert!(lens.with_pupil_magnification(f64::NAN).is_err());
        assert_eq!(lens.with_pupil_magnification(0.5).unwrap().pupil_magnification, 0.5);
        for t in [0.0, -0.1, 1.01, f64::NAN] {
            assert!(lens.with_transmittance(t).is_err(), "T = {t}");
        }
        assert_eq!(lens.with_transmittance(1.0).unwrap().transmittance, 1.0);
        let err = lens.with_transmittance(1.5).unwrap_err().to_string();
        assert!(err.contains("(0, 1], got 1.5"), "{err}");
    }

    #[test]
    fn conjugate_distances_satisfy_the_lens_equation() {
        for (f, s) in [(50.0, 1000.0), (55.0, 290.0), (24.0, 48.0), (200.0, 1e7)] {
            let lens = ThinLens::new(f, 4.0, s).unwrap();
            let v = lens.image_distance_mm();
            assert!(rel_eq(1.0 / s + 1.0 / v, 1.0 / f, 1e-14)); // eq 3.1
                                                                // eq 3.5; the round trip is ill-conditioned (v - f cancels) at distant focus
            assert!(rel_eq(ThinLens::object_distance_for_image_mm(v, f), s, 1e-9));
            let m = lens.magnification();
            assert!(rel_eq(v, f * (1.0 + m), 1e-14)); // eq 3.4
            assert!(rel_eq(s, f * (1.0 + 1.0 / m), 1e-12)); // eq 3.3
        }
        // Unit magnification at S = 2f: v = 2f.
        let lens = ThinLens::new(50.0, 4.0, 100.0).unwrap();
        assert_eq!(lens.image_distance_mm(), 100.0);
        assert_eq!(lens.magnification(), 1.0);
    }

    #[test]
    fn pupils_and_effective_aperture() {
        // Potmesil & Chakravarty 1981 Table 1 footnote: 55 mm lens diameter 9.82 / 5.00 / 2.50 mm.
        for (n, d_mm) in [(5.6, 9.82), (11.0, 5.00), (22.0, 2.50)] {
            let lens = ThinLens::new(55.0, n, 2000.0).unwrap();
            assert!((lens.entrance_pupil_diameter_mm() - d_mm).abs() < 0.005);
        }
        // eq 4.5: N' = v / e, and with P = 1 that is N (1 + m).
        let lens = ThinLens::new(50.0, 2.8, 400.0).unwrap();
        let n_eff = lens.image_distance_mm() / lens.entrance_pupil_diameter_mm();
        assert!(rel_eq(lens.effective_f_number(), n_eff, 1e-14));
        // With P: N (1 + m/P); a retrofocus-like P = 2 loses less light at close focus.
        let retro = lens.with_pupil_magnification(2.0).unwrap();
        let m = lens.magnification();
        assert!(rel_eq(retro.effective_f_number(), 2.8 * (1.0 + m / 2.0), 1e-14));
        // Distant focus: N' -> N.
        let far = ThinLens::new(50.0, 2.8, 1e9).unwrap();
        assert!(rel_eq(far.effective_f_number(), 2.8, 1e-7));
    }

    #[test]
    fn field_of_view_and_breathing() {
        let diagonal_mm = 36f64.hypot(24.0);
        let lens = ThinLens::new(50.0, 2.0, 1e12).unwrap();
        assert!((lens.fov_at_infinity_deg(diagonal_mm) - 46.793).abs() < 1e-3); // 50 mm on 135 film
        assert!((lens.fov_deg(diagonal_mm) - lens.fov_at_infinity_deg(diagonal_mm)).abs() < 1e-8);
        // At unit magnification v = 2f: the view narrows to 2 atan(K / 4f).
        let macro_lens = ThinLens::new(50.0, 2.0, 100.0).unwrap();
        let expected = 2.0 * (36.0f64 / 200.0).atan().to_degrees();
        assert!(rel_eq(macro_lens.fov_deg(36.0), expected, 1e-14));
        assert!(macro_lens.fov_deg(36.0) < macro_lens.fov_at_infinity_deg(36.0));
    }

    /// Eq 5.3 against the direct construction on the image side (P = 1): the cone from the
    /// aperture D = f/N converges at v_u and is cut by the film at v, so C = D |v_u - v| / v_u
    /// (also Potmesil & Chakravarty 1981 eq 8). Substituting 1/v_u = 1/f - 1/u and
    /// 1/v = 1/f - 1/S gives C = D v |1/S - 1/u|, and D v = (f/N) v = v^2 / N' because
    /// N' = N (1 + m) = N v / f. Hence the two agree for every u, including u < f, where v_u is
    /// negative (a virtual image) and the cone diverges.
    #[test]
    fn coc_eq53_equals_the_geometric_construction() {
        for (f, n, s) in [(50.0, 2.8, 2000.0), (55.0, 5.6, 290.0), (100.0, 8.0, 150.0)] {
            let lens = ThinLens::new(f, n, s).unwrap();
            let v = lens.image_distance_mm();
            let d = f / n;
            for u in [0.3 * f, 0.9 * f, 1.01 * f, 0.5 * s, 0.99 * s, 1.01 * s, 3.0 * s, 1e6] {
                let v_u = ThinLens::image_distance_for_object_mm(u, f);
                let geometric = d * (v_u - v).abs() / v_u.abs();
                let coc = lens.coc_mm(u);
                assert!(rel_eq(coc.abs(), geometric, 1e-9), "f {f} S {s} u {u}");
                assert_eq!(coc > 0.0, u > s, "sign: background positive");
                // The literal (less stable) form of eq 5.3 for ordinary distances.
                let literal = v * v * (s - u).abs() / (u * s * lens.effective_f_number());
                assert!(rel_eq(coc.abs(), literal, 1e-9));
            }
        }
    }

    #[test]
    fn coc_special_distances() {
        let lens = ThinLens::new(50.0, 2.0, 3000.0).unwrap().with_pupil_magnification(0.7).unwrap();
        let v = lens.image_distance_mm();
        assert_eq!(lens.coc_mm(3000.0), 0.0);
        let at_infinity = v * v / (3000.0 * lens.effective_f_number() * 0.7);
        assert!(rel_eq(lens.coc_mm(f64::INFINITY), at_infinity, 1e-15));
        assert_eq!(lens.coc_mm(0.0), f64::NEG_INFINITY);
        assert!(lens.coc_mm(20.0).is_finite() && lens.coc_mm(20.0) < 0.0);
        assert!(lens.coc_mm(50.0).is_finite());
        // Monotonic in u: the blur grows continuously from foreground to background.
        let mut previous = f64::NEG_INFINITY;
        for i in 1..2000 {
            let coc = lens.coc_mm(i as f64 * 7.3);
            assert!(coc > previous);
            previous = coc;
        }
    }

    #[test]
    fn eq54_is_eq53_without_the_close_focus_factor() {
        // Eq 5.4 replaces N' by N: larger by N'/N = 1 + m (P = 1). Equal in the distant limit.
        let close = ThinLens::new(50.0, 4.0, 150.0).unwrap();
        let m = close.magnification();
        for u in [60.0, 100.0, 400.0, f64::INFINITY] {
            assert!(rel_eq(close.coc_eq54_mm(u), close.coc_mm(u).abs() * (1.0 + m), 1e-14));
        }
        let distant = ThinLens::new(50.0, 4.0, 1e8).unwrap();
        assert!(rel_eq(distant.coc_eq54_mm(5000.0), distant.coc_mm(5000.0).abs(), 1e-6));
        assert_eq!(distant.coc_eq54_mm(1e8), 0.0);
    }
}
