//! The motion-blur reference (`--motion-blur reference`): per sub-frame time, every texel of the
//! pinhole image scattered to where its own path has it (with depth ordering: the nearest texel
//! landing on a pixel wins), what each pixel shows added up with the shutter curve's weight.
//! The sub-frame times are at most half a pixel of motion apart, so each pixel's share of a
//! path is its length over the pixel: exact area sampling of the streak. Slow (its cost grows
//! with the blur length); for tests and the accuracy report beside the fast path
//! (src/passes/motion/blur.rs), whose plan it shares. Steps: mb_ref_splat (two stages),
//! mb_ref_resolve.

use super::blur::{plan_motion, MotionPlan, ORDER_NOTE};
use super::edges::{self, EdgeKernels};
use super::ref_resolve::{MbRefResolveBindings, MbRefResolvePush, MbRefResolveShader};
use super::ref_splat::{MbRefSplatBindings, MbRefSplatPush, MbRefSplatShader};
use crate::gpu::{Gpu, GpuResult, Kernel, Recorder};
use crate::model::camera::{Camera, MotionBlurMode};
use crate::passes::barriers::{after_compute_write, overwrite, write_after_write};
use crate::passes::scene::PlanInput;
use crate::passes::{groups_for, Decision, FrameImages, Input, Pass};
use ash::vk;

pub const NAME: &str = "motion_blur_reference";

/// Fewest and most sub-frame times.
pub const MIN_TIMES: u32 = 16;
pub const MAX_TIMES: u32 = 256;

/// One run of the reference.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionReferenceParams {
    pub motion: MotionPlan,
    /// The first and last instant any line of the frame is exposed (frames).
    pub extent_frames: (f32, f32),
    /// Sub-frame times, equally spaced over the extent (midpoints).
    pub times: u32,
}

pub struct MotionReference {
    edges: EdgeKernels,
    splat: Kernel<MbRefSplatShader>,
    resolve: Kernel<MbRefResolveShader>,
}

impl Pass for MotionReference {
    const NAME: &'static str = NAME;
    const INPUTS: &'static [Input] = &[Input::Depth, Input::Velocity];
    type Params = MotionReferenceParams;

    /// Every pixel's path over the open time, and the edge resolve's 3x3 neighbours.
    fn reach_px(p: &MotionReferenceParams) -> Option<f64> {
        Some(p.motion.max_reach_px + 2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<MotionReferenceParams> {
        let (motion, why) = match plan_motion(input, MotionBlurMode::Reference) {
            Ok(p) => p,
            Err(skip) => return skip,
        };
        let (earliest, latest) = input.camera.motion.timing.extent_frames();
        // At most half a pixel of motion between two sub-frame times.
        let travel_px = motion.speed_px * (latest - earliest);
        let times = ((2.0 * travel_px).ceil() as u32).clamp(MIN_TIMES, MAX_TIMES);
        let params = MotionReferenceParams { motion, extent_frames: (earliest as f32, latest as f32), times };
        let why = format!(
            "{why}; every pixel scattered along its path at {times} sub-frame times ({:.2} px apart at the fastest) with depth ordering; {ORDER_NOTE}",
            travel_px / times as f64
        );
        Decision::run(params, why)
    }

    /// The reference chosen and the input's headers naming a velocity pass.
    fn likely(camera: &Camera, velocity: bool) -> bool {
        velocity && camera.motion.mode == MotionBlurMode::Reference
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(MotionReference { edges: EdgeKernels::new(gpu)?, splat: Kernel::new(gpu)?, resolve: Kernel::new(gpu)? })
    }

    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &MotionReferenceParams) -> GpuResult<()> {
        let m = &p.motion;
        let (color, depth, velocity) = edges::inputs(&self.edges, rec, images, m.edges.as_ref())?;
        rec.begin_pass(NAME);
        let (w, h) = (m.width, m.height);
        let size = [w as i32, h as i32];
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        let landing_depth = rec.create_buffer("motion reference landing depth", w as u64 * h as u64 * 4, usage)?;
        let landing_index = rec.create_buffer("motion reference landing index", w as u64 * h as u64 * 4, usage)?;
        let rgba = vk::Format::R32G32B32A32_SFLOAT;
        let accum = rec.create_image("motion reference sum", w, h, rgba)?;
        let output = rec.create_image("color (motion blur reference)", w, h, rgba)?;
        // color: written by the upload (its own barrier) or an earlier compute pass; read at any
        //   texel. accum, output: written from scratch.
        rec.image_barriers(&[after_compute_write(&color), overwrite(&accum), overwrite(&output)]);
        let dt = (p.extent_frames.1 - p.extent_frames.0) / p.times as f32;
        let groups = groups_for(w, h);
        let splat_bindings = MbRefSplatBindings {
            depth_m: &depth,
            velocity: &velocity,
            landing_depth: &landing_depth,
            landing_index: &landing_index,
        };
        let resolve_bindings = MbRefResolveBindings {
            color_in: &color,
            depth_m: &depth,
            velocity: &velocity,
            accum: &accum,
            color_out: &output,
            landing_index: &landing_index,
        };
        for k in 0..p.times {
            let t_frames = p.extent_frames.0 + (k as f32 + 0.5) * dt;
            // The landing buffers are cleared for this time: the previous time's splats wrote them
            //   and its resolve read them, all before the clear (write-after-write, -after-read).
            rec.memory_barrier(
                vk::MemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
                    .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE | vk::AccessFlags2::SHADER_STORAGE_READ)
                    .dst_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
                    .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE),
            );
            rec.fill_buffer(&landing_depth, u32::MAX);
            rec.fill_buffer(&landing_index, u32::MAX);
            // The clears, before the splats' atomics read and write the buffers.
            rec.memory_barrier(
                vk::MemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
                    .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                    .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
                    .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE),
            );
            let splat =
                |stage| MbRefSplatPush { size, shutter: m.shutter, max_speed_px: m.max_speed_px, t_frames, stage };
            self.splat.dispatch(rec, &splat_bindings, &splat(0), groups)?;
            // Stage 0's nearest depths, complete, before stage 1 compares against them.
            rec.buffer_barriers(&[crate::passes::barriers::buffer_after_compute_write(&landing_depth)]);
            self.splat.dispatch(rec, &splat_bindings, &splat(1), groups)?;
            // The winners' indices, complete, before the resolve reads them (its own and its
            //   neighbours'); the previous resolve's sum before this one adds to it.
            rec.buffer_barriers(&[crate::passes::barriers::buffer_after_compute_write(&landing_index)]);
            if k > 0 {
                rec.image_barriers(&[write_after_write(&accum)]);
            }
            let resolve = MbRefResolvePush {
                size,
                shutter: m.shutter,
                max_speed_px: m.max_speed_px,
                t_frames,
                dt_frames: dt,
                first: (k == 0) as i32,
                last: (k + 1 == p.times) as i32,
            };
            self.resolve.dispatch(rec, &resolve_bindings, &resolve, groups)?;
        }
        rec.end_pass();
        images.set_color(None, output);
        Ok(())
    }
}
