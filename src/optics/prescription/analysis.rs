//! The analysis of a prescription focused at infinity: spherical aberration, field curves,
//! distortion, lateral and longitudinal colour, coma, relative illumination and the cat's eye,
//! and the lens-file tables they imply ([`DerivedTables`]).

use std::fmt;

use super::{Paraxial, Prescription, Ray, RayFailure, LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM};

impl Prescription {
    /// Analyse the lens focused at infinity with its stop set for `f_number` (d line is the
    /// reference; the image plane is the d-line paraxial focus).
    pub fn analyze(&self, f_number: f64, field_angles_deg: &[f64]) -> LensAnalysis {
        let lens = self.with_f_number(f_number);
        let par = lens.paraxial(LAMBDA_D_NM);
        let par_f = lens.paraxial(LAMBDA_F_NM);
        let par_c = lens.paraxial(LAMBDA_C_NM);
        let spherical = lens.lsa_zones(&par);
        let (lsa_a, lsa_b) = lsa_fit(&spherical);
        // Relative illumination reference: the rays passing on axis.
        let on_axis_count = lens.count_passing(&par, 0.0, 0.0).max(1);
        let fields = field_angles_deg.iter().map(|&deg| lens.field_sample(&par, deg, on_axis_count)).collect();

        LensAnalysis {
            name: lens.name.clone(),
            f_number,
            f_number_at_table_stop: self.f_number_at_table_stop(),
            stop_index: lens.stop_index(),
            stop_semi_diameter_mm: lens.surfaces[lens.stop_index()].semi_diameter_mm,
            paraxial: par,
            spherical,
            lsa_h2_coefficient_per_mm: lsa_a,
            lsa_h4_coefficient_per_mm3: lsa_b,
            longitudinal_color: LongitudinalColor {
                focus_f_minus_d_mm: par_f.rear_focal_z_mm - par.rear_focal_z_mm,
                focus_c_minus_d_mm: par_c.rear_focal_z_mm - par.rear_focal_z_mm,
                focus_f_minus_c_mm: par_f.rear_focal_z_mm - par_c.rear_focal_z_mm,
            },
            fields,
        }
    }

    /// Longitudinal spherical aberration at pupil zones (`par`: the d-line paraxial data).
    fn lsa_zones(&self, par: &Paraxial) -> Vec<LsaSample> {
        let (z_img, ep_sd) = (par.rear_focal_z_mm, par.entrance_pupil_semi_diameter_mm);
        let zones = [0.2, 0.4, 0.6, std::f64::consts::FRAC_1_SQRT_2, 0.8, 0.9, 1.0];
        zones
            .iter()
            .map(|&rho| {
                let h = rho * ep_sd;
                LsaSample {
                    zone: rho,
                    height_mm: h,
                    lsa_mm: self.axial_intercept_z_mm(h, LAMBDA_D_NM).map(|z| z - z_img),
                    clipped: self.trace(&Ray::new([0.0, h, -1.0], [0.0, 0.0, 1.0]), LAMBDA_D_NM, true).err(),
                }
            })
            .collect()
    }

    /// How many rays of a grid over a square 1.5x the entrance pupil, at field angle `theta`
    /// and centred at pupil height `yc`, pass the lens.
    fn count_passing(&self, par: &Paraxial, theta: f64, yc: f64) -> usize {
        let (ep_sd, ep_z) = (par.entrance_pupil_semi_diameter_mm, par.entrance_pupil_z_mm);
        let grid = 64usize;
        let w = 1.5 * ep_sd;
        let mut n = 0;
        for i in 0..grid {
            for j in 0..grid {
                let x = -w + (i as f64 + 0.5) * 2.0 * w / grid as f64;
                let y = yc - w + (j as f64 + 0.5) * 2.0 * w / grid as f64;
                if self.trace(&Self::field_ray(theta, x, y, ep_z), LAMBDA_D_NM, true).is_ok() {
                    n += 1;
                }
            }
        }
        n
    }

