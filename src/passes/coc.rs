//! Circle-of-confusion pass: signed CoC diameter in pixels per pixel, from planar depth
//! (Kyaw 2013 eq 5.3). Shader: glsl/coc.comp.

use super::{groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use crate::optics::ThinLens;
use ash::vk;

pub const NAME: &str = "coc";

/// Push constants of glsl/coc.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CocParams {
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
}

/// The field-curvature buffer: heights, then offsets in mm; `[0]` for none.
pub fn table_data(table: Option<&crate::optics::distortion::HeightTable>) -> Vec<f32> {
    match table {
        None => vec![0.0],
        Some(t) => t.image_height_mm.iter().chain(&t.values).map(|&v| v as f32).collect(),
    }
}

impl CocParams {
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
    ) -> CocParams {
        let v_mm = lens.image_distance_mm();
        // Kyaw 2013 eq 5.3: C = v^2 |S - u| / (u S N' P) = v^2/(N' P) * (1/S - 1/u), signed.
        let scale_mm2 = v_mm * v_mm / (lens.effective_f_number() * lens.pupil_magnification);
        CocParams {
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
        }
    }

    /// CPU twin at pixel (x, y) with the field-curvature table (`table_data` layout).
    pub fn coc_px_at(&self, depth_m: f32, x: u32, y: u32, table: &[f32]) -> f32 {
        let n = self.entries as usize;
        if n == 0 {
            return self.coc_px(depth_m);
        }
        let u_mm = depth_m * self.mm_per_depth_unit;
        let inv_u = 1.0 / u_mm.max(1.0e-30);
        let (dx, dy) = (x as f32 + 0.5 - self.centre_px[0], y as f32 + 0.5 - self.centre_px[1]);
        let h = (dx * dx + dy * dy).sqrt() * self.pixel_pitch_mm;
        let delta = super::height_table_lookup(table, 1, n, h);
        let w = self.inv_focal_length_per_mm - inv_u;
        let coc = self.aperture_px * (self.image_distance_mm * w / (1.0 + delta * w) - 1.0);
        (coc + self.coc_offset_px).clamp(-self.max_coc_px, self.max_coc_px)
    }

    /// CPU twin of the shader for one depth value, in the same f32 arithmetic.
    pub fn coc_px(&self, depth_m: f32) -> f32 {
        let u_mm = depth_m * self.mm_per_depth_unit;
        let inv_u = 1.0 / u_mm.max(1.0e-30);
        let coc = self.coc_scale_px_mm * (self.inv_focus_distance_per_mm - inv_u);
        (coc + self.coc_offset_px).clamp(-self.max_coc_px, self.max_coc_px)
    }
}

/// CPU twin: the CoC of every pixel.
pub fn coc_cpu(depth_m: &[f32], params: &CocParams, table: &[f32]) -> Vec<f32> {
    let w = params.size[0].max(1) as u32;
    depth_m.iter().enumerate().map(|(i, &d)| params.coc_px_at(d, i as u32 % w, i as u32 / w, table)).collect()
}

pub struct CocPass {
    pipeline: ComputePipeline,
}

impl CocPass {
    pub fn new(gpu: &Gpu) -> GpuResult<CocPass> {
        let bindings =
            [vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_BUFFER];
        let pipeline =
            ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, std::mem::size_of::<CocParams>() as u32)?;
        Ok(CocPass { pipeline })
    }

    /// `depth` (R32F metres) -> `coc` (R32F signed px).
    pub fn record(
        &self,
        rec: &mut Recorder,
        depth: &GpuImage,
        coc: &GpuImage,
        field_curvature: &GpuBuffer,
        params: &CocParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // depth: written by the upload copy, whose own barrier already made it visible to
        //   compute reads in layout GENERAL; nothing to wait for here.
        // field_curvature: uploaded with its own barrier.
        // coc: written from scratch; discard old contents.
        rec.image_barriers(&[overwrite(coc)]);
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(depth), Bind::Image(coc), Bind::Buffer(field_curvature)],
            push_bytes(params),
            groups_for(depth.width, depth.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::distortion::HeightTable;

    #[test]
    fn field_curvature_blurs_the_focus_plane_off_axis_like_the_geometric_cone() {
        // A point at the focus distance, at image height h where the sharp surface lies delta
        // behind the film: the cone from the exit pupil (diameter v/(N' P)) converging at
        // v + delta meets the film in a disk of diameter D delta / (v + delta), in front of focus
        // (negative). On the axis (delta = 0) the CoC is the plain eq 5.3 value, 0.
        let lens = ThinLens::new(50.0, 2.0, 2000.0).unwrap();
        let pitch_mm = 0.01;
        let table = HeightTable { image_height_mm: vec![0.0, 10.0], values: vec![0.0, 0.2] };
        let p = CocParams::new(&lens, pitch_mm, 1000.0, 2001, 1, [1000.5, 0.5], Some(&table));
        let data = table_data(Some(&table));
        assert!(p.coc_px_at(2.0, 1000, 0, &data).abs() < 1e-3);
        // 500 px right of the centre: h = 5 mm, delta = 0.1 mm.
        let v = lens.image_distance_mm();
        let d = v / lens.effective_f_number();
        let expected_px = -d * 0.1 / (v + 0.1) / pitch_mm;
        let got = p.coc_px_at(2.0, 1500, 0, &data) as f64;
        assert!((got / expected_px - 1.0).abs() < 1e-4, "{got} vs {expected_px}");
        // Without a table the reciprocal form is used: exactly 0 in focus.
        let plain = CocParams::new(&lens, pitch_mm, 1000.0, 2001, 1, [1000.5, 0.5], None);
        assert_eq!(plain.coc_px_at(2.0, 1500, 0, &[0.0]), 0.0);
    }
}
