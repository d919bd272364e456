//! Astigmatism: tangential then sagittal 1D blurs whose lengths follow the lens's tables against
//! image height (Kyaw 2013 sec 6.3.3, sec 7.3). Two dispatches of one shader:
//! glsl/lens/astigmatism.comp.

use crate::gpu::{Gpu, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::optics::distortion::HeightTable;
use crate::passes::filter::{self, FilterBindings};
use crate::passes::scene::PlanInput;
use crate::passes::twin::{bilinear_in_band, finite_or_zero, floats};
use crate::passes::{height_table_lookup, Decision, FrameImages, Pass};

pub const NAME: &str = "astigmatism";

/// Push constants of glsl/lens/astigmatism.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AstigmatismPush {
    pub size: [i32; 2],
    pub centre_px: [f32; 2],
    pub pixel_pitch_mm: f32,
    pub entries: i32,
    /// 0: tangential, 1: sagittal (set per dispatch).
    pub direction: i32,
    /// The image is the band of the frame from this row (banded rendering; `centre_px` is in
    /// the whole frame's pixels); 0 for the whole frame.
    pub band_top_px: i32,
}

/// The table buffer: heights, tangential blur (mm), sagittal blur (mm).
pub fn table_data(tangential_mm: &HeightTable, sagittal_mm: &HeightTable) -> Vec<f32> {
    tangential_mm
        .image_height_mm
        .iter()
        .chain(&tangential_mm.values)
        .chain(&sagittal_mm.values)
        .map(|&v| v as f32)
        .collect()
}

/// glsl/lens/astigmatism.comp.
pub struct AstigmatismShader;

impl Shader for AstigmatismShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FilterBindings<'a>;
    type Push = AstigmatismPush;
}

impl Twin for AstigmatismShader {
    /// One 1D box blur per pixel along the tangent (direction 0) or the radius (1), L px long
    /// with n = ceil(L) bilinear samples at the centres of n equal parts.
    fn cpu(push: &AstigmatismPush, _groups: [u32; 3], b: &mut [HostData]) {
        let table = floats(b[2].words());
        let input = b[0].image().clone();
        let out = b[1].image_mut();
        let pitch = push.pixel_pitch_mm;
        for y in 0..push.size[1] as u32 {
            for x in 0..push.size[0] as u32 {
                let (top, yw) = (push.band_top_px, y as i32 + push.band_top_px);
                let d = [x as f32 + 0.5 - push.centre_px[0], yw as f32 + 0.5 - push.centre_px[1]];
                let h_px = (d[0] * d[0] + d[1] * d[1]).sqrt();
                let column = 1 + push.direction as usize;
                let length_px = height_table_lookup(&table, column, push.entries as usize, h_px * pitch) / pitch;
                if length_px <= 0.0 || h_px == 0.0 {
                    let texel = input.clamped(x as i32, y as i32).to_vec();
                    out.texel_mut(x, y).copy_from_slice(&texel);
                    continue;
                }
                let radial = [d[0] / h_px, d[1] / h_px];
                let axis = if push.direction == 0 { [-radial[1], radial[0]] } else { radial };
                let n = (length_px.ceil() as i32).max(1);
                let mut sum = [0.0f32; 4];
                for i in 0..n {
                    let s = ((i as f32 + 0.5) / n as f32 - 0.5) * length_px;
                    let v = bilinear_in_band(&input, x as f32 + 0.5 + s * axis[0], yw as f32 + 0.5 + s * axis[1], top);
                    for k in 0..4 {
                        sum[k] += v[k];
                    }
                }
                let texel = sum.map(|v| finite_or_zero(v / n as f32));
                out.texel_mut(x, y).copy_from_slice(&texel);
            }
        }
    }
}

/// The pass's constants and its tables.
#[derive(Clone, Debug)]
pub struct AstigmatismParams {
    pub push: AstigmatismPush,
    pub table: Vec<f32>,
}

pub struct Astigmatism {
    kernel: Kernel<AstigmatismShader>,
}

impl Pass for Astigmatism {
    const NAME: &'static str = NAME;
    type Params = AstigmatismParams;

    /// The longest blur of the tables (mm on the film, tangential or sagittal).
    fn reach_px(p: &AstigmatismParams) -> Option<f64> {
        let n = p.push.entries.max(0) as usize;
        let mm = p.table.get(n..).unwrap_or(&[]).iter().fold(0.0f64, |m, v| m.max(v.abs() as f64));
        Some(mm / p.push.pixel_pitch_mm.max(1e-9) as f64 + 2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<AstigmatismParams> {
        match &input.camera.astigmatism {
            Some((t, s)) if !(t.is_zero() && s.is_zero()) => {
                let (frame, pitch_mm) = (input.frame, input.facts.pixel_pitch_mm);
                let corner_mm = frame.farthest_corner_px() * pitch_mm;
                let why = format!(
                    "the lens's tables: tangential blur up to {:.1} px, sagittal up to {:.1} px in the frame",
                    t.max_abs_within(corner_mm) / pitch_mm,
                    s.max_abs_within(corner_mm) / pitch_mm
                );
                let push = AstigmatismPush {
                    size: [frame.width as i32, frame.height as i32],
                    centre_px: [frame.centre_px[0] as f32, (frame.centre_px[1] + frame.band_top_px() as f64) as f32],
                    pixel_pitch_mm: pitch_mm as f32,
                    entries: t.image_height_mm.len() as i32,
                    direction: 0,
                    band_top_px: frame.band_top_px() as i32,
                };
                Decision::run(AstigmatismParams { push, table: table_data(t, s) }, why)
            }
            _ => Decision::skip("the lens has no (non-zero) tangential or sagittal blur tables"),
        }
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Astigmatism { kernel: Kernel::new(gpu)? })
    }

    /// Two dispatches: the tangential blur into an image of its own, then the sagittal blur.
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &AstigmatismParams) -> GpuResult<()> {
        rec.begin_pass("astigmatism_tangential");
        let table = rec.upload_buffer("astigmatism tables", &p.table)?;
        let tangential = AstigmatismPush { direction: 0, ..p.push };
        let between =
            filter::dispatch(&self.kernel, rec, images.color(), &table, &tangential, "color (tangential blur)")?;
        rec.begin_pass("astigmatism_sagittal");
        // The filter's barriers wait for the tangential blur's writes to `between`.
        let sagittal = AstigmatismPush { direction: 1, ..p.push };
        let output = filter::dispatch(&self.kernel, rec, &between, &table, &sagittal, "color (astigmatism)")?;
        rec.end_pass();
        images.set_color(None, output);
        Ok(())
    }
}