    /// The analysis at field angle `deg`: image height and distortion, tangential and sagittal
    /// focus, relative illumination (against `on_axis_count` passing rays), lateral colour and
    /// coma.
    fn field_sample(&self, par: &Paraxial, deg: f64, on_axis_count: usize) -> FieldSample {
        let lens = self;
        let z_img = par.rear_focal_z_mm;
        let efl = par.efl_mm;
        let ep_sd = par.entrance_pupil_semi_diameter_mm;
        let ep_z = par.entrance_pupil_z_mm;
        let delta = 1e-3 * ep_sd;
        let theta = deg.to_radians();
        let ideal = efl * theta.tan();
        let mut fs = FieldSample { angle_deg: deg, ideal_height_mm: ideal, ..FieldSample::default() };
        let Some(yc) = lens.chief_ray_pupil_height(theta, LAMBDA_D_NM) else {
            return fs;
        };
        let chief = Self::field_ray(theta, 0.0, yc, ep_z);
        fs.chief_ray_clipped = lens.trace(&chief, LAMBDA_D_NM, true).err();
        if let Ok(r) = lens.trace(&chief, LAMBDA_D_NM, false) {
            let h = r.at_z(z_img).p[1];
            fs.image_height_mm = Some(h);
            fs.distortion_percent = Some(if ideal.abs() < 1e-12 { 0.0 } else { 100.0 * (h - ideal) / ideal });
        }
        // tangential focus: rays at +-delta in y around the chief ray
        let tp = lens.trace(&Self::field_ray(theta, 0.0, yc + delta, ep_z), LAMBDA_D_NM, false);
        let tm = lens.trace(&Self::field_ray(theta, 0.0, yc - delta, ep_z), LAMBDA_D_NM, false);
        if let (Ok(a), Ok(b)) = (tp, tm) {
            let (a, b) = (a.at_z(z_img), b.at_z(z_img));
            let (sa, sb) = (a.d[1] / a.d[2], b.d[1] / b.d[2]);
            if sa != sb {
                fs.tangential_focus_mm = Some(-(a.p[1] - b.p[1]) / (sa - sb));
            }
        }
        // sagittal focus: a ray at +delta in x crosses the meridional plane
        if let Ok(a) = lens.trace(&Self::field_ray(theta, delta, yc, ep_z), LAMBDA_D_NM, false) {
            let a = a.at_z(z_img);
            if a.d[0] != 0.0 {
                fs.sagittal_focus_mm = Some(-a.p[0] * a.d[2] / a.d[0]);
            }
        }
        if let (Some(t), Some(s)) = (fs.tangential_focus_mm, fs.sagittal_focus_mm) {
            fs.astigmatism_mm = Some(t - s);
        }
        let frac = self.count_passing(par, theta, yc) as f64 / on_axis_count as f64;
        fs.pupil_transmission = frac;
        fs.relative_illumination = frac * theta.cos().powi(4);
        // lateral colour: F and C chief rays (each through the stop centre) on the
        // d-line image plane
        let h_at = |lambda: f64| -> Option<f64> {
            let y = lens.chief_ray_pupil_height(theta, lambda)?;
            let r = lens.trace(&Self::field_ray(theta, 0.0, y, ep_z), lambda, false).ok()?;
            Some(r.at_z(z_img).p[1])
        };
        if let (Some(hf), Some(hc)) = (h_at(LAMBDA_F_NM), h_at(LAMBDA_C_NM)) {
            fs.lateral_color_f_minus_c_mm = Some(hf - hc);
            if let Some(hd) = fs.image_height_mm {
                fs.lateral_color_c_minus_d_mm = Some(hc - hd);
                fs.lateral_color_f_minus_d_mm = Some(hf - hd);
            }
        }
        // Coma: the rim rays of the meridional fan (upper and lower edge of the pupil)
        // and a sagittal rim ray, on the paraxial image plane, against the chief ray.
        // Defocus, astigmatism and spherical aberration move the two meridional rim
        // rays by equal and opposite amounts, so their mean minus the chief ray is the
        // tangential coma; the sagittal rim ray's height minus the chief ray is the
        // sagittal coma (a third of it in third-order theory). Unclipped rays: the
        // aberration of the design, not of the vignetted pupil.
        if let Some(h) = fs.image_height_mm {
            let y_at = |x: f64, y: f64| -> Option<f64> {
                let r = lens.trace(&Self::field_ray(theta, x, y, ep_z), LAMBDA_D_NM, false).ok()?;
                Some(r.at_z(z_img).p[1])
            };
            let outward = if h < 0.0 { -1.0 } else { 1.0 };
            if let (Some(a), Some(b)) = (y_at(0.0, yc + ep_sd), y_at(0.0, yc - ep_sd)) {
                fs.tangential_coma_mm = Some(outward * (0.5 * (a + b) - h));
            }
            if let Some(a) = y_at(ep_sd, yc) {
                fs.sagittal_coma_mm = Some(outward * (a - h));
            }
        }
        fs
    }
}

