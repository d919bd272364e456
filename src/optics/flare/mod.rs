//! Lens flare (Walch 2017 sec. 3.2): the ghosts a lens's inner reflections make, the starburst
//! of its aperture's diffraction and the halo of its scattering, as plain f64 optics.
//!
//! - [`ghosts`]: every path with two reflections (surfaces j < i) through a prescription as 2x2
//!   ray-transfer matrices (Walch sec. 4.2.1; the matrix method of Lee & Eisemann 2013): where
//!   each ghost lies on the line through the image centre and the light, how large it is, the
//!   aperture's image as its shape, clipped where the path is vignetted, and its colour from the
//!   surfaces' [`coating`]s at several wavelengths.
//! - [`traced`]: the reference: the same paths by real rays (f64, Fresnel at every surface at
//!   the ray's own angle, clipped at every surface and by the aperture polygon).
//! - [`starburst`]: the Fraunhofer diffraction of the aperture (spikes along the blades' normals,
//!   n for an even blade count, 2n for an odd one) and the halo, with their energies.
//!
//! Conventions: the image plane is "display" space, pixels x right and y down, the image upright
//! (the sensor's image turned by 180 degrees). A light's direction enters as the vector u (mm of
//! image per mm of focal length, the paraxial slope) whose direct image lies at `centre + G0 u`;
//! every flare element is linear in it. The colour channels are wavelength bands: red 600-700,
//! green 500-600, blue 400-500 nm, each sampled at three wavelengths (trapezoid weights), the
//! geometry at the band's middle wavelength.

pub mod coating;
pub mod ghosts;
pub mod starburst;
pub mod traced;

use crate::optics::prescription::Prescription;

/// The band of each colour channel (red, green, blue): three wavelengths (nm) and their weights.
pub const BANDS_NM: [[f64; 3]; 3] = [[600.0, 650.0, 700.0], [500.0, 550.0, 600.0], [400.0, 450.0, 500.0]];
/// Trapezoid weights of a band's three wavelengths.
pub const BAND_WEIGHTS: [f64; 3] = [0.25, 0.5, 0.25];

/// The middle wavelength of channel `c` (0 red, 1 green, 2 blue), where the geometry is taken.
pub fn channel_nm(c: usize) -> f64 {
    BANDS_NM[c][1]
}

/// A light given by position and energy rather than found in the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlareLight {
    /// Position in the image's pixels (x right, y down, pixel centres at +0.5); may lie outside
    /// the frame.
    pub x_px: f64,
    pub y_px: f64,
    /// Energy per channel: the sum of the scene values of the pixels it would cover (value x
    /// pixels), before the exposure.
    pub energy: [f64; 3],
    /// Its visible area in pixels (at least 1).
    pub area_px: f64,
}

impl FlareLight {
    /// A white light of `energy` per channel covering one pixel.
    pub fn white(x_px: f64, y_px: f64, energy: f64) -> FlareLight {
        FlareLight { x_px, y_px, energy: [energy; 3], area_px: 1.0 }
    }

    /// Every number finite, the energy non-negative and the area at least 0.
    pub fn is_valid(&self) -> bool {
        [self.x_px, self.y_px, self.area_px].iter().chain(&self.energy).all(|v| v.is_finite())
            && self.energy.iter().all(|&e| e >= 0.0)
            && self.area_px >= 0.0
    }
}

/// The aperture of a lens for flare: n blades (< 3: circular) with rotation and blade
/// curvature, as the bokeh passes draw it (glsl/include/aperture.glsl): corners on the circle
/// of radius r; rotation 0 puts a corner straight up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AperturePolygon {
    pub blades: u32,
    pub rotation_rad: f64,
    /// 0 straight blades .. 1 circular.
    pub curvature: f64,
}

impl AperturePolygon {
    pub const CIRCLE: AperturePolygon = AperturePolygon { blades: 0, rotation_rad: 0.0, curvature: 1.0 };

    /// Straight blades (or a circle below 3 blades).
    pub fn is_polygon(&self) -> bool {
        self.blades >= 3 && self.curvature < 1.0
    }

    /// Signed distance from offset `o` (x right, y down) to the edge of the aperture of
    /// circumradius `r`, negative inside: the f64 form of glsl/include/aperture.glsl's
    /// `aperture_sdf` (a blend of the polygon's and the circle's distances by the curvature).
    pub fn sdf(&self, o: [f64; 2], r: f64) -> f64 {
        let len = (o[0] * o[0] + o[1] * o[1]).sqrt();
        let d_circle = len - r;
        if !self.is_polygon() {
            return d_circle;
        }
        let sector = 2.0 * std::f64::consts::PI / self.blades as f64;
        let phi = (-o[1]).atan2(o[0]) - (0.5 * std::f64::consts::PI + self.rotation_rad + 0.5 * sector);
        let phi = phi - sector * (phi / sector + 0.5).floor();
        let d_poly = len * phi.cos() - r * (0.5 * sector).cos();
        d_poly + (d_circle - d_poly) * self.curvature
    }

