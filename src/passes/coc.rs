//! Circle-of-confusion pass: signed CoC diameter in pixels per pixel, from planar depth
//! (Kyaw 2013 eq 5.3). Shader: glsl/coc.comp.

use super::barriers::overwrite;
use super::scene::{Channel, PlanInput, VISIBLE_COC_PX};
use super::{groups_for, Decision, FrameImages, Input, Pass};
use crate::gpu::{Gpu, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::model::camera::{BokehMode, Camera};
use crate::model::frame::Frame;
use crate::optics::ThinLens;
use ash::vk;

pub const NAME: &str = "coc";

/// Push constants of glsl/coc.comp.
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
        CocPush::new(
            &camera.lens,
            pixel_pitch_mm,
            camera.max_coc.px(pixel_pitch_mm),
            frame.width,
            frame.height,
            frame.centre_px,
            camera.field_curvature.as_ref(),
        )
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
pub fn coc_cpu(depth_m: &[f32], push: &CocPush, table: &[f32]) -> Vec<f32> {
    let w = push.size[0].max(1) as u32;
    depth_m.iter().enumerate().map(|(i, &d)| push.coc_px_at(d, i as u32 % w, i as u32 / w, table)).collect()
}

crate::shader_bindings! {
    /// The bindings of glsl/coc.comp.
    pub struct CocBindings {
        depth_m: image(depth_m),
        coc_px: image(coc_px),
        field_curvature: buffer(FieldCurvature),
    }
}

/// glsl/coc.comp.
pub struct CocShader;

impl Shader for CocShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = CocBindings<'a>;
    type Push = CocPush;
}

impl Twin for CocShader {
    fn cpu(push: &CocPush, _groups: [u32; 3], b: &mut [HostData]) {
        let table: Vec<f32> = b[2].words().iter().map(|&w| f32::from_bits(w)).collect();
        let coc = coc_cpu(&b[0].image().texels, push, &table);
        b[1].image_mut().texels = coc;
    }
}

/// One run of the pass: its constants, the field-curvature table, and the channel it is for
/// (longitudinal colour runs it once per channel, each with its offset).
#[derive(Clone, Debug)]
pub struct CocParams {
    pub push: CocPush,
    pub table: Vec<f32>,
    pub channel: Option<Channel>,
}

impl CocParams {
    /// One run for all channels.
    pub fn new(push: CocPush, field_curvature: Option<&crate::optics::distortion::HeightTable>) -> CocParams {
        CocParams { push, table: table_data(field_curvature), channel: None }
    }
}

pub struct Coc {
    kernel: Kernel<CocShader>,
}

impl Pass for Coc {
    const NAME: &'static str = NAME;
    const INPUTS: &'static [Input] = &[Input::Depth];
    type Params = CocParams;

    fn plan(input: &PlanInput<'_>) -> Decision<CocParams> {
        let (f, camera) = (&input.facts, input.camera);
        let why = format!(
            "CoC from {:.2} px (nearest, {:.3} m) to {:.2} px (farthest, {:.3e} m) at f/{} focused at {} m",
            f.coc_range_px.0,
            f.depth_range_m.0,
            f.coc_range_px.1,
            f.depth_range_m.1,
            camera.lens.f_number,
            camera.lens.focus_distance_mm / 1000.0
        );
        let why = match f.coc_clamp_note(camera) {
            Some(note) => format!("{why}; {note}"),
            None => why,
        };
        if !f.dof_visible() {
            return Decision::skip(format!(
                "{why}: every CoC is at most {VISIBLE_COC_PX} px, depth of field is invisible"
            ));
        }
        if camera.bokeh == BokehMode::Diffraction {
            // The focus processor maps depth to its tables itself.
            return Decision::skip(format!("{why}; not needed by the focus processor"));
        }
        let base =
            CocParams::new(CocPush::for_frame(camera, f.pixel_pitch_mm, input.frame), camera.field_curvature.as_ref());
        let runs = input
            .dof_runs()
            .into_iter()
            .map(|(channel, offset_px)| CocParams {
                push: CocPush { coc_offset_px: offset_px, ..base.push },
                channel,
                ..base.clone()
            })
            .collect();
        Decision::run_each(runs, why)
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Coc { kernel: Kernel::new(gpu)? })
    }

    /// Depth (R32F metres) -> a new CoC image (R32F signed px) for the run's channel.
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &CocParams) -> GpuResult<()> {
        rec.begin_pass(NAME);
        let depth = images.depth()?.clone();
        let name = match p.channel {
            None => "coc (px)".to_string(),
            Some(c) => format!("coc (px, {c:?})"),
        };
        let coc = rec.create_image(&name, images.width, images.height, vk::Format::R32_SFLOAT)?;
        // field_curvature: uploaded with its own barrier (copy -> compute read).
        let table = rec.upload_buffer("field curvature", &p.table)?;
        // depth: written by the upload copy, whose own barrier already made it visible to
        //   compute reads in layout GENERAL; nothing to wait for here.
        // coc: written from scratch; discard old contents.
        rec.image_barriers(&[overwrite(&coc)]);
        let bindings = CocBindings { depth_m: &depth, coc_px: &coc, field_curvature: &table };
        self.kernel.dispatch(rec, &bindings, &p.push, groups_for(images.width, images.height))?;
        rec.end_pass();
        images.set_coc(p.channel, coc);
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
        let p = CocPush::new(&lens, pitch_mm, 1000.0, 2001, 1, [1000.5, 0.5], Some(&table));
        let data = table_data(Some(&table));
        assert!(p.coc_px_at(2.0, 1000, 0, &data).abs() < 1e-3);
        // 500 px right of the centre: h = 5 mm, delta = 0.1 mm.
        let v = lens.image_distance_mm();
        let d = v / lens.effective_f_number();
        let expected_px = -d * 0.1 / (v + 0.1) / pitch_mm;
        let got = p.coc_px_at(2.0, 1500, 0, &data) as f64;
        assert!((got / expected_px - 1.0).abs() < 1e-4, "{got} vs {expected_px}");
        // Without a table the reciprocal form is used: exactly 0 in focus.
        let plain = CocPush::new(&lens, pitch_mm, 1000.0, 2001, 1, [1000.5, 0.5], None);
        assert_eq!(plain.coc_px_at(2.0, 1500, 0, &[0.0]), 0.0);
    }
}