/// Least squares LSA = a h^2 + b h^4 over the zones that pass: (a, b); NaN (no fit) when fewer
/// than two zones pass or the system is singular.
fn lsa_fit(spherical: &[LsaSample]) -> (f64, f64) {
    let (mut s44, mut s46, mut s66, mut r4, mut r6) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for smp in spherical {
        if let Some(l) = smp.lsa_mm {
            let h2 = smp.height_mm * smp.height_mm;
            s44 += h2 * h2;
            s46 += h2 * h2 * h2;
            s66 += h2 * h2 * h2 * h2;
            r4 += l * h2;
            r6 += l * h2 * h2;
        }
    }
    let det = s44 * s66 - s46 * s46;
    if det.abs() > 1e-12 * (s44 * s66).abs() && det.is_finite() {
        ((r4 * s66 - r6 * s46) / det, (s44 * r6 - s46 * r4) / det)
    } else {
        (f64::NAN, f64::NAN)
    }
}

/// Longitudinal spherical aberration of one pupil zone.
#[derive(Debug, Clone, PartialEq)]
pub struct LsaSample {
    /// Zone as a fraction of the entrance-pupil radius.
    pub zone: f64,
    pub height_mm: f64,
    /// Axial intercept minus the paraxial focus (negative = marginal focus nearer the lens,
    /// under-corrected). None if the ray fails.
    pub lsa_mm: Option<f64>,
    /// Where the ray would be vignetted by a semi-diameter, if anywhere.
    pub clipped: Option<RayFailure>,
}

/// Off-axis results at one field angle (d line, image plane at the paraxial focus).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FieldSample {
    pub angle_deg: f64,
    /// f tan(theta).
    pub ideal_height_mm: f64,
    /// Real chief-ray height on the paraxial image plane.
    pub image_height_mm: Option<f64>,
    /// Kyaw eq. 6.8: 100 (R - r)/r; negative = barrel.
    pub distortion_percent: Option<f64>,
    /// Tangential focus minus the paraxial image plane, along the axis.
    pub tangential_focus_mm: Option<f64>,
    /// Sagittal focus minus the paraxial image plane, along the axis.
    pub sagittal_focus_mm: Option<f64>,
    /// Tangential minus sagittal focus.
    pub astigmatism_mm: Option<f64>,
    /// Fraction of the on-axis ray count that passes every semi-diameter (pupil vignetting).
    pub pupil_transmission: f64,
    /// pupil_transmission * cos^4(theta).
    pub relative_illumination: f64,
    /// Chief-ray height F minus C on the d image plane.
    pub lateral_color_f_minus_c_mm: Option<f64>,
    /// Chief-ray height C (red) minus d, and F (blue) minus d, on the d image plane.
    pub lateral_color_c_minus_d_mm: Option<f64>,
    pub lateral_color_f_minus_d_mm: Option<f64>,
    /// Tangential coma: mean of the meridional rim rays minus the chief ray (mm, + = the
    /// flare points away from the axis).
    pub tangential_coma_mm: Option<f64>,
    /// Sagittal coma: a sagittal rim ray minus the chief ray, along the radius.
    pub sagittal_coma_mm: Option<f64>,
    /// Where the chief ray is vignetted, if it is.
    pub chief_ray_clipped: Option<RayFailure>,
}

/// Paraxial focus shifts between the F, d and C lines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LongitudinalColor {
    pub focus_f_minus_d_mm: f64,
    pub focus_c_minus_d_mm: f64,
    pub focus_f_minus_c_mm: f64,
}

