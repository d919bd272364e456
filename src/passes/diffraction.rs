//! Diffraction depth of field: the focus processor of Potmesil & Chakravarty 1981 (sec. 3.2,
//! eq 20) as a gather pass. Shader: glsl/diffraction.comp. Tables and CPU reference (f64):
//! [`crate::optics::focus_processor`] (`build_tables`, `process_cpu`).
//!
//! Usage: build the tables on the CPU, upload them with [`Recorder::upload_buffer`] (its
//! barrier makes them visible to compute reads), then [`DiffractionPass::record`] with
//! [`DiffractionParams::new`]. Only the tables of sub-pixel offset 0 are read (the input pixels
//! are point samples at their centres), but the whole `PsfTables::data` is uploaded as is.
//!
//! Cost: `(2R+1)²` taps per output pixel, `R = PsfTables::radius_px`.

use super::{after_compute_write, groups_for, overwrite, push_bytes};
use crate::gpu::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use crate::optics::focus_processor::PsfTables;
use ash::vk;

pub const NAME: &str = "diffraction";

/// Push constants of glsl/diffraction.comp: the table geometry and the depth -> level mapping
/// of [`crate::optics::focus_processor::LevelMapping`] in f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffractionParams {
    pub size: [i32; 2],
    pub radius_px: i32,
    pub levels: i32,
    pub subpixel: i32,
    pub knot_level: i32,
    pub inv_focus_per_m: f32,
    pub defocus_near_per_m: f32,
    pub defocus_far_per_m: f32,
    pub defocus_knot_per_m: f32,
    pub near_levels_per_defocus_m: f32,
    pub far_levels_per_defocus_m: f32,
}

impl DiffractionParams {
    pub fn new(tables: &PsfTables, width: u32, height: u32) -> DiffractionParams {
        let m = &tables.mapping;
        DiffractionParams {
            size: [width as i32, height as i32],
            radius_px: tables.radius_px as i32,
            levels: tables.levels() as i32,
            subpixel: tables.subpixel as i32,
            knot_level: m.knot_level as i32,
            inv_focus_per_m: m.inv_focus_per_m as f32,
            defocus_near_per_m: m.defocus_near_per_m as f32,
            defocus_far_per_m: m.defocus_far_per_m as f32,
            defocus_knot_per_m: m.defocus_knot_per_m as f32,
            near_levels_per_defocus_m: m.near_levels_per_defocus_m as f32,
            far_levels_per_defocus_m: m.far_levels_per_defocus_m as f32,
        }
    }

    /// CPU twin of the shader's `level_coordinate`, in the same f32 arithmetic.
    pub fn level_coordinate(&self, depth_m: f32) -> f32 {
        let inv_depth = if depth_m.is_nan() { 0.0 } else { 1.0 / depth_m.max(1.0e-30) };
        let w = (self.inv_focus_per_m - inv_depth).clamp(self.defocus_near_per_m, self.defocus_far_per_m);
        let x = if w < self.defocus_knot_per_m {
            (w - self.defocus_near_per_m) * self.near_levels_per_defocus_m
        } else {
            self.knot_level as f32 + (w - self.defocus_knot_per_m) * self.far_levels_per_defocus_m
        };
        x.clamp(0.0, (self.levels - 1) as f32)
    }
}

pub struct DiffractionPass {
    pipeline: ComputePipeline,
}

impl DiffractionPass {
    pub fn new(gpu: &Gpu) -> GpuResult<DiffractionPass> {
        let mut bindings = vec![vk::DescriptorType::STORAGE_IMAGE; 3];
        bindings.push(vk::DescriptorType::STORAGE_BUFFER);
        let size = std::mem::size_of::<DiffractionParams>() as u32;
        Ok(DiffractionPass { pipeline: ComputePipeline::new(gpu, NAME, shaders::spirv(NAME)?, &bindings, size)? })
    }

    /// `color` (RGBA32F) and `depth` (R32F, metres) -> `output` (RGBA32F, alpha copied), with
    /// `table` holding `PsfTables::data` (from [`Recorder::upload_buffer`]).
    pub fn record(
        &self,
        rec: &mut Recorder,
        color: &GpuImage,
        depth: &GpuImage,
        table: &GpuBuffer,
        output: &GpuImage,
        params: &DiffractionParams,
    ) -> GpuResult<()> {
        rec.begin_pass(NAME);
        // color, depth: when uploaded by `Recorder::upload_images`, its own barrier already made
        //   them visible to compute reads in layout GENERAL; waiting on earlier compute writes as
        //   well keeps this pass correct when a compute pass produced them (e.g. vignetting
        //   before it), and costs nothing otherwise.
        // table: `Recorder::upload_buffer` recorded its copy -> compute-read barrier; nothing
        //   writes it on the GPU.
        // output: written from scratch; discard old contents (and order after earlier reads).
        rec.image_barriers(&[after_compute_write(color), after_compute_write(depth), overwrite(output)]);
        rec.dispatch(
            &self.pipeline,
            &[Bind::Image(color), Bind::Image(depth), Bind::Image(output), Bind::Buffer(table)],
            push_bytes(params),
            groups_for(output.width, output.height),
        )?;
        rec.end_pass();
        Ok(())
    }
}
