//! Diffraction depth of field: the focus processor of Potmesil & Chakravarty 1981 (sec. 3.2,
//! eq 20) as a gather pass. Shader: glsl/dof/diffraction.comp. Tables and CPU reference (f64):
//! [`crate::optics::focus_processor`] (`build_tables`, `process_cpu`).
//!
//! The plan builds the tables on the CPU (for the frame's depth range); the pass uploads them
//! and gathers. Only the tables of sub-pixel offset 0 are read (the input pixels are point
//! samples at their centres), but the whole `PsfTables::data` is uploaded as is.
//!
//! Cost: `(2R+1)²` taps per output pixel, `R = PsfTables::radius_px`.

use crate::gpu::{Gpu, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::model::camera::BokehMode;
use crate::optics::focus_processor::{build_tables, PsfTableSettings, PsfTables};
use crate::passes::barriers::{after_compute_write, overwrite};
use crate::passes::scene::PlanInput;
use crate::passes::twin::{finite_or_zero, floats};
use crate::passes::{groups_for, Decision, FrameImages, Input, Pass};
use std::sync::Arc;

pub const NAME: &str = "diffraction";

/// Push constants of glsl/dof/diffraction.comp: the table geometry and the depth -> level mapping
/// of [`crate::optics::focus_processor::LevelMapping`] in f32.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DiffractionPush {
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

impl DiffractionPush {
    pub fn new(tables: &PsfTables, width: u32, height: u32) -> DiffractionPush {
        let m = &tables.mapping;
        DiffractionPush {
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

crate::shader_bindings! {
    /// The bindings of glsl/dof/diffraction.comp.
    pub struct DiffractionBindings {
        color_in: image(color_in),
        depth_m: image(depth_m),
        color_out: image(color_out),
        tables: buffer(Tables),
    }
}

/// glsl/dof/diffraction.comp.
pub struct DiffractionShader;

impl Shader for DiffractionShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = DiffractionBindings<'a>;
    type Push = DiffractionPush;
}

impl Twin for DiffractionShader {
    /// The shader's gather in f32 ([`crate::optics::focus_processor::process_cpu`] is the f64
    /// reference of the same sums).
    fn cpu(pc: &DiffractionPush, _groups: [u32; 3], b: &mut [HostData]) {
        let table = floats(b[3].words());
        let (color, depth) = (b[0].image().clone(), b[1].image().clone());
        let (w, h, r) = (pc.size[0], pc.size[1], pc.radius_px);
        let side = 2 * r + 1;
        let channel_stride = (pc.subpixel * pc.subpixel * side * side) as usize;
        let level_stride = 3 * channel_stride;
        let reach = r as f32 + 1.25;
        let out = b[2].image_mut();
        for py in 0..h {
            for px in 0..w {
                let (mut numerator, mut denominator) = ([0.0f32; 3], [0.0f32; 3]);
                for dy in -r..=r {
                    let qy = py - dy;
                    if qy < 0 || qy >= h {
                        continue;
                    }
                    for dx in -r..=r {
                        let qx = px - dx;
                        if qx < 0 || qx >= w || (dx * dx + dy * dy) as f32 > reach * reach {
                            continue;
                        }
                        let x = pc.level_coordinate(depth.clamped(qx, qy)[0]);
                        let l0 = (x.floor() as i32).min(pc.levels - 1);
                        let l1 = (l0 + 1).min(pc.levels - 1);
                        let t = x - l0 as f32;
                        let e = ((dy + r) * side + (dx + r)) as usize;
                        let (b0, b1) = (l0 as usize * level_stride + e, l1 as usize * level_stride + e);
                        let c = color.clamped(qx, qy);
                        for k in 0..3 {
                            let weight =
                                (1.0 - t) * table[b0 + k * channel_stride] + t * table[b1 + k * channel_stride];
                            numerator[k] += weight * finite_or_zero(c[k]);
                            denominator[k] += weight;
                        }
                    }
                }
                let alpha = color.clamped(px, py)[3];
                let rgb: [f32; 3] = std::array::from_fn(|k| {
                    if denominator[k] > 0.0 {
                        numerator[k] / denominator[k].max(1e-30)
                    } else {
                        0.0
                    }
                });
                out.texel_mut(px as u32, py as u32).copy_from_slice(&[rgb[0], rgb[1], rgb[2], alpha]);
            }
        }
    }
}

/// The pass's constants and the focus processor's tables for the frame's depth range.
#[derive(Clone, Debug)]
pub struct DiffractionParams {
    pub push: DiffractionPush,
    pub tables: Arc<PsfTables>,
}

/// Potmesil & Chakravarty's focus processor (`--bokeh diffraction`).
pub struct Diffraction {
    kernel: Kernel<DiffractionShader>,
}

impl Pass for Diffraction {
    const NAME: &'static str = NAME;
    const INPUTS: &'static [Input] = &[Input::Depth];
    type Params = DiffractionParams;

    /// The kernels' radius.
    fn reach_px(p: &DiffractionParams) -> Option<f64> {
        Some(p.push.radius_px as f64 + 2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<DiffractionParams> {
        let (f, camera) = (&input.facts, input.camera);
        if let Some(gated) = input.dof_method_gate(BokehMode::Diffraction) {
            return gated;
        }
        let nm = input.frame.channel_wavelengths_nm();
        let settings = PsfTableSettings {
            subpixel: 1,
            wavelengths_nm: nm,
            max_radius_px: (0.5 * f.max_coc_px).ceil().max(1.0) as u32 + 4,
            ..Default::default()
        };
        let (near_m, far_m) = f.depth_range_m;
        let tables = build_tables(&camera.lens, f.pixel_pitch_mm, near_m.max(1e-6) as f64, far_m as f64, &settings);
        let (w, h) = input.size();
        let push = DiffractionPush::new(&tables, w, h);
        let why = format!(
            "--bokeh diffraction: Potmesil & Chakravarty focus processor, {} depth tables of radius {} px at {:.0}/{:.0}/{:.0} nm, gathered over the whole frame",
            tables.levels(),
            tables.radius_px,
            nm[0],
            nm[1],
            nm[2]
        );
        Decision::run(DiffractionParams { push, tables: Arc::new(tables) }, why)
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Diffraction { kernel: Kernel::new(gpu)? })
    }

    /// Colour (RGBA32F) and depth (R32F, metres) -> a new colour (alpha copied).
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &DiffractionParams) -> GpuResult<()> {
        rec.begin_pass(NAME);
        let (color, depth) = (images.color().clone(), images.depth()?.clone());
        let output = rec.create_image("color (depth of field)", color.width, color.height, color.format)?;
        // table: `Recorder::upload_buffer` records its copy -> compute-read barrier; nothing
        //   writes it on the GPU.
        let table = rec.upload_buffer("psf tables", &p.tables.data)?;
        // color, depth: the upload's own barrier made them visible to compute reads in layout
        //   GENERAL; waiting on earlier compute writes as well keeps this pass correct when a
        //   compute pass produced them, and costs nothing otherwise.
        // output: written from scratch; discard old contents (and order after earlier reads).
        rec.image_barriers(&[after_compute_write(&color), after_compute_write(&depth), overwrite(&output)]);
        let bindings = DiffractionBindings { color_in: &color, depth_m: &depth, color_out: &output, tables: &table };
        self.kernel.dispatch(rec, &bindings, &p.push, groups_for(output.width, output.height))?;
        rec.end_pass();
        images.set_color(None, output);
        Ok(())
    }
}