    /// Area of the aperture of circumradius 1: (n/2) sin(2 pi / n) for straight blades, pi for
    /// a circle. Curved blades: along a ray at angle phi from a blade's normal, [`Self::sdf`] is
    /// linear in the distance, so the edge lies at
    ///     R(phi) = ((1 - k) cos(s/2) + k) / ((1 - k) cos(phi) + k),  s = 2 pi / n, k the curvature,
    /// and the area is (n/2) times the integral of R^2 over -s/2..s/2 (Simpson's rule: R is smooth
    /// there; 512 intervals are within 1e-9 of 8192 for 3 to 9 blades).
    pub fn area_factor(&self) -> f64 {
        if !self.is_polygon() {
            return std::f64::consts::PI;
        }
        let (n, k) = (self.blades as f64, self.curvature);
        let sector = 2.0 * std::f64::consts::PI / n;
        if k <= 0.0 {
            return 0.5 * n * sector.sin();
        }
        let rim = (1.0 - k) * (0.5 * sector).cos() + k;
        let r2 = |phi: f64| (rim / ((1.0 - k) * phi.cos() + k)).powi(2);
        let intervals = 512;
        let h = sector / intervals as f64;
        let inner: f64 =
            (1..intervals).map(|i| if i % 2 == 1 { 4.0 } else { 2.0 } * r2(-0.5 * sector + i as f64 * h)).sum();
        let integral = h / 3.0 * (r2(-0.5 * sector) + inner + r2(0.5 * sector));
        0.5 * n * integral
    }

    /// The unit normals (x right, y down) of the blades' edges, outward, one per blade.
    pub fn edge_normals(&self) -> Vec<[f64; 2]> {
        if self.blades < 3 {
            return Vec::new();
        }
        let sector = 2.0 * std::f64::consts::PI / self.blades as f64;
        (0..self.blades)
            .map(|k| {
                let a = 0.5 * std::f64::consts::PI + self.rotation_rad + (k as f64 + 0.5) * sector;
                [a.cos(), -a.sin()]
            })
            .collect()
    }
}

/// Area of the intersection of two disks of radii `r1`, `r2` whose centres are `d` apart.
pub fn disk_overlap_area(r1: f64, r2: f64, d: f64) -> f64 {
    let (r1, r2, d) = (r1.max(0.0), r2.max(0.0), d.abs());
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        let r = r1.min(r2);
        return std::f64::consts::PI * r * r;
    }
    let a1 = ((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1)).clamp(-1.0, 1.0).acos();
    let a2 = ((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2)).clamp(-1.0, 1.0).acos();
    let k = ((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2)).max(0.0);
    r1 * r1 * a1 + r2 * r2 * a2 - 0.5 * k.sqrt()
}

/// A prescription set up for flare: its stop set for the f-number, the image plane where the
/// camera's focus puts it, the coatings' design wavelength and the aperture's shape.
#[derive(Clone, Debug)]
pub struct FlareLens {
    /// The prescription with its stop set for the f-number.
    pub prescription: Prescription,
    /// Axial position of the sensor (z from the first vertex, mm).
    pub image_z_mm: f64,
    /// Design wavelength of the single-layer quarter-wave coatings of the air|glass surfaces;
    /// None: uncoated.
    pub coating_design_nm: Option<f64>,
    pub aperture: AperturePolygon,
}

impl FlareLens {
    /// `prescription` stopped to `f_number`, its sensor at the d-line focus for infinity moved
    /// back by `extension_mm` (a lens focused closer moves away from the sensor by v - f).
    pub fn new(
        prescription: &Prescription,
        f_number: f64,
        extension_mm: f64,
        coating_design_nm: Option<f64>,
        aperture: AperturePolygon,
    ) -> FlareLens {
        let stopped = prescription.with_f_number(f_number);
        let par = stopped.paraxial(crate::optics::prescription::LAMBDA_D_NM);
        FlareLens { image_z_mm: par.rear_focal_z_mm + extension_mm, prescription: stopped, coating_design_nm, aperture }
    }

    /// Indices of the media before and after surface `k` at `lambda_nm`.
    pub fn media(&self, k: usize, lambda_nm: f64) -> (f64, f64) {
        let s = &self.prescription.surfaces;
        let before = if k == 0 { 1.0 } else { s[k - 1].index_at(lambda_nm) };
        (before, s[k].index_at(lambda_nm))
    }

    /// Surface `k` reflects (its two media differ; the stop and air gaps do not).
    pub fn reflects(&self, k: usize) -> bool {
        let (a, b) = self.media(k, crate::optics::prescription::LAMBDA_D_NM);
        a != b
    }

