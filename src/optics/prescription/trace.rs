//! Real rays: exact 3D tracing through spherical surfaces, the chief ray and axial intercepts.

use super::Prescription;

/// Why a real ray did not get through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RayFailure {
    /// Outside the semi-diameter of this surface (vignetted).
    Clipped { surface: usize },
    /// Does not meet the sphere of this surface.
    Missed { surface: usize },
    /// Total internal reflection at this surface.
    TotalInternalReflection { surface: usize },
}

/// A real ray: a point and a unit direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub p: [f64; 3],
    pub d: [f64; 3],
}

impl Ray {
    /// A ray from `p` along `d` (normalised here).
    pub fn new(p: [f64; 3], d: [f64; 3]) -> Ray {
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        Ray { p, d: [d[0] / l, d[1] / l, d[2] / l] }
    }

    /// The ray moved along itself to the plane z = `z_mm`.
    pub fn at_z(&self, z_mm: f64) -> Ray {
        let t = (z_mm - self.p[2]) / self.d[2];
        Ray { p: [self.p[0] + t * self.d[0], self.p[1] + t * self.d[1], z_mm], d: self.d }
    }
}

impl Prescription {
    /// Trace `ray` (in object space, anywhere on its line) through surfaces `0..=last`; returns
    /// the ray at the last surface met, already refracted. With `clip`, rays outside a
    /// semi-diameter are reported as clipped.
    pub fn trace_through(&self, ray: &Ray, last: usize, lambda_nm: f64, clip: bool) -> Result<Ray, RayFailure> {
        let zs = self.vertex_z_mm();
        let mut r = *ray;
        for (i, (s, &z)) in self.surfaces.iter().zip(&zs).enumerate().take(last + 1) {
            // to the vertex plane, then to the sphere (Welford's stable form)
            r = r.at_z(z);
            let c = s.curvature_per_mm();
            let (x, y) = (r.p[0], r.p[1]);
            let [l, m, nz] = r.d;
            let f = c * (x * x + y * y);
            let g = nz - c * (x * l + y * m);
            let disc = g * g - c * f;
            if disc < 0.0 {
                return Err(RayFailure::Missed { surface: i });
            }
            let t = f / (g + disc.sqrt());
            if !t.is_finite() {
                return Err(RayFailure::Missed { surface: i });
            }
            let p = [x + t * l, y + t * m, zs[i] + t * nz];
            if clip && p[0] * p[0] + p[1] * p[1] > s.semi_diameter_mm * s.semi_diameter_mm {
                return Err(RayFailure::Clipped { surface: i });
            }
            // unit normal towards +z
            let sag = p[2] - zs[i];
            let nrm = [-c * p[0], -c * p[1], 1.0 - c * sag];
            let mu = self.index_before(i, lambda_nm) / s.index_at(lambda_nm);
            let cosi = nrm[0] * l + nrm[1] * m + nrm[2] * nz;
            let k = 1.0 - mu * mu * (1.0 - cosi * cosi);
            if k < 0.0 {
                return Err(RayFailure::TotalInternalReflection { surface: i });
            }
            let g2 = k.sqrt() - mu * cosi;
            r = Ray::new(p, [mu * l + g2 * nrm[0], mu * m + g2 * nrm[1], mu * nz + g2 * nrm[2]]);
        }
        Ok(r)
    }

    /// Trace through every surface.
    pub fn trace(&self, ray: &Ray, lambda_nm: f64, clip: bool) -> Result<Ray, RayFailure> {
        self.trace_through(ray, self.surfaces.len() - 1, lambda_nm, clip)
    }

    /// Ray from infinity at field angle `theta_rad` (in the y-z plane) through the point
    /// (x, y) of the plane z = `z_plane_mm`.
    pub(super) fn field_ray(theta_rad: f64, x: f64, y: f64, z_plane_mm: f64) -> Ray {
        Ray::new([x, y, z_plane_mm], [0.0, theta_rad.sin(), theta_rad.cos()])
    }

    /// The real chief ray at `theta_rad`: the ray from infinity through the stop centre, found
    /// by secant iteration on its height in the paraxial entrance-pupil plane. Returns that
    /// height (None if it cannot be found).
    pub fn chief_ray_pupil_height(&self, theta_rad: f64, lambda_nm: f64) -> Option<f64> {
        let p = self.paraxial(lambda_nm);
        let s = self.stop_index();
        let z = p.entrance_pupil_z_mm;
        let stop_y = |y: f64| -> Option<f64> {
            self.trace_through(&Self::field_ray(theta_rad, 0.0, y, z), s, lambda_nm, false).ok().map(|r| r.p[1])
        };
        let scale = p.entrance_pupil_semi_diameter_mm.max(1e-3);
        let (mut y0, mut g0) = (0.0, stop_y(0.0)?);
        let mut y1 = -g0 / p.pupil_scale().max(1e-12) * 0.5 + 1e-3 * scale;
        let mut g1 = stop_y(y1)?;
        for _ in 0..60 {
            if g1.abs() < 1e-13 * scale {
                return Some(y1);
            }
            let dg = g1 - g0;
            if dg == 0.0 {
                break;
            }
            let y2 = y1 - g1 * (y1 - y0) / dg;
            y0 = y1;
            g0 = g1;
            y1 = y2;
            g1 = stop_y(y1)?;
        }
        if g1.abs() < 1e-9 * scale {
            Some(y1)
        } else {
            None
        }
    }

    /// Axial intercept (z) of a meridional ray from infinity parallel to the axis at height
    /// `h_mm` (d line unless given), without clipping.
    pub fn axial_intercept_z_mm(&self, h_mm: f64, lambda_nm: f64) -> Option<f64> {
        let r = self.trace(&Ray::new([0.0, h_mm, -1.0], [0.0, 0.0, 1.0]), lambda_nm, false).ok()?;
        if r.d[1] == 0.0 {
            return None;
        }
        Some(r.p[2] - r.p[1] * r.d[2] / r.d[1])
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_lenses::*;
    use super::super::*;

    fn efl_three_ways(p: &Prescription) -> (f64, f64, f64) {
        let m = p.paraxial(LAMBDA_D_NM).efl_mm;
        let (_, u) = p.paraxial_trace(1.0, 0.0, LAMBDA_D_NM);
        let yu = -1.0 / u;
        let h = 1e-6;
        let r = p.trace(&Ray::new([0.0, h, -1.0], [0.0, 0.0, 1.0]), LAMBDA_D_NM, false).unwrap();
        let real = -h / (r.d[1] / r.d[2]);
        (m, yu, real)
    }

    #[test]
    fn efl_matrix_equals_paraxial_and_real_trace() {
        for p in [thick_lens(10.0), walch()] {
            let (m, yu, real) = efl_three_ways(&p);
            assert!(rel(yu, m) < 1e-9, "{m} vs y-u {yu}");
            assert!(rel(real, m) < 1e-6, "{m} vs real {real}");
        }
    }

    #[test]
    fn chief_ray_passes_stop_centre() {
        let lens = walch();
        let p = lens.paraxial(LAMBDA_D_NM);
        let s = lens.stop_index();
        for deg in [5.0, 15.0, 25.0] {
            let th = f64::to_radians(deg);
            let y = lens.chief_ray_pupil_height(th, LAMBDA_D_NM).unwrap();
            let r = lens
                .trace_through(
                    &Ray::new([0.0, y, p.entrance_pupil_z_mm], [0.0, th.sin(), th.cos()]),
                    s,
                    LAMBDA_D_NM,
                    false,
                )
                .unwrap();
            assert!(r.p[1].abs() < 1e-9, "{}", r.p[1]);
        }
    }
}