/// Everything [`Prescription::analyze`] computes.
#[derive(Debug, Clone, PartialEq)]
pub struct LensAnalysis {
    pub name: String,
    pub f_number: f64,
    /// f-number with the stop at its table semi-diameter.
    pub f_number_at_table_stop: f64,
    pub stop_index: usize,
    /// Stop semi-diameter used (set for `f_number`).
    pub stop_semi_diameter_mm: f64,
    /// d-line paraxial properties at `f_number`.
    pub paraxial: Paraxial,
    pub spherical: Vec<LsaSample>,
    /// Least-squares fit LSA = a h^2 + b h^4 over the zones (h = entrance-pupil height).
    pub lsa_h2_coefficient_per_mm: f64,
    pub lsa_h4_coefficient_per_mm3: f64,
    pub longitudinal_color: LongitudinalColor,
    pub fields: Vec<FieldSample>,
}

/// The lens-file tables a prescription implies (see [`LensAnalysis::derived_tables`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DerivedTables {
    pub f_number: f64,
    pub image_height_mm: Vec<f64>,
    pub distortion_percent: Vec<f64>,
    pub lateral_color_red_percent: Vec<f64>,
    pub lateral_color_blue_percent: Vec<f64>,
    pub relative_illumination: Vec<f64>,
    pub field_curvature_mm: Vec<f64>,
    pub tangential_blur_mm: Vec<f64>,
    pub sagittal_blur_mm: Vec<f64>,
    pub coma_mm: Vec<f64>,
    /// Red (C) and blue (F) paraxial focus minus green (d), mm.
    pub longitudinal_color_mm: [f64; 2],
    /// Cat's eye at `cats_eye_at_mm` (the outermost field traced): the shift K (in pupil radii)
    /// of the clipping circle whose overlap with the pupil passes the traced fraction of rays.
    pub cats_eye: f64,
    pub cats_eye_at_mm: f64,
    /// Longitudinal spherical aberration at the rim of the pupil from the least-squares fit
    /// LSA = k h^2 over the traced, unclipped zones (the third-order part the bokeh model
    /// represents), mm.
    pub lsa_rim_mm: f64,
}

/// Fraction of a unit circle's area that a second unit circle, shifted by `k` radii, overlaps:
/// (2 acos(k/2) - k sqrt(1 - k^2/4)) / pi. The cat's-eye model of the bokeh passes
/// (glsl/include/aperture.glsl, src/passes/dof/aperture.rs) clips the aperture this way.
pub fn circle_overlap_fraction(k: f64) -> f64 {
    let h = (0.5 * k).clamp(0.0, 1.0);
    (2.0 * h.acos() - 2.0 * h * (1.0 - h * h).sqrt()) / std::f64::consts::PI
}

