//! The CoC pass's push constants (the `CocPush` block of glsl/include/coc.glsl): the camera's
//! signed CoC on a frame (Kyaw 2013 eq 5.3, with the field curvature and a channel's offset), and
//! the shaders' f32 arithmetic on them as CPU twins. Read by the coc pass (`coc`), its edge
//! resolve (`coc_edges`) and the planner.
use crate::model::camera::{Camera, CocModel};
use crate::model::frame::Frame;
use crate::optics::ThinLens;

/// Push constants of glsl/dof/coc.comp and glsl/dof/coc_edges.comp (glsl/include/coc.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CocPush {
    pub size: [i32; 2],
    /// v^2 / (N' P) / pixel pitch: eq 5.3 is C_px = coc_scale_px_mm * (1/S - 1/u).
    pub coc_scale_px_mm: f32,
    pub inv_focus_distance_per_mm: f32,
    pub max_coc_px: f32,
    pub mm_per_depth_unit: f32,
    pub centre_px: [f32; 2],
    pub pixel_pitch_mm: f32,
    pub image_distance_mm: f32,
    pub inv_focal_length_per_mm: f32,
    /// v / (N' P) / pixel pitch: eq 5.3 is C_px = aperture_px (v w - 1), w = 1/f - 1/u.
    pub aperture_px: f32,
    /// Entries of the field-curvature table; 0: none.
    pub entries: i32,
    /// Added to the signed CoC (longitudinal colour: a channel focusing behind or in front of
    /// green); 0 for green.
    pub coc_offset_px: f32,
    /// 1: each pixel at an anti-aliased depth edge takes the depth of the layer that brings most
    /// of its light (glsl/dof/coc_edges.comp); 0: the depth as stored.
    pub resolve_edges: i32,
}

/// The field-curvature buffer: heights, then offsets in mm; `[0]` for none.
pub fn table_data(table: Option<&crate::optics::distortion::HeightTable>) -> Vec<f32> {
    match table {
        None => vec![0.0],
        Some(t) => t.image_height_mm.iter().chain(&t.values).map(|&v| v as f32).collect(),
    }
}

impl CocPush {
    /// The camera's CoC on this frame (its size and optical centre), before any channel offset.
    pub fn for_frame(camera: &Camera, pixel_pitch_mm: f64, frame: &Frame) -> CocPush {
        let push = CocPush::new(
            &camera.lens,
            pixel_pitch_mm,
            crate::passes::scene::coc_clamp_px(camera, pixel_pitch_mm, frame),
            frame.width,
            frame.height,
            frame.centre_px,
            camera.field_curvature.as_ref(),
        );
        let push = CocPush { resolve_edges: camera.resolve_depth_edges as i32, ..push };
        match camera.coc_model {
            CocModel::Physical => push,
            // The renderers' CoC, f^2/N (1/S - 1/u) (ThinLens::coc_renderer_mm); a film offset
            // (field curvature) scales with it: aperture_px v = coc_scale, as in eq 5.3's form.
            CocModel::Renderer => {
                let f = camera.lens.focal_length_mm;
                let scale_px_mm = f * f / camera.lens.f_number / pixel_pitch_mm;
                CocPush {
                    coc_scale_px_mm: scale_px_mm as f32,
                    aperture_px: (scale_px_mm / camera.lens.image_distance_mm()) as f32,
                    ..push
                }
            }
        }
    }

    /// `field_curvature`: the film-plane offset (mm) of the sharp image surface against height,
    /// with the optical centre `centre_px`.
    pub fn new(
        lens: &ThinLens,
        pixel_pitch_mm: f64,
        max_coc_px: f64,
        width: u32,
        height: u32,
        centre_px: [f64; 2],
        field_curvature: Option<&crate::optics::distortion::HeightTable>,
    ) -> CocPush {
        let v_mm = lens.image_distance_mm();
        // Kyaw 2013 eq 5.3: C = v^2 |S - u| / (u S N' P) = v^2/(N' P) * (1/S - 1/u), signed.
        let scale_mm2 = v_mm * v_mm / (lens.effective_f_number() * lens.pupil_magnification);
        CocPush {
            size: [width as i32, height as i32],
            coc_scale_px_mm: (scale_mm2 / pixel_pitch_mm) as f32,
            inv_focus_distance_per_mm: (1.0 / lens.focus_distance_mm) as f32,
            max_coc_px: max_coc_px as f32,
            mm_per_depth_unit: 1000.0,
            centre_px: [centre_px[0] as f32, centre_px[1] as f32],
            pixel_pitch_mm: pixel_pitch_mm as f32,
            image_distance_mm: v_mm as f32,
            inv_focal_length_per_mm: (1.0 / lens.focal_length_mm) as f32,
            aperture_px: (v_mm / (lens.effective_f_number() * lens.pupil_magnification) / pixel_pitch_mm) as f32,
            entries: field_curvature.map_or(0, |t| t.image_height_mm.len() as i32),
            coc_offset_px: 0.0,
            resolve_edges: 0,
        }
    }

