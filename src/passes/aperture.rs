//! The aperture shared by every bokeh pass: the push-constant form ([`ApertureConstants`], the
//! `Aperture` struct of glsl/include/aperture.glsl) of the camera's
//! [`ApertureShape`](crate::model::aperture::ApertureShape), and the CPU twins of that file's
//! functions.

use crate::model::aperture::ApertureShape;

/// The `Aperture` struct of glsl/include/aperture.glsl: part of every bokeh pass's push
/// constants (4-byte fields only, no padding).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ApertureConstants {
    pub blades: i32,
    pub rotation: f32,
    pub curvature: f32,
    pub sa_amount: f32,
    /// The CoC diameter at which spherical aberration reaches its full amount (the user's CoC
    /// clamp, like the appendix shader's largest CoC).
    pub sa_max_coc_px: f32,
    pub centre_x_px: f32,
    pub centre_y_px: f32,
    pub cats_eye_per_px: f32,
    /// Traced spherical aberration: the rim's focus shift seen as a signed CoC (px),
    /// -LSA / (N' P pitch); 0: the amount model (sa_amount) instead.
    pub sa_lsa_coc_px: f32,
}

impl ApertureConstants {
    /// The traced spherical aberration (`sa_lsa_coc_px`) starts at 0; the planner sets it, as it
    /// depends on the pixel pitch.
    pub fn new(shape: &ApertureShape, sa_max_coc_px: f64, centre_px: [f64; 2], width: u32, height: u32) -> Self {
        ApertureConstants {
            blades: shape.blades as i32,
            rotation: shape.rotation_deg.to_radians() as f32,
            curvature: if shape.blades < 3 { 1.0 } else { shape.curvature.clamp(0.0, 1.0) as f32 },
            sa_amount: shape.spherical_aberration as f32,
            sa_max_coc_px: sa_max_coc_px as f32,
            centre_x_px: centre_px[0] as f32,
            centre_y_px: centre_px[1] as f32,
            cats_eye_per_px: shape.cats_eye_per_px(width, height, centre_px) as f32,
            sa_lsa_coc_px: 0.0,
        }
    }

    /// What of the aperture depends on the pixel pitch: traced spherical aberration (the rim's
    /// focus shift seen as a CoC, src/optics/spherical.rs) and a cat's eye given at an image
    /// height, growing linearly from the centre (per pixel).
    pub fn with_pitch(mut self, camera: &crate::model::camera::Camera, pixel_pitch_mm: f64) -> Self {
        if let Some(lsa_mm) = camera.aperture.lsa_rim_mm {
            let n = camera.lens.effective_f_number() * camera.lens.pupil_magnification;
            self.sa_lsa_coc_px = (-lsa_mm / (n * pixel_pitch_mm)) as f32;
        }
        if let Some(h_mm) = camera.aperture.cats_eye_at_mm {
            self.cats_eye_per_px = (camera.aperture.cats_eye.clamp(0.0, 1.0) * pixel_pitch_mm / h_mm) as f32;
        }
        self
    }

    /// Spherical-aberration strength s of src/optics/spherical.rs for a sample of signed CoC.
    pub fn sa_strength(&self, coc_px: f32) -> f64 {
        if self.sa_lsa_coc_px != 0.0 {
            crate::optics::spherical::strength_traced(self.sa_lsa_coc_px as f64, coc_px as f64)
        } else {
            crate::optics::spherical::strength(self.sa_amount as f64, coc_px as f64, self.sa_max_coc_px as f64)
        }
    }

    /// The same aperture in half-resolution pixel units.
    pub fn half_resolution(&self) -> Self {
        ApertureConstants {
            sa_max_coc_px: 0.5 * self.sa_max_coc_px,
            sa_lsa_coc_px: 0.5 * self.sa_lsa_coc_px,
            centre_x_px: 0.5 * self.centre_x_px,
            centre_y_px: 0.5 * self.centre_y_px,
            cats_eye_per_px: 2.0 * self.cats_eye_per_px,
            ..*self
        }
    }
}

/// The aperture image's storage buffer (glsl/include/aperture.glsl): [size, mean, size x size
/// values], or [0, 0] for none.
pub fn mask_buffer_data(mask: Option<&crate::model::aperture::ApertureMask>) -> Vec<f32> {
    match mask {
        None => vec![0.0, 0.0],
        Some(m) => {
            let mut data = vec![crate::model::aperture::MASK_SIZE as f32, m.mean];
            data.extend_from_slice(&m.values);
            data
        }
    }
}

