//! Paraxial optics: ray-transfer matrices acting on (y, u) (Walch 2017, sec. 4.2.1), the
//! first-order properties of a prescription, its pupils, and the stop for an f-number.

use super::{Prescription, LAMBDA_D_NM};

/// A 2x2 ray-transfer matrix [[a, b], [c, d]] acting on (height y, angle u).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayMatrix {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub d: f64,
}

impl RayMatrix {
    pub const IDENTITY: RayMatrix = RayMatrix { a: 1.0, b: 0.0, c: 0.0, d: 1.0 };

    /// Walch 4.2.1: translation by `d_mm` in a homogeneous medium.
    pub fn translation(d_mm: f64) -> RayMatrix {
        RayMatrix { a: 1.0, b: d_mm, c: 0.0, d: 1.0 }
    }

    /// Walch 4.2.1: refraction at a surface of curvature `c_per_mm` from index n1 into n2.
    pub fn refraction(c_per_mm: f64, n1: f64, n2: f64) -> RayMatrix {
        RayMatrix { a: 1.0, b: 0.0, c: (n1 - n2) * c_per_mm / n2, d: n1 / n2 }
    }

    /// `self` applied after `first`: self * first.
    pub fn after(&self, first: &RayMatrix) -> RayMatrix {
        RayMatrix {
            a: self.a * first.a + self.b * first.c,
            b: self.a * first.b + self.b * first.d,
            c: self.c * first.a + self.d * first.c,
            d: self.c * first.b + self.d * first.d,
        }
    }

    pub fn apply(&self, y: f64, u: f64) -> (f64, f64) {
        (self.a * y + self.b * u, self.c * y + self.d * u)
    }

    pub fn determinant(&self) -> f64 {
        self.a * self.d - self.b * self.c
    }
}

/// First-order (Gaussian) properties of a prescription at one wavelength. Positions are axial
/// z in the frame with the first vertex at 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paraxial {
    pub lambda_nm: f64,
    /// Effective (rear) focal length -1/C of the system matrix.
    pub efl_mm: f64,
    /// Back focal length: last vertex to the rear focal point.
    pub bfl_mm: f64,
    /// Front focal length: front focal point to the first vertex (positive when the focal
    /// point is in front of the lens).
    pub ffl_mm: f64,
    pub front_focal_z_mm: f64,
    pub rear_focal_z_mm: f64,
    /// Front (object-side) principal plane H.
    pub front_principal_z_mm: f64,
    /// Rear (image-side) principal plane H'.
    pub rear_principal_z_mm: f64,
    pub entrance_pupil_z_mm: f64,
    pub entrance_pupil_semi_diameter_mm: f64,
    pub exit_pupil_z_mm: f64,
    pub exit_pupil_semi_diameter_mm: f64,
    /// P = exit pupil diameter / entrance pupil diameter.
    pub pupil_magnification: f64,
    /// Stop semi-diameter per entrance-pupil semi-diameter (|A| of the front group matrix).
    pub stop_per_entrance_pupil: f64,
    /// Axial position of the last vertex.
    pub last_vertex_z_mm: f64,
    /// Image plane from the table (last vertex + last thickness).
    pub table_image_z_mm: f64,
}

impl Prescription {
    /// Ray-transfer matrix from just before the vertex of surface `first` to just after the
    /// refraction at surface `last` (inclusive; translations between them included). With
    /// `to_next` the translation after `last` is appended too.
    pub fn group_matrix(&self, first: usize, last: usize, to_next: bool, lambda_nm: f64) -> RayMatrix {
        let mut m = RayMatrix::IDENTITY;
        for i in first..=last {
            let s = &self.surfaces[i];
            let r = RayMatrix::refraction(s.curvature_per_mm(), self.index_before(i, lambda_nm), s.index_at(lambda_nm));
            m = r.after(&m);
            if i < last || to_next {
                m = RayMatrix::translation(s.thickness_mm).after(&m);
            }
        }
        m
    }

    /// System matrix from the first vertex to the last vertex.
    pub fn system_matrix(&self, lambda_nm: f64) -> RayMatrix {
        self.group_matrix(0, self.surfaces.len() - 1, false, lambda_nm)
    }

    /// Paraxial y-nu trace (independent of the matrices): the ray (y, u) entering at the first
    /// vertex, returned as (y, u) just after the last surface.
    pub fn paraxial_trace(&self, y: f64, u: f64, lambda_nm: f64) -> (f64, f64) {
        let (mut y, mut u) = (y, u);
        let n_last = self.surfaces.len() - 1;
        for (i, s) in self.surfaces.iter().enumerate() {
            let n1 = self.index_before(i, lambda_nm);
            let n2 = s.index_at(lambda_nm);
            // n' u' = n u - y c (n' - n)
            u = (n1 * u - y * s.curvature_per_mm() * (n2 - n1)) / n2;
            if i < n_last {
                y += s.thickness_mm * u;
            }
        }
        (y, u)
    }