/// The shift whose overlap passes `transmission` of the light (bisection; 0 for 1 or more).
pub fn cats_eye_from_transmission(transmission: f64) -> f64 {
    // NaN and full transmission: no cat's eye.
    if transmission.is_nan() || transmission >= 1.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0, 2.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if circle_overlap_fraction(mid) > transmission {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

impl LensAnalysis {
    /// The tables of a lens file, from the traced field samples (which must start on axis and
    /// all trace). Against the ideal height f tan(theta):
    /// - distortion and lateral colour in percent of the ideal height (Kyaw 2013 eq 6.8);
    /// - field curvature = the medial surface (T + S) / 2, which the CoC pass uses as the film
    ///   offset, so a point on it is in focus in the mean;
    /// - what is left at the medial surface is the astigmatic circle of least confusion, of
    ///   diameter |T - S| / (2 N) (the tangential and sagittal fans each defocused by
    ///   |T - S| / 2, each spreading over defocus / N): both blur tables get that length;
    /// - coma = the tangential coma (the comet's length);
    /// - relative illumination = pupil transmission * cos^4;
    /// - the cat's eye: the traced pupil transmission at the outermost field read as the
    ///   overlap of the pupil with a shifted circle (the bokeh passes' model).
    pub fn derived_tables(&self) -> Result<DerivedTables, String> {
        if self.fields.first().is_none_or(|f| f.angle_deg != 0.0) {
            return Err("the field angles must start at 0 degrees".into());
        }
        let n = self.f_number;
        let mut t = DerivedTables {
            f_number: n,
            image_height_mm: vec![],
            distortion_percent: vec![],
            lateral_color_red_percent: vec![],
            lateral_color_blue_percent: vec![],
            relative_illumination: vec![],
            field_curvature_mm: vec![],
            tangential_blur_mm: vec![],
            sagittal_blur_mm: vec![],
            coma_mm: vec![],
            longitudinal_color_mm: [
                self.longitudinal_color.focus_c_minus_d_mm,
                self.longitudinal_color.focus_f_minus_d_mm,
            ],
            cats_eye: {
                let last = self.fields.last().map_or(1.0, |f| f.pupil_transmission);
                cats_eye_from_transmission(last)
            },
            cats_eye_at_mm: self.fields.last().map_or(0.0, |f| f.ideal_height_mm),
            lsa_rim_mm: {
                let (mut num, mut den) = (0.0, 0.0);
                // Zones whose ray some semi-diameter clips are not in the beam.
                for z in self.spherical.iter().filter(|z| z.clipped.is_none()) {
                    if let Some(l) = z.lsa_mm {
                        let h2 = z.height_mm * z.height_mm;
                        num += l * h2;
                        den += h2 * h2;
                    }
                }
                let rim_mm = self.spherical.iter().map(|z| z.height_mm).fold(0.0, f64::max);
                if den > 0.0 {
                    num / den * rim_mm * rim_mm
                } else {
                    return Err("no spherical-aberration zone could be traced".into());
                }
            },
        };
        for f in &self.fields {
            let missing = || format!("the rays at {} degrees could not be traced", f.angle_deg);
            let percent = |d: Option<f64>| -> Result<f64, String> {
                let d = d.ok_or_else(missing)?;
                Ok(if f.ideal_height_mm.abs() < 1e-12 { 0.0 } else { 100.0 * d / f.ideal_height_mm })
            };
            let (tf, sf) = (f.tangential_focus_mm.ok_or_else(missing)?, f.sagittal_focus_mm.ok_or_else(missing)?);
            t.image_height_mm.push(f.ideal_height_mm);
            t.distortion_percent.push(f.distortion_percent.ok_or_else(missing)?);
            t.lateral_color_red_percent.push(percent(f.lateral_color_c_minus_d_mm)?);
            t.lateral_color_blue_percent.push(percent(f.lateral_color_f_minus_d_mm)?);
            t.relative_illumination.push(f.relative_illumination);
            t.field_curvature_mm.push(0.5 * (tf + sf));
            let least_confusion_mm = (tf - sf).abs() / (2.0 * n);
            t.tangential_blur_mm.push(least_confusion_mm);
            t.sagittal_blur_mm.push(least_confusion_mm);
            t.coma_mm.push(f.tangential_coma_mm.ok_or_else(missing)?);
        }
        // On axis the heights are 0 and the ratios 0/0: take their limits.
        // Distortion in percent goes as h^2 (0 on axis); lateral colour in percent tends to a
        // constant (the colour's height difference goes as h): continue the first off-axis value.
        t.distortion_percent[0] = 0.0;
        if t.image_height_mm.len() > 1 {
            t.lateral_color_red_percent[0] = t.lateral_color_red_percent[1];
            t.lateral_color_blue_percent[0] = t.lateral_color_blue_percent[1];
        }
        t.coma_mm[0] = 0.0;
        if let Some(i) = (1..t.image_height_mm.len()).find(|&i| t.image_height_mm[i] <= t.image_height_mm[i - 1]) {
            return Err(format!("the image heights do not increase at field {} degrees", self.fields[i].angle_deg));
        }
        Ok(t)
    }
}

fn opt(v: Option<f64>, prec: usize) -> String {
    match v {
        Some(x) => format!("{x:.prec$}"),
        None => "-".to_string(),
    }
}

impl fmt::Display for LensAnalysis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = &self.paraxial;
        writeln!(f, "Lens: {}", self.name)?;
        writeln!(
            f,
            "  f/{:.2} (stop = surface {}, semi-diameter {:.3} mm; table stop gives f/{:.2})",
            self.f_number, self.stop_index, self.stop_semi_diameter_mm, self.f_number_at_table_stop
        )?;
        writeln!(f, "Paraxial (d line, z from the first vertex):")?;
        writeln!(f, "  EFL {:.4} mm   BFL {:.4} mm   FFL {:.4} mm", p.efl_mm, p.bfl_mm, p.ffl_mm)?;
        writeln!(
            f,
            "  focal points F {:.4}  F' {:.4}; principal planes H {:.4}  H' {:.4} mm",
            p.front_focal_z_mm, p.rear_focal_z_mm, p.front_principal_z_mm, p.rear_principal_z_mm
        )?;
        writeln!(
            f,
            "  entrance pupil z {:.4} mm, diameter {:.4} mm; exit pupil z {:.4} mm, diameter {:.4} mm; P = {:.4}",
            p.entrance_pupil_z_mm,
            2.0 * p.entrance_pupil_semi_diameter_mm,
            p.exit_pupil_z_mm,
            2.0 * p.exit_pupil_semi_diameter_mm,
            p.pupil_magnification
        )?;
        writeln!(
            f,
            "  table image plane z {:.4} mm (paraxial focus {:+.4} mm from it)",
            p.table_image_z_mm,
            p.rear_focal_z_mm - p.table_image_z_mm
        )?;
        writeln!(f, "Longitudinal spherical aberration (marginal intercept - paraxial focus):")?;
        for s in &self.spherical {
            writeln!(
                f,
                "  zone {:.3} (h {:.3} mm): {} mm{}",
                s.zone,
                s.height_mm,
                opt(s.lsa_mm, 5),
                match s.clipped {
                    Some(c) => format!("  [vignetted: {c:?}]"),
                    None => String::new(),
                }
            )?;
        }
        let (a, b) = (self.lsa_h2_coefficient_per_mm, self.lsa_h4_coefficient_per_mm3);
        if a.is_finite() && b.is_finite() {
            writeln!(f, "  fit LSA = {a:.4e} h^2 + {b:.4e} h^4")?;
        } else {
            writeln!(f, "  fit LSA: too few unclipped zones to fit")?;
        }
        let lc = &self.longitudinal_color;
        writeln!(
            f,
            "Longitudinal colour: F-d {:+.5} mm, C-d {:+.5} mm, F-C {:+.5} mm",
            lc.focus_f_minus_d_mm, lc.focus_c_minus_d_mm, lc.focus_f_minus_c_mm
        )?;
        writeln!(
            f,
            "Field:  angle   height    ideal  dist(%)   T-focus   S-focus     astig  pupil  RI     lat.col(F-C)  coma T/S (mm)"
        )?;
        for s in &self.fields {
            writeln!(
                f,
                "  {:6.2} {:>8} {:8.3} {:>8} {:>9} {:>9} {:>9} {:6.3} {:6.3} {:>9}  {:>8} {:>8}{}",
                s.angle_deg,
                opt(s.image_height_mm, 3),
                s.ideal_height_mm,
                opt(s.distortion_percent, 3),
                opt(s.tangential_focus_mm, 4),
                opt(s.sagittal_focus_mm, 4),
                opt(s.astigmatism_mm, 4),
                s.pupil_transmission,
                s.relative_illumination,
                opt(s.lateral_color_f_minus_c_mm, 5),
                opt(s.tangential_coma_mm, 4),
                opt(s.sagittal_coma_mm, 4),
                match s.chief_ray_clipped {
                    Some(c) => format!("  chief ray vignetted: {c:?}"),
                    None => String::new(),
                }
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_lenses::*;
    use super::super::*;

    fn plano_convex() -> Prescription {
        // convex side to infinity, stop on the lens
        Prescription {
            name: "plano-convex".into(),
            surfaces: vec![surf(50.0, 6.0, 1.5, 20.0, true), surf(0.0, 95.0, 1.0, 20.0, false)],
        }
    }

    #[test]
    fn plano_convex_is_undercorrected_and_lsa_goes_as_h2() {
        let lens = plano_convex();
        let zf = lens.paraxial(LAMBDA_D_NM).rear_focal_z_mm;
        let lsa = |h: f64| lens.axial_intercept_z_mm(h, LAMBDA_D_NM).unwrap() - zf;
        assert!(lsa(10.0) < 0.0, "marginal focus must be nearer the lens");
        // small zones: ratio for doubling the height -> 4
        let ratio = lsa(2.0) / lsa(1.0);
        assert!((ratio - 4.0).abs() < 0.02, "ratio {ratio}");
        let a = lens.analyze(4.0, &[]);
        assert!(a.lsa_h2_coefficient_per_mm < 0.0);
        // the h^2 term dominates the fit over the pupil
        let h = a.paraxial.entrance_pupil_semi_diameter_mm;
        assert!(a.lsa_h4_coefficient_per_mm3.abs() * h * h < 0.2 * a.lsa_h2_coefficient_per_mm.abs());
        for s in &a.spherical {
            assert!(s.lsa_mm.unwrap() < 0.0);
        }
    }

    #[test]
    fn distortion_zero_on_axis_and_barrel_with_front_stop() {
        // stop 20 mm in front of a positive plano-convex singlet: barrel (negative)
        let lens = Prescription {
            name: "front stop singlet".into(),
            surfaces: vec![
                surf(0.0, 20.0, 1.0, 5.0, true),
                surf(50.0, 6.0, 1.5, 30.0, false),
                surf(0.0, 95.0, 1.0, 30.0, false),
            ],
        };
        let a = lens.analyze(8.0, &[0.0, 10.0, 20.0]);
        assert_eq!(a.fields[0].distortion_percent, Some(0.0));
        let d10 = a.fields[1].distortion_percent.unwrap();
        let d20 = a.fields[2].distortion_percent.unwrap();
        assert!(d10 < 0.0 && d20 < d10, "{d10} {d20}");
        // and the reverse (stop behind the lens) gives pincushion
        let rear = Prescription {
            name: "rear stop singlet".into(),
            surfaces: vec![
                surf(0.0, 6.0, 1.5, 30.0, false),
                surf(-50.0, 20.0, 1.0, 30.0, false),
                surf(0.0, 80.0, 1.0, 5.0, true),
            ],
        };
        let a = rear.analyze(8.0, &[15.0]);
        assert!(a.fields[0].distortion_percent.unwrap() > 0.0);
    }

    #[test]
    fn field_curves_of_singlet_and_relative_illumination() {
        // Stop at a thin-ish singlet: the Petzval surface is curved towards the lens, both field
        // foci move inwards (negative) and tangential lies inside sagittal.
        let lens = Prescription {
            name: "thin singlet".into(),
            surfaces: vec![surf(100.0, 2.0, 1.5, 10.0, true), surf(-100.0, 100.0, 1.0, 10.0, false)],
        };
        let a = lens.analyze(8.0, &[0.0, 5.0, 10.0]);
        let f0 = &a.fields[0];
        assert!(f0.astigmatism_mm.unwrap().abs() < 1e-6);
        assert!((f0.relative_illumination - 1.0).abs() < 1e-12);
        let f10 = &a.fields[2];
        assert!(f10.tangential_focus_mm.unwrap() < f10.sagittal_focus_mm.unwrap());
        assert!(f10.sagittal_focus_mm.unwrap() < 0.0);
        // no vignetting by other apertures: RI ~ cos^4 (the pupil grows slightly off-axis)
        let c4 = f64::to_radians(10.0).cos().powi(4);
        assert!((f10.relative_illumination - c4).abs() < 0.03, "{}", f10.relative_illumination);
    }

    #[test]
    fn coma_follows_third_order_theory_at_small_aperture_and_field() {
        // A singlet with the stop in contact has coma (a bending that is not the coma-free
        // one). Third-order (Seidel) coma: tangential = 3 x sagittal, both grow linearly with
        // the field and with the square of the aperture.
        let lens = Prescription {
            name: "singlet".into(),
            surfaces: vec![surf(60.0, 3.0, 1.5168, 12.0, true), surf(-400.0, 100.0, 1.0, 12.0, false)],
        };
        let coma = |n: f64, deg: f64| {
            let a = lens.analyze(n, &[deg]);
            (a.fields[0].tangential_coma_mm.unwrap(), a.fields[0].sagittal_coma_mm.unwrap())
        };
        let (t, s) = coma(16.0, 1.0);
        assert!(t.abs() > 1e-7, "no coma: {t}");
        assert!((t / s - 3.0).abs() < 0.03, "T/S = {}", t / s);
        let (t2, _) = coma(16.0, 2.0);
        assert!((t2 / t - 2.0).abs() < 0.02, "field ratio {}", t2 / t);
        let (t_half, _) = coma(32.0, 1.0);
        assert!((t / t_half - 4.0).abs() < 0.05, "aperture ratio {}", t / t_half);
    }

    #[test]
    fn cats_eye_overlap_and_its_inverse() {
        assert_eq!(circle_overlap_fraction(0.0), 1.0);
        assert!(circle_overlap_fraction(2.0).abs() < 1e-15);
        // By hand: K = 0.55 -> (2 acos 0.275 - 0.55 sqrt(1 - 0.075625)) / pi = 0.6544.
        assert!((circle_overlap_fraction(0.55) - 0.6544).abs() < 1e-4);
        for t in [0.99, 0.8, 0.5, 0.1] {
            assert!((circle_overlap_fraction(cats_eye_from_transmission(t)) - t).abs() < 1e-12);
        }
        assert_eq!(cats_eye_from_transmission(1.0), 0.0);
        assert_eq!(cats_eye_from_transmission(f64::NAN), 0.0);
    }

    #[test]
    fn derived_tables_follow_the_trace() {
        let a = walch().analyze(2.8, &[0.0, 5.0, 10.0, 15.0]);
        let t = a.derived_tables().unwrap();
        assert_eq!(t.image_height_mm.len(), 4);
        assert_eq!(t.distortion_percent[0], 0.0);
        let f = &a.fields[2];
        assert_eq!(t.distortion_percent[2], f.distortion_percent.unwrap());
        let medial = 0.5 * (f.tangential_focus_mm.unwrap() + f.sagittal_focus_mm.unwrap());
        assert_eq!(t.field_curvature_mm[2], medial);
        // circle of least confusion at the medial surface: |T - S| / (2N)
        assert!((t.tangential_blur_mm[2] - f.astigmatism_mm.unwrap().abs() / 5.6).abs() < 1e-12);
        assert_eq!(t.longitudinal_color_mm[0], a.longitudinal_color.focus_c_minus_d_mm);
        // LSA = k h^2 fitted over the unclipped zones, at the rim: on a pure h^2 lens it is exact.
        let zones: Vec<_> = a.spherical.iter().filter(|z| z.clipped.is_none()).collect();
        let k = zones.iter().map(|z| z.lsa_mm.unwrap() * z.height_mm.powi(2)).sum::<f64>()
            / zones.iter().map(|z| z.height_mm.powi(4)).sum::<f64>();
        let rim = a.spherical.last().unwrap().height_mm;
        assert!((t.lsa_rim_mm - k * rim * rim).abs() < 1e-12);
        // red minus blue lateral colour in percent = (C - F) heights over the ideal height
        let lat = t.lateral_color_red_percent[2] - t.lateral_color_blue_percent[2];
        assert!((lat + 100.0 * f.lateral_color_f_minus_c_mm.unwrap() / f.ideal_height_mm).abs() < 1e-9);
        // The cat's eye: the outermost field's pupil transmission as a shifted circle's overlap.
        let last = a.fields.last().unwrap();
        assert_eq!(t.cats_eye_at_mm, last.ideal_height_mm);
        assert!((circle_overlap_fraction(t.cats_eye) - last.pupil_transmission).abs() < 1e-12);
        let err = walch().analyze(2.8, &[5.0, 10.0]).derived_tables().unwrap_err();
        assert_eq!(err, "the field angles must start at 0 degrees");
    }

    #[test]
    fn chromatic_model_and_positive_lens_colour() {
        let n_f = index_at(1.5168, 64.17, LAMBDA_F_NM);
        let n_c = index_at(1.5168, 64.17, LAMBDA_C_NM);
        assert!(((n_f - n_c) - 0.5168 / 64.17).abs() < 1e-12);
        assert_eq!(index_at(1.5168, 64.17, LAMBDA_D_NM), 1.5168);
        let a = thick_lens(10.0).analyze(8.0, &[10.0]);
        // a positive singlet focuses blue nearer: F - C focus negative
        assert!(a.longitudinal_color.focus_f_minus_c_mm < 0.0);
        assert!(a.longitudinal_color.focus_f_minus_d_mm < 0.0);
        assert!(a.longitudinal_color.focus_c_minus_d_mm > 0.0);
        assert!(a.fields[0].lateral_color_f_minus_c_mm.unwrap().is_finite());
    }
}