    /// The coating of surface `k`: air|glass surfaces are coated (their design indices at the
    /// design wavelength); cemented glass|glass surfaces are not.
    pub fn layer(&self, k: usize) -> Option<coating::Layer> {
        let design = self.coating_design_nm?;
        let (a, b) = self.media(k, design);
        (a != b && (a == 1.0 || b == 1.0)).then(|| coating::Layer::quarter_wave(a, b, design))
    }

    /// Reflectance of surface `k` for light arriving from its front (`from_front`, travelling
    /// towards the sensor) or from its back, at incidence cosine `cos_in`.
    pub fn reflectance(&self, k: usize, from_front: bool, cos_in: f64, lambda_nm: f64) -> f64 {
        let (before, after) = self.media(k, lambda_nm);
        let (n_in, n_out) = if from_front { (before, after) } else { (after, before) };
        if n_in == n_out {
            return 0.0;
        }
        coating::reflectance(n_in, n_out, cos_in, lambda_nm, self.layer(k))
    }

    /// Semi-diameter of the stop.
    pub fn stop_radius_mm(&self) -> f64 {
        self.prescription.surfaces[self.prescription.stop_index()].semi_diameter_mm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aperture_area_and_normals() {
        let hexagon = AperturePolygon { blades: 6, rotation_rad: 0.0, curvature: 0.0 };
        assert!((hexagon.area_factor() - 1.5 * 3f64.sqrt()).abs() < 1e-12);
        assert_eq!(AperturePolygon::CIRCLE.area_factor(), std::f64::consts::PI);
        // Curved blades lie between the polygon and the circle, and their polar integral agrees
        // with a count of the sdf's inside on a grid of 1024 x 1024 over the unit square (the
        // count's own error: a few 1e-4; 6 blades at k = 0.5 give 2.86591 there, 2.866028 on a
        // grid of 6000 x 6000, 2.8660254 integrated).
        let grid_area = |a: AperturePolygon| {
            let steps = 1024;
            let h = 2.0 / steps as f64;
            let inside = (0..steps * steps)
                .filter(|i| {
                    let (x, y) = ((i % steps) as f64 + 0.5, (i / steps) as f64 + 0.5);
                    a.sdf([x * h - 1.0, y * h - 1.0], 1.0) < 0.0
                })
                .count();
            inside as f64 * h * h
        };
        for (blades, curvature) in [(6, 0.5), (9, 0.3), (5, 0.9)] {
            let a = AperturePolygon { blades, rotation_rad: 0.4, curvature };
            let straight = AperturePolygon { curvature: 0.0, ..a }.area_factor();
            let area = a.area_factor();
            assert!(area > straight && area < std::f64::consts::PI, "{blades} blades, k {curvature}: {area}");
            assert!((area - grid_area(a)).abs() < 5e-4, "{blades} blades, k {curvature}: {area} vs {}", grid_area(a));
        }
        let nearly_straight = AperturePolygon { curvature: 1e-9, ..hexagon }.area_factor();
        assert!((nearly_straight - hexagon.area_factor()).abs() < 1e-8, "{nearly_straight}");
        let nearly_round = AperturePolygon { curvature: 1.0 - 1e-9, ..hexagon }.area_factor();
        assert!((nearly_round - std::f64::consts::PI).abs() < 1e-8, "{nearly_round}");
        // Rotation 0 puts a corner straight up: (0, -1) is on the edge, the first normal is
        // half a sector (30 degrees) to the left of straight up.
        assert!(hexagon.sdf([0.0, -1.0], 1.0).abs() < 1e-12);
        let n = hexagon.edge_normals();
        assert_eq!(n.len(), 6);
        let a = (120.0f64).to_radians();
        assert!((n[0][0] - a.cos()).abs() < 1e-12 && (n[0][1] + a.sin()).abs() < 1e-12);
        // The apothem along each normal.
        for e in &n {
            assert!((hexagon.sdf([e[0] * 0.75, e[1] * 0.75], 1.0) - (0.75 - 30f64.to_radians().cos())).abs() < 1e-12);
        }
    }

    #[test]
    fn disk_overlap_at_the_limits_and_in_between() {
        use std::f64::consts::PI;
        assert_eq!(disk_overlap_area(1.0, 2.0, 3.5), 0.0);
        assert!((disk_overlap_area(1.0, 2.0, 0.5) - PI).abs() < 1e-12);
        // Equal unit disks one radius apart: 2 pi / 3 - sqrt(3) / 2.
        assert!((disk_overlap_area(1.0, 1.0, 1.0) - (2.0 * PI / 3.0 - 0.75f64.sqrt())).abs() < 1e-12);
        // Continuous where one disk starts to leave the other.
        assert!((disk_overlap_area(1.0, 2.0, 1.0 - 1e-9) - disk_overlap_area(1.0, 2.0, 1.0 + 1e-9)).abs() < 1e-6);
    }
}