    /// First-order properties at `lambda_nm`.
    pub fn paraxial(&self, lambda_nm: f64) -> Paraxial {
        let n = self.surfaces.len();
        let zs = self.vertex_z_mm();
        let z_last = zs[n - 1];
        let m = self.system_matrix(lambda_nm);
        let efl = -1.0 / m.c;
        let bfl = -m.a / m.c;
        let front_focal_z = m.d / m.c;
        let rear_focal_z = z_last + bfl;
        let s = self.stop_index();
        let stop_sd = self.surfaces[s].semi_diameter_mm;
        // Entrance pupil: the stop seen through surfaces 0..s-1.
        let (ep_z, ep_sd) = if s == 0 {
            (0.0, stop_sd)
        } else {
            let f = self.group_matrix(0, s - 1, true, lambda_nm);
            // chief ray: y_stop = a y0 + b u0 = 0 => crosses the axis at z = b/a;
            // parallel rays of height h reach the stop at a h.
            (f.b / f.a, stop_sd / f.a.abs())
        };
        // Exit pupil: the stop seen through surfaces s..n-1.
        let r = self.group_matrix(s, n - 1, false, lambda_nm);
        let (xp_z, xp_sd) = if r.d == 0.0 {
            (f64::INFINITY, f64::INFINITY)
        } else {
            // a ray leaving the stop centre at angle u is at (b u, d u) after the last surface.
            (z_last - r.b / r.d, stop_sd * (r.determinant() / r.d).abs())
        };
        Paraxial {
            lambda_nm,
            efl_mm: efl,
            bfl_mm: bfl,
            ffl_mm: -front_focal_z,
            front_focal_z_mm: front_focal_z,
            rear_focal_z_mm: rear_focal_z,
            front_principal_z_mm: front_focal_z + efl,
            rear_principal_z_mm: rear_focal_z - efl,
            entrance_pupil_z_mm: ep_z,
            entrance_pupil_semi_diameter_mm: ep_sd,
            exit_pupil_z_mm: xp_z,
            exit_pupil_semi_diameter_mm: xp_sd,
            pupil_magnification: xp_sd / ep_sd,
            stop_per_entrance_pupil: stop_sd / ep_sd,
            last_vertex_z_mm: z_last,
            table_image_z_mm: z_last + self.surfaces[n - 1].thickness_mm,
        }
    }

    /// Stop semi-diameter that gives the infinity f-number `f_number` = EFL / (2 EP radius).
    pub fn stop_semi_diameter_for(&self, f_number: f64) -> f64 {
        let p = self.paraxial(LAMBDA_D_NM);
        let ep_sd = p.efl_mm.abs() / (2.0 * f_number);
        ep_sd * p.pupil_scale()
    }

    /// A copy with the stop opened or closed to give `f_number`.
    pub fn with_f_number(&self, f_number: f64) -> Prescription {
        let mut out = self.clone();
        let sd = self.stop_semi_diameter_for(f_number);
        let s = self.stop_index();
        out.surfaces[s].semi_diameter_mm = sd;
        out
    }

    /// f-number at the table's stop semi-diameter (the widest aperture).
    pub fn f_number_at_table_stop(&self) -> f64 {
        let p = self.paraxial(LAMBDA_D_NM);
        p.efl_mm.abs() / (2.0 * p.entrance_pupil_semi_diameter_mm)
    }
}

impl Paraxial {
    /// Stop semi-diameter per entrance-pupil semi-diameter (|A| of the front group).
    pub(super) fn pupil_scale(&self) -> f64 {
        self.stop_per_entrance_pupil
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_lenses::*;
    use super::super::*;

    #[test]
    fn thick_lens_by_hand() {
        let (n, r1, r2, d) = (1.5, 50.0, -50.0, 10.0);
        let f = 1.0 / ((n - 1.0) * (1.0 / r1 - 1.0 / r2 + (n - 1.0) * d / (n * r1 * r2)));
        let bfl = f * (1.0 - (n - 1.0) * d / (n * r1));
        let ffl = f * (1.0 + (n - 1.0) * d / (n * r2));
        let p = thick_lens(d).paraxial(LAMBDA_D_NM);
        assert!(rel(p.efl_mm, f) < 1e-9, "{} vs {f}", p.efl_mm);
        assert!(rel(p.bfl_mm, bfl) < 1e-9, "{} vs {bfl}", p.bfl_mm);
        assert!(rel(p.ffl_mm, ffl) < 1e-9, "{} vs {ffl}", p.ffl_mm);
        // principal planes: H at -f (n-1) d / (n R2) from the first vertex, H' at
        // -f (n-1) d / (n R1) from the last
        let h = -f * (n - 1.0) * d / (n * r2);
        let h2 = d - f * (n - 1.0) * d / (n * r1);
        assert!((p.front_principal_z_mm - h).abs() < 1e-9 * f);
        assert!((p.rear_principal_z_mm - h2).abs() < 1e-9 * f);
        // symmetric lens, stop at the first surface: entrance pupil at the stop, P from the
        // exit pupil; the matrix determinant is 1 (air to air)
        assert!((thick_lens(d).system_matrix(LAMBDA_D_NM).determinant() - 1.0).abs() < 1e-12);
        assert_eq!(p.entrance_pupil_z_mm, 0.0);
        assert_eq!(p.entrance_pupil_semi_diameter_mm, 10.0);
    }

    #[test]
    fn thin_lens_limit_is_lensmaker() {
        let f_thin = 1.0 / (0.5 * (1.0 / 50.0 + 1.0 / 50.0));
        let p = thick_lens(1e-7).paraxial(LAMBDA_D_NM);
        assert!(rel(p.efl_mm, f_thin) < 1e-8, "{} vs {f_thin}", p.efl_mm);
        assert!(rel(p.bfl_mm, f_thin) < 1e-7);
    }

    #[test]
    fn f_number_sets_stop() {
        let lens = walch();
        for n in [2.8, 4.0, 8.0] {
            let l = lens.with_f_number(n);
            let p = l.paraxial(LAMBDA_D_NM);
            assert!(rel(p.efl_mm / (2.0 * p.entrance_pupil_semi_diameter_mm), n) < 1e-12);
        }
    }
}
