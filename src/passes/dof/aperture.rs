//! The aperture shared by every bokeh pass: the push-constant form ([`ApertureConstants`], the
//! `Aperture` struct of glsl/include/aperture.glsl) of the camera's
//! [`ApertureShape`](crate::model::aperture::ApertureShape), and the CPU twins of that file's
//! functions.

use crate::gpu::{GpuBuffer, GpuImage, GpuResult, Recorder};
use crate::model::aperture::ApertureShape;
use ash::vk;
use std::sync::Arc;

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
    /// mix(cos(pi/n), 1, curvature): with the shape table's g(o), the signed distance to the
    /// edge of the aperture image of circumradius r is g(o) - r shape_b.
    pub shape_b: f32,
    /// The aperture image's area over r^2 (aperture_area).
    pub area_factor: f32,
    /// The shape table covers offsets with |x|, |y| <= this; 0: no table (every weight takes
    /// the general path). Set by [`ApertureConstants::with_shape_table`].
    pub shape_radius: i32,
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
            shape_b: 1.0,
            area_factor: std::f32::consts::PI,
            shape_radius: 0,
        }
        .with_shape_b()
    }

    /// `shape_b` and `area_factor` of the blades and curvature.
    fn with_shape_b(self) -> Self {
        let b = if self.blades < 3 {
            1.0
        } else {
            let half_sector = std::f32::consts::PI / self.blades as f32;
            half_sector.cos() + (1.0 - half_sector.cos()) * self.curvature
        };
        ApertureConstants { shape_b: b, area_factor: aperture_area(1.0, &self), ..self }
    }

    /// These constants with a shape table of offsets up to `radius` (in the units the shader
    /// gathers in), and the table: texel (x + radius, y + radius) holds g((x, y)), the support
    /// of the aperture's outline in the direction of (x, y) scaled by |(x, y)|: |o| mix(cos phi,
    /// 1, curvature), phi the angle from the nearest blade edge's normal (f64, then f32).
    pub fn with_shape_table(self, radius: u32) -> (Self, Vec<f32>) {
        let r = radius as i32;
        let mut table = Vec::with_capacity(((2 * r + 1) * (2 * r + 1)) as usize);
        for y in -r..=r {
            for x in -r..=r {
                table.push(self.shape_g(x, y));
            }
        }
        (ApertureConstants { shape_radius: r, ..self }, table)
    }

    /// g(o) of the shape table for the integer offset (x right, y down).
    fn shape_g(&self, x: i32, y: i32) -> f32 {
        let len = ((x * x + y * y) as f64).sqrt();
        if self.blades < 3 {
            return len as f32;
        }
        let sector = 2.0 * std::f64::consts::PI / self.blades as f64;
        let mut phi =
            (-(y as f64)).atan2(x as f64) - (0.5 * std::f64::consts::PI + self.rotation as f64 + 0.5 * sector);
        phi -= sector * (phi / sector + 0.5).floor();
        let c = self.curvature as f64;
        (len * (phi.cos() * (1.0 - c) + c)) as f32
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

    /// The same aperture in the pixel units of pyramid level `level` (1/2^level resolution).
    pub fn at_level(&self, level: u32) -> Self {
        let s = 0.5f32.powi(level as i32);
        ApertureConstants {
            sa_max_coc_px: s * self.sa_max_coc_px,
            sa_lsa_coc_px: s * self.sa_lsa_coc_px,
            centre_x_px: s * self.centre_x_px,
            centre_y_px: s * self.centre_y_px,
            cats_eye_per_px: self.cats_eye_per_px / s,
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

/// The weight of aperture_weight_at in glsl/include/aperture.glsl: from the shape table
/// (`data.shape`, of half-size `p.shape_radius`) for an integer offset `o`, the general
/// [`aperture_weight`] (with the aperture image `data.mask`) otherwise.
pub fn aperture_weight_at(
    o: [i32; 2],
    r: f32,
    p: &ApertureConstants,
    sample_px: [f32; 2],
    flip: f32,
    ramp: f32,
    data: &ApertureData,
) -> f32 {
    let (mask, table) = (&data.mask[..], &data.shape[..]);
    let with_mask = mask.first().copied().unwrap_or(0.0) > 0.0 && r > 1.0;
    let in_table = p.shape_radius > 0 && o[0].abs() <= p.shape_radius && o[1].abs() <= p.shape_radius;
    if !in_table || p.cats_eye_per_px > 0.0 || with_mask {
        return aperture_weight([o[0] as f32, o[1] as f32], r, p, sample_px, flip, ramp, mask);
    }
    let limit = r + 0.5 * ramp;
    if ((o[0] * o[0] + o[1] * o[1]) as f32) >= limit * limit {
        return 0.0;
    }
    let side = 2 * p.shape_radius + 1;
    let g = table[((o[1] + p.shape_radius) * side + o[0] + p.shape_radius) as usize];
    let cov = (0.5 - (g - r * p.shape_b) / ramp).clamp(0.0, 1.0);
    cov / (p.area_factor * r * r)
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
/// aberration: sa_weight of glsl/include/aperture.glsl (1 without it).
pub fn sa_weight(o: [f32; 2], radius_q: f32, coc_q: f32, p: &ApertureConstants) -> f32 {
    if p.sa_amount == 0.0 && p.sa_lsa_coc_px == 0.0 {
        return 1.0;
    }
    let r_norm = (o[0] * o[0] + o[1] * o[1]).sqrt() / radius_q;
    crate::optics::spherical::intensity(p.sa_strength(coc_q), r_norm as f64) as f32
}

/// The gather's rule for one tap, shared by the CPU twins of the exact gather
/// (glsl/include/gather.glsl) and of the pyramid levels' gather (glsl/dof/dof_level_gather.comp):
/// the weight with which a sample of signed CoC `coc_q` at offset (dx, dy) from a pixel of CoC
/// `coc_p` reaches it, or 0. A sample behind the pixel spreads no farther than the pixel's own
/// CoC; the aperture's image is upright behind the focus plane and inverted in front.
/// `sample_px` is the sample's centre in the gather's pixel units.
pub fn tap_weight(
    d: [i32; 2],
    coc_p: f32,
    coc_q: f32,
    p: &ApertureConstants,
    sample_px: [f32; 2],
    data: &ApertureData,
) -> f32 {
    tap_weight_at_reach(d, gather_reach(coc_p, coc_q), coc_q, p, sample_px, data)
}

/// How far sample q reaches pixel p in the gathers: its own radius, or p's where q lies behind p
/// (occlusion: a sample behind a pixel reaches it no farther than the pixel's own CoC).
pub fn gather_reach(coc_p: f32, coc_q: f32) -> f32 {
    let radius_p = (0.5 * coc_p.abs()).max(0.5);
    let radius_q = (0.5 * coc_q.abs()).max(0.5);
    if coc_q > coc_p {
        radius_q.min(radius_p)
    } else {
        radius_q
    }
}

/// [`tap_weight`] for a given reach (the level gathers shorten it by the pyramid's own blur).
pub fn tap_weight_at_reach(
    d: [i32; 2],
    reach: f32,
    coc_q: f32,
    p: &ApertureConstants,
    sample_px: [f32; 2],
    data: &ApertureData,
) -> f32 {
    let radius_q = (0.5 * coc_q.abs()).max(0.5);
    if ((d[0] * d[0] + d[1] * d[1]) as f32) > (reach + 1.0) * (reach + 1.0) {
        return 0.0;
    }
    let flip = if coc_q < 0.0 { -1 } else { 1 };
    let o = [-d[0] * flip, -d[1] * flip];
    aperture_weight_at(o, reach, p, sample_px, flip as f32, 1.0, data)
        * sa_weight([o[0] as f32, o[1] as f32], radius_q, coc_q, p)
}

/// The gathers' taps around a pixel (glsl/include/gather.glsl, glsl/dof/dof_level_gather.comp): the
/// disc of radius `tap_disc_px` ([`ApertureData::tap_disc_px`]; negative: none), row by row as
/// `(dy, half_width)`, in the shaders' f32 arithmetic.
pub fn tap_disc_rows(tap_disc_px: f32) -> impl Iterator<Item = (i32, i32)> {
    let r = tap_disc_px.floor() as i32;
    (-r..=r).map(move |dy| (dy, (tap_disc_px * tap_disc_px - (dy * dy) as f32).sqrt().floor() as i32))
}

/// The aperture's data on the CPU: the user's aperture image ([`mask_buffer_data`]) and the
/// shape table ([`ApertureConstants::with_shape_table`]) of a depth-of-field run.
#[derive(Clone, Debug, PartialEq)]
pub struct ApertureData {
    pub mask: Vec<f32>,
    pub shape: Vec<f32>,
    pub shape_radius: u32,
}

impl ApertureData {
    /// The camera's aperture image, and a shape table for `constants` covering offsets up to
    /// `shape_radius`; returns the constants that name the table.
    pub fn new(
        constants: ApertureConstants,
        mask: Option<&crate::model::aperture::ApertureMask>,
        shape_radius: u32,
    ) -> (ApertureConstants, ApertureData) {
        let (constants, shape) = constants.with_shape_table(shape_radius);
        (constants, ApertureData { mask: mask_buffer_data(mask), shape, shape_radius })
    }

    /// The specialization constants of glsl/include/aperture.glsl for this aperture:
    /// [APERTURE_GENERAL, APERTURE_ABERRATION]. The general path is needed only for the user's
    /// aperture image, the cat's eye, or without a shape table (the table is sized to the
    /// largest reach, [`shape_radius_for`], so no weighted offset lies beyond it); the
    /// aberration only when either model of it is non-zero. A pipeline compiled with a path
    /// off gives the same weights as the general one for such an aperture.
    pub fn specialization(&self, constants: &ApertureConstants) -> [u32; 2] {
        let general = self.mask.first().is_some_and(|&size| size > 0.0)
            || constants.cats_eye_per_px > 0.0
            || constants.shape_radius <= 0
            || self.shape_radius == 0;
        let aberration = constants.sa_amount != 0.0 || constants.sa_lsa_coc_px != 0.0;
        [general as u32, aberration as u32]
    }

    /// The radius of the disc of offsets at which samples reaching at most `reach_px` can weigh
    /// (tap_disc_px in glsl/include/aperture.glsl): half a pixel beyond the reach (the coverage
    /// ramp, [`aperture_weight_at`]), a pixel with the user's aperture image; every reach is
    /// at least 0.5.
    pub fn tap_disc_px(&self, reach_px: f32) -> f32 {
        let image = self.mask.first().is_some_and(|&size| size > 0.0);
        reach_px.max(0.5) + if image { 1.0 } else { 0.5 }
    }

    /// The data back from a shader's bindings (twins): the mask buffer and the shape image.
    pub fn from_bindings(mask: &crate::gpu::HostData, shape: &crate::gpu::HostData, shape_radius: i32) -> ApertureData {
        ApertureData {
            mask: crate::passes::twin::floats(mask.words()),
            shape: shape.image().texels.clone(),
            shape_radius: shape_radius.max(0) as u32,
        }
    }

    /// Upload both: the mask as a storage buffer, the shape table as an R32F image (each with
    /// the upload's own barrier to compute reads).
    pub fn upload(&self, rec: &mut Recorder) -> GpuResult<(Arc<GpuBuffer>, Arc<GpuImage>)> {
        let mask = rec.upload_buffer("aperture image", &self.mask)?;
        let side = 2 * self.shape_radius + 1;
        let shape = rec.create_image("aperture shape table", side, side, vk::Format::R32_SFLOAT)?;
        rec.upload_images(&[(&shape, &self.shape)])?;
        Ok((mask, shape))
    }
}

/// The largest offset (px) an exact gather or a sprite of the largest CoC `max_abs_coc_px`
/// reaches, plus the anti-aliasing ramp: the shape table's radius.
pub fn shape_radius_for(max_abs_coc_px: f64) -> u32 {
    (0.5 * max_abs_coc_px).ceil().max(0.0) as u32 + 2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::aperture::{ApertureMask, ApertureShape, MASK_SIZE};

    fn specialization(shape: ApertureShape, mask: Option<&ApertureMask>, shape_radius: u32) -> [u32; 2] {
        let constants = ApertureConstants::new(&shape, 40.0, [64.0, 36.0], 128, 72);
        let (constants, data) = ApertureData::new(constants, mask, shape_radius);
        data.specialization(&constants)
    }

    /// sa_intensity of glsl/include/aperture.glsl in f32: `steps` Newton steps from rho = r.
    fn shader_sa_intensity(r: f32, s: f32, steps: u32) -> f32 {
        let mut rho = r;
        for _ in 0..steps {
            let f = rho + s * rho * rho * rho - (1.0 + s) * r;
            rho = (rho - f / (1.0 + 3.0 * s * rho * rho)).clamp(0.0, 1.0);
        }
        (1.0 + s) * (1.0 + s) / ((1.0 + s * rho * rho) * (1.0 + 3.0 * s * rho * rho))
    }

    /// The largest relative error of `steps` shader steps against the f64 root for strengths
    /// |s| <= `s_max` (0.3 is the shader's SA_MAX_STRENGTH) over the whole radius.
    fn worst_sa_error(steps: u32, s_max: f64) -> f64 {
        let mut worst = 0.0f64;
        for i in 0..=120 {
            let s = s_max * (i as f64 / 60.0 - 1.0);
            for j in 0..=2000 {
                let r = j as f64 / 2000.0;
                let exact = crate::optics::spherical::intensity(s, r);
                let got = shader_sa_intensity(r as f32, s as f32, steps) as f64;
                worst = worst.max((got - exact).abs() / exact);
            }
        }
        worst
    }

    #[test]
    fn sa_newton_steps_reach_the_f64_root() {
        use crate::gpu::shaders::aperture::{SA_NEWTON_STEPS, SA_NEWTON_STEPS_WEAK};
        // Each count leaves only f32 rounding over its range of strengths (the error of twice
        // as many steps); one step fewer does not. The shader takes the weak count for |s| <= 0.1.
        for (steps, s_max) in [(SA_NEWTON_STEPS, 0.3), (SA_NEWTON_STEPS_WEAK, 0.1)] {
            let (chosen, twice) = (worst_sa_error(steps, s_max), worst_sa_error(2 * steps, s_max));
            assert!(chosen < 1.5e-5 && chosen <= twice * 1.01, "{steps} steps to |s| {s_max}: {chosen:e} ({twice:e})");
            let fewer = worst_sa_error(steps - 1, s_max);
            assert!(fewer > 1e-4, "{} steps would do to |s| {s_max}: {fewer:e}", steps - 1);
        }
    }

    #[test]
    fn only_a_lens_that_needs_a_path_gets_its_pipeline() {
        let hexagon = ApertureShape { blades: 6, curvature: 0.0, ..ApertureShape::CIRCLE };
        // An ideal lens's bladed aperture: every weight from the shape table, no aberration.
        assert_eq!(specialization(hexagon, None, 22), [0, 0]);
        // Without a table every weight takes the general path.
        assert_eq!(specialization(hexagon, None, 0), [1, 0]);
        // The cat's eye and the user's aperture image are general paths.
        assert_eq!(specialization(ApertureShape { cats_eye: 0.3, ..hexagon }, None, 22), [1, 0]);
        let mask = ApertureMask { values: vec![1.0; (MASK_SIZE * MASK_SIZE) as usize], mean: 1.0 };
        assert_eq!(specialization(hexagon, Some(&mask), 22), [1, 0]);
        // Either model of spherical aberration keeps its weight.
        assert_eq!(specialization(ApertureShape { spherical_aberration: 0.4, ..hexagon }, None, 22), [0, 1]);
        let traced =
            ApertureConstants { sa_lsa_coc_px: -3.0, ..ApertureConstants::new(&hexagon, 40.0, [0.0; 2], 8, 8) };
        let (traced, data) = ApertureData::new(traced, None, 22);
        assert_eq!(data.specialization(&traced), [0, 1]);
    }

    /// The gathers' tap disc holds every offset at which a sample of any reach up to its
    /// bound weighs, for bladed, round and cat's-eye apertures and the user's aperture image,
    /// in front of and behind the focus plane; and it is tighter than the whole-pixel disc
    /// (ceil(reach) + 1) the gathers took before.
    #[test]
    fn the_tap_disc_holds_every_tap_that_weighs() {
        let hexagon = ApertureShape { blades: 6, curvature: 0.0, ..ApertureShape::CIRCLE };
        let mask = ApertureMask { values: vec![1.0; (MASK_SIZE * MASK_SIZE) as usize], mean: 1.0 };
        let apertures = [
            (hexagon, None),
            (ApertureShape { blades: 5, curvature: 0.4, rotation_deg: 17.0, ..hexagon }, None),
            (ApertureShape::CIRCLE, None),
            (ApertureShape { cats_eye: 0.5, ..hexagon }, None),
            (hexagon, Some(&mask)),
        ];
        for (shape, mask) in apertures {
            let constants = ApertureConstants::new(&shape, 40.0, [0.0, 0.0], 64, 64);
            let (constants, data) = ApertureData::new(constants, mask, shape_radius_for(2.0 * 6.0));
            let (mut disc_taps, mut whole_pixel_taps) = (0, 0);
            for quarter in 0..=24 {
                let reach_max = quarter as f32 * 0.25;
                let rows: Vec<(i32, i32)> = tap_disc_rows(data.tap_disc_px(reach_max)).collect();
                let in_disc = |d: [i32; 2]| rows.iter().any(|&(dy, half)| dy == d[1] && d[0].abs() <= half);
                disc_taps += rows.iter().map(|&(_, half)| 2 * half + 1).sum::<i32>();
                let r = reach_max.ceil() as i32 + 1;
                whole_pixel_taps += (-r..=r).map(|dy| 2 * ((r * r - dy * dy) as f32).sqrt() as i32 + 1).sum::<i32>();
                // Samples of CoCs whose reach is within the bound (both ends exactly), at a pixel
                // of CoC 0 and at one behind them all.
                let steps = 20 * quarter;
                let cocs = (0..=steps).map(|i| 2.0 * reach_max * (2.0 * i as f32 / steps.max(1) as f32 - 1.0));
                for coc_q in cocs.chain([-2.0 * reach_max, 2.0 * reach_max]) {
                    for dy in -8..=8 {
                        for dx in -8..=8 {
                            let w = tap_weight([dx, dy], 0.0, coc_q, &constants, [30.5 + dx as f32, 20.5], &data);
                            let w_behind =
                                tap_weight([dx, dy], 2.0 * reach_max, coc_q, &constants, [30.5, 20.5], &data);
                            assert!(
                                (w <= 0.0 && w_behind <= 0.0) || in_disc([dx, dy]),
                                "{shape:?} mask {}: CoC {coc_q} weighs at ({dx}, {dy}) outside the disc of reach {reach_max}",
                                mask.is_some()
                            );
                        }
                    }
                }
            }
            assert!(disc_taps < whole_pixel_taps, "{disc_taps} taps against {whole_pixel_taps}");
        }
    }
}