    /// The shader's specialization constants for these constants: `RESOLVE_EDGES` and
    /// `FIELD_CURVATURE` (a table of entries), so a run's pipeline holds only its own paths.
    pub fn specialization(&self) -> [u32; 2] {
        [u32::from(self.resolve_edges != 0), u32::from(self.entries > 0)]
    }

    /// glsl/dof/coc_edges.comp's specialization constant: `FIELD_CURVATURE`.
    pub fn edge_specialization(&self) -> [u32; 1] {
        [u32::from(self.entries > 0)]
    }

    /// [`CocPush::specialization`] of every run through `camera` (it depends on the camera
    /// alone: its edge resolve and its field curvature).
    pub fn specialization_for(camera: &Camera) -> [u32; 2] {
        [u32::from(camera.resolve_depth_edges), u32::from(camera.field_curvature.is_some())]
    }

    /// The depth in mm of a depth value as the shader reads it (at least 1e-30).
    pub fn depth_mm(&self, depth_m: f32) -> f32 {
        (depth_m * self.mm_per_depth_unit).max(1.0e-30)
    }

    /// The inverse depth (1/mm) of a depth value as the shader reads it.
    pub fn inverse_depth(&self, depth_m: f32) -> f32 {
        1.0 / self.depth_mm(depth_m)
    }

    /// CPU twin at pixel (x, y) with the field-curvature table (`table_data` layout).
    pub fn coc_px_at(&self, depth_m: f32, x: u32, y: u32, table: &[f32]) -> f32 {
        self.coc_px_of_inverse_depth(self.inverse_depth(depth_m), x, y, table)
    }

    /// The shader's CoC at pixel (x, y) for an inverse depth `inv_u` (1/mm).
    pub fn coc_px_of_inverse_depth(&self, inv_u: f32, x: u32, y: u32, table: &[f32]) -> f32 {
        let n = self.entries as usize;
        let coc = if n == 0 {
            self.coc_scale_px_mm * (self.inv_focus_distance_per_mm - inv_u)
        } else {
            let (dx, dy) = (x as f32 + 0.5 - self.centre_px[0], y as f32 + 0.5 - self.centre_px[1]);
            let h = (dx * dx + dy * dy).sqrt() * self.pixel_pitch_mm;
            let delta = crate::passes::height_table_lookup(table, 1, n, h);
            let w = self.inv_focal_length_per_mm - inv_u;
            self.aperture_px * (self.image_distance_mm * w / (1.0 + delta * w) - 1.0)
        };
        (coc + self.coc_offset_px).clamp(-self.max_coc_px, self.max_coc_px)
    }

    /// CPU twin of the shader for one depth value, in the same f32 arithmetic.
    pub fn coc_px(&self, depth_m: f32) -> f32 {
        let coc = self.coc_scale_px_mm * (self.inv_focus_distance_per_mm - self.inverse_depth(depth_m));
        (coc + self.coc_offset_px).clamp(-self.max_coc_px, self.max_coc_px)
    }
}

/// CPU twin without the edge resolve: the CoC of every pixel from its own depth.
pub fn coc_cpu(depth_m: &[f32], push: &CocPush, table: &[f32]) -> Vec<f32> {
    let w = push.size[0].max(1) as u32;
    depth_m.iter().enumerate().map(|(i, &d)| push.coc_px_at(d, i as u32 % w, i as u32 / w, table)).collect()
}