/// Signed distance to the aperture image of circumradius r (glsl/include/aperture.glsl).
pub fn aperture_sdf(o: [f32; 2], r: f32, p: &ApertureConstants) -> f32 {
    let len = (o[0] * o[0] + o[1] * o[1]).sqrt();
    let d_circle = len - r;
    if p.blades < 3 || p.curvature >= 1.0 {
        return d_circle;
    }
    let sector = 2.0 * std::f32::consts::PI / p.blades as f32;
    let mut phi = (-o[1]).atan2(o[0]) - (0.5 * std::f32::consts::PI + p.rotation + 0.5 * sector);
    phi -= sector * (phi / sector + 0.5).floor();
    let d_poly = len * phi.cos() - r * (0.5 * sector).cos();
    d_poly + (d_circle - d_poly) * p.curvature
}

pub fn aperture_area(r: f32, p: &ApertureConstants) -> f32 {
    let circle = std::f32::consts::PI * r * r;
    if p.blades < 3 {
        return circle;
    }
    let n = p.blades as f32;
    let polygon = 0.5 * n * r * r * (2.0 * std::f32::consts::PI / n).sin();
    polygon + (circle - polygon) * p.curvature
}

/// The aperture image, bilinear, at uv in [-1, 1]^2 (mask_value in glsl/include/aperture.glsl).
pub fn mask_value(mask: &[f32], uv: [f32; 2]) -> f32 {
    let n = mask[0] as i32;
    let texel = |x: i32, y: i32| if x < 0 || y < 0 || x >= n || y >= n { 0.0 } else { mask[2 + (y * n + x) as usize] };
    let t = [(uv[0] * 0.5 + 0.5) * n as f32 - 0.5, (uv[1] * 0.5 + 0.5) * n as f32 - 0.5];
    let (i, j) = (t[0].floor() as i32, t[1].floor() as i32);
    let (fx, fy) = (t[0] - i as f32, t[1] - j as f32);
    let top = texel(i, j) + (texel(i + 1, j) - texel(i, j)) * fx;
    let bottom = texel(i, j + 1) + (texel(i + 1, j + 1) - texel(i, j + 1)) * fx;
    top + (bottom - top) * fy
}

/// Coverage over area of a sample's aperture image, with the cat's eye
/// (aperture_weight in glsl/include/aperture.glsl): the edge is a linear ramp `ramp` px wide.
pub fn aperture_weight(
    o: [f32; 2],
    r: f32,
    p: &ApertureConstants,
    sample_px: [f32; 2],
    flip: f32,
    ramp: f32,
    mask: &[f32],
) -> f32 {
    let (mut cov, mut area);
    if mask.first().copied().unwrap_or(0.0) > 0.0 && r > 1.0 {
        let (c, s) = (p.rotation.cos(), p.rotation.sin());
        let up = [o[0], -o[1]];
        let turned = [c * up[0] + s * up[1], -s * up[0] + c * up[1]];
        cov = mask_value(mask, [turned[0] / r, -turned[1] / r]);
        area = mask[1] * 4.0 * r * r;
    } else {
        // Nothing beyond the circumscribed circle's ramp.
        let limit = r + 0.5 * ramp;
        if o[0] * o[0] + o[1] * o[1] >= limit * limit {
            return 0.0;
        }
        cov = (0.5 - aperture_sdf(o, r, p) / ramp).clamp(0.0, 1.0);
        area = aperture_area(r, p);
    }
    if p.cats_eye_per_px > 0.0 && cov > 0.0 {
        let k = p.cats_eye_per_px * r * flip;
        let c = [(p.centre_x_px - sample_px[0]) * k, (p.centre_y_px - sample_px[1]) * k];
        let d = (c[0] * c[0] + c[1] * c[1]).sqrt().min(2.0 * r);
        let dist = ((o[0] - c[0]).powi(2) + (o[1] - c[1]).powi(2)).sqrt();
        cov = cov.min((0.5 - (dist - r) / ramp).clamp(0.0, 1.0));
        let h = 0.5 * d / r.max(1e-6);
        let overlap = (2.0 * h.acos() - 2.0 * h * (1.0 - h * h).max(0.0).sqrt()) / std::f32::consts::PI;
        area *= overlap.max(1e-3);
    }
    cov / area
}

/// The weight of a sample of signed CoC `coc_q` at offset `o` (already flipped) for spherical
/// aberration: sa_intensity(|o| / radius_q, sa_strength(coc_q)) of glsl/include/aperture.glsl.
pub fn sa_weight(o: [f32; 2], radius_q: f32, coc_q: f32, p: &ApertureConstants) -> f32 {
    let r_norm = (o[0] * o[0] + o[1] * o[1]).sqrt() / radius_q;
    crate::optics::spherical::intensity(p.sa_strength(coc_q), r_norm as f64) as f32
}
