//! Motion blur from the velocity pass (`--motion-blur fast`, the default): tiles -> neighbourhood
//! -> reconstruction gather over the tiles something near moves in, a copy of the others, each a
//! module with its shader and CPU twin (mb_tiles, mb_neighbor, mb_gather, mb_still). This pass plans the path (and shares its plan with the reference,
//! src/passes/motion/reference.rs), owns the buffers the steps share and the barriers between them.
//!
//! Kyaw 2013 sec 5.2 and 7.3: a point that moves while the shutter is open leaves a streak as
//! long as its motion over the open time; the passes turn the renderer's per-frame velocity into
//! that with the frame rate and the shutter (src/optics/shutter.rs).

use super::edges::{changed_pixels, EdgeInputs, EdgeKernels, MbEdgesPush};
use super::gather::{MbGatherBindings, MbGatherPush, MbGatherShader};
use super::neighbor::{MbNeighborPush, NeighborOutputs, GATHER_FROM_PX};
use super::path::ShutterPush;
use super::still::{MbStillBindings, MbStillPush, MbStillShader};
use super::tiles::MbTilesPush;
use super::{edges, gather, neighbor, still, tiles};
use crate::gpu::shaders::motion::{MB_TILE_ARGS_MOVING, MB_TILE_ARGS_STILL, MB_TILE_ARGS_WORDS};
use crate::gpu::{Gpu, GpuResult, Kernel, Recorder};
use crate::model::camera::{Camera, MotionBlurMode};
use crate::optics::shutter::ShutterCurve;
use crate::passes::barriers::{
    after_compute_write, args_for_indirect, buffer_after_compute_write, overwrite, write_after_write,
};
use crate::passes::scene::PlanInput;
use crate::passes::{Decision, FrameImages, Input, Pass, TILE_SIZE};
use ash::vk;

pub const NAME: &str = "motion_blur";

/// Blur shorter than this (px) while the shutter is open is invisible.
pub const VISIBLE_BLUR_PX: f64 = 0.5;

/// What both motion-blur methods plan from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionPlan {
    pub width: u32,
    pub height: u32,
    pub shutter: ShutterPush,
    /// Velocities are clamped to this (px per frame): the user's largest blur over the open time.
    pub max_speed_px: f32,
    /// The longest path (px) any pixel travels while its shutter is open.
    pub max_blur_px: f64,
    /// The fastest velocity in the frame after the clamp (px per frame).
    pub speed_px: f64,
    /// The farthest (px) a pixel's path reaches from it on either side of the frame time.
    pub max_reach_px: f64,
    /// The anti-aliased-edge resolve of the velocity and depth (`mb_edges`), unless
    /// `--keep-edge-depth`.
    pub edges: Option<MbEdgesPush>,
}

impl MotionPlan {
    pub fn tiles(&self) -> [i32; 2] {
        [self.width.div_ceil(TILE_SIZE) as i32, self.height.div_ceil(TILE_SIZE) as i32]
    }
}

/// The plan of the motion blur for `mode`, or why it is skipped.
pub fn plan_motion<P>(input: &PlanInput<'_>, mode: MotionBlurMode) -> Result<(MotionPlan, String), Decision<P>> {
    let (frame, motion) = (input.frame, &input.camera.motion);
    if motion.mode != mode {
        return Err(if motion.mode == MotionBlurMode::Off && mode == MotionBlurMode::Fast {
            Decision::skip("--motion-blur off")
        } else {
            Decision::not_chosen()
        });
    }
    let (true, Some(extent)) = (frame.velocity_px.is_some(), input.facts.motion) else {
        return Err(Decision::skip("no velocity pass"));
    };
    let timing = &motion.timing;
    let open = timing.open_length_frames();
    let max_speed_px = (motion.max_blur_px / open.max(1e-9)) as f32;
    let MotionExtent { speed_px, reach_px, blur_px } = extent;
    let rolling = if timing.readout_frames > 0.0 {
        format!(
            ", rolling shutter reading out {} in {:.4} s ({:.3} frames)",
            timing.direction.name(),
            timing.readout_frames / motion.fps,
            timing.readout_frames
        )
    } else {
        String::new()
    };
    let format = frame.velocity_format.map_or("given".to_string(), |f| f.name().to_string());
    let fps =
        if motion.fps_given { format!("{} fps", motion.fps) } else { format!("{} fps (assumed; --fps)", motion.fps) };
    let position = match timing.open_frames {
        o if o < 0.0 && timing.close_frames > 0.0 => "centred",
        o if o >= 0.0 => "opening at the frame time",
        _ => "closing at the frame time",
    };
    let curve = match timing.curve {
        ShutterCurve::Box => "box".to_string(),
        ShutterCurve::Trapezoid { ramp } => format!("trapezoid (ramps {ramp})"),
    };
    let why = format!(
        "velocity up to {speed_px:.1} px/frame ({format}) at {fps}, shutter {:.4} s = {:.0} deg {position}, {curve}{rolling}: blur up to {blur_px:.1} px",
        open / motion.fps,
        open * 360.0
    );
    if blur_px.max(reach_px) < VISIBLE_BLUR_PX {
        return Err(Decision::skip(format!(
            "{why}: nothing moves more than {VISIBLE_BLUR_PX} px while the shutter is open"
        )));
    }
    let (w, h) = input.size();
    // The edge resolve, counted here with its twin (the frame's colour is what the pass reads:
    // motion blur comes first), so that --explain says how many pixels it changes (only then:
    // 4% of a shot's CPU time).
    let (edges, edges_why) = if input.camera.resolve_depth_edges {
        let push = MbEdgesPush::new([w as i32, h as i32], timing.extent_frames(), max_speed_px);
        let what = "pixels whose colour is mostly a neighbouring layer's";
        let changed = if let (true, Some(rgba)) = (input.explained, frame.velocity_rgba()) {
            let edge_input =
                EdgeInputs { width: w, height: h, color: &frame.color, depth: &frame.depth_m, velocity: &rgba };
            format!("{} {what}", changed_pixels(&edge_input, &push))
        } else {
            what.to_string()
        };
        let why = format!(
            "; anti-aliased edges resolved ({}): {changed} (at least {:.0}% of their light) take that layer's velocity and depth",
            edges::NAME,
            100.0 * edges::MIN_SHARE
        );
        (Some(push), why)
    } else {
        (None, "; velocity and depth kept as stored at anti-aliased edges (--keep-edge-depth)".to_string())
    };
    let why = format!("{why}{edges_why}");
    let (_, full_h) = frame.full_size();
    let plan = MotionPlan {
        width: w,
        height: h,
        shutter: ShutterPush::for_band(timing, w, full_h, frame.band_top_px()),
        max_speed_px,
        max_blur_px: blur_px,
        speed_px,
        max_reach_px: reach_px,
        edges,
    };
    Ok((plan, why))
}

/// How far the frame's pixels move while the shutter is open (a fact both methods plan from,
/// of the whole frame when a band is planned).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionExtent {
    /// The fastest velocity after the clamp (px per frame).
    pub speed_px: f64,
    /// The farthest (px) a pixel's path reaches from it on either side of the frame time.
    pub reach_px: f64,
    /// The longest path (px) a pixel travels while its line's shutter is open.
    pub blur_px: f64,
}

/// The [`MotionExtent`] of `frame`'s velocities under `motion`'s shutter and clamp (`None`:
/// the frame has none), read in place (the previous vector the negated next one where the
/// pass has only one, as [`crate::model::frame::Frame::velocity_rgba`]).
pub fn motion_extent(
    frame: &crate::model::frame::Frame,
    motion: &crate::model::camera::Motion,
) -> Option<MotionExtent> {
    let next = frame.velocity_px.as_deref()?;
    let prev = frame.velocity_prev_px.as_deref();
    let timing = &motion.timing;
    let max_speed_px = (motion.max_blur_px / timing.open_length_frames().max(1e-9)) as f32;
    let (earliest, latest) = timing.extent_frames();
    let (t_fwd, t_back) = (latest.max(0.0), (-earliest).max(0.0));
    // The longest path over one line's open time (both halves when it straddles the frame
    // time): |next| times the open time after the frame time plus |prev| times the time before.
    let (o, c) = (timing.open_frames, timing.close_frames);
    let (after, before) = ((c.max(0.0) - o.max(0.0)) as f32, ((-o).max(0.0) - (-c).max(0.0)) as f32);
    let (t_fwd_f, t_back_f) = (t_fwd as f32, t_back as f32);
    // A velocity's length after clamped_velocity's clamp (the shaders' clamp_speed), to f32
    // rounding: the limit where it is longer, 0 where its length overflows (clamp_speed scales
    // it by 0 there), NaN kept (no max below takes it). One f32 square root per vector: in f64,
    // or with libm's hypot, this loop over the pixels was 4-5% of a shot's CPU time.
    let clamped_length = |x: f32, y: f32| {
        let l = (x * x + y * y).sqrt();
        match l > max_speed_px {
            true if l.is_finite() => max_speed_px,
            true => 0.0,
            false => l,
        }
    };
    let (mut speed, mut reach, mut blur) = (0.0f32, 0.0f32, 0.0f32);
    for i in 0..next.len() / 2 {
        let (nx, ny) = (next[2 * i], next[2 * i + 1]);
        let (px, py) = prev.map_or((-nx + 0.0, -ny + 0.0), |p| (p[2 * i], p[2 * i + 1]));
        let (next, prev) = (clamped_length(nx, ny), clamped_length(px, py));
        speed = speed.max(next).max(prev);
        reach = reach.max(next * t_fwd_f).max(prev * t_back_f);
        blur = blur.max(next * after + prev * before);
    }
    let (speed_px, mut reach_px, blur_px) = (speed as f64, reach as f64, blur as f64);
    if timing.readout_frames > 0.0 {
        reach_px = reach_px.max(speed_px * timing.readout_frames);
    }
    Some(MotionExtent { speed_px, reach_px, blur_px })
}

/// Why motion blur runs before the depth of field, in `--explain`.
pub const ORDER_NOTE: &str = "before the depth of field: both act while the shutter is open, and for one point they commute (its aperture disk swept along its path); the velocities and depths describe the sharp pinhole pixels, so the motion is resolved on those";

/// One run of the fast path.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionBlurParams {
    pub motion: MotionPlan,
    pub samples_per_line: i32,
    pub search_tiles: i32,
}

/// The pipelines of the fast path, one per step (the tile steps' shared with the edge resolve).
pub struct MotionBlur {
    edges: EdgeKernels,
    gather: Kernel<MbGatherShader>,
    still: Kernel<MbStillShader>,
}

impl Pass for MotionBlur {
    const NAME: &'static str = NAME;
    const INPUTS: &'static [Input] = &[Input::Depth, Input::Velocity];
    type Params = MotionBlurParams;

    /// A pixel's four lines reach `max_reach_px`; its tile's neighbourhood `search_tiles` tiles
    /// (of the tiles' largest velocities); the edge resolve a pixel's 3x3 neighbours.
    fn reach_px(p: &MotionBlurParams) -> Option<f64> {
        Some(p.motion.max_reach_px + ((p.search_tiles + 1) * TILE_SIZE as i32) as f64 + 2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<MotionBlurParams> {
        let (motion, why) = match plan_motion(input, MotionBlurMode::Fast) {
            Ok(p) => p,
            Err(skip) => return skip,
        };
        let search_tiles = (motion.max_reach_px / TILE_SIZE as f64).ceil() as i32;
        let params = MotionBlurParams { motion, samples_per_line: 8, search_tiles };
        let [tx, ty] = motion.tiles();
        let why = format!(
            "{why}; {tx}x{ty} tiles of {TILE_SIZE} px, neighbours within {search_tiles} tiles, 4 lines x {} samples per pixel; tiles with nothing moving near them copied; {ORDER_NOTE}",
            params.samples_per_line
        );
        Decision::run(params, why)
    }

    /// The fast path chosen and the input's headers naming a velocity pass.
    fn likely(camera: &Camera, velocity: bool) -> bool {
        velocity && camera.motion.mode == MotionBlurMode::Fast
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(MotionBlur { edges: EdgeKernels::new(gpu)?, gather: Kernel::new(gpu)?, still: Kernel::new(gpu)? })
    }

    /// The colour, depth and velocity in; a new colour written for every pixel.
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &MotionBlurParams) -> GpuResult<()> {
        let m = &p.motion;
        let (color, depth, velocity) = edges::inputs(&self.edges, rec, images, m.edges.as_ref())?;
        let tiles = m.tiles();
        let tile_count = (tiles[0] * tiles[1]) as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let tile_motion = rec.create_buffer("motion blur tile max", tile_count * 16, storage)?;
        let neighbor_motion = rec.create_buffer("motion blur neighbour max", tile_count * 16, storage)?;
        let size = [m.width as i32, m.height as i32];
        rec.begin_pass(tiles::NAME);
        tiles::record(
            &self.edges.tiles,
            rec,
            &velocity,
            &tile_motion,
            &MbTilesPush { size, tiles, max_speed_px: m.max_speed_px },
        )?;
        rec.begin_pass(neighbor::NAME);
        let args = rec.create_args_buffer("motion blur tile lists (indirect dispatches)", MB_TILE_ARGS_WORDS)?;
        let tile_list = rec.create_buffer("motion blur tile lists", 2 * tile_count * 4, storage)?;
        let lists = NeighborOutputs { neighbor_motion: &neighbor_motion, args: &args, tile_list: &tile_list };
        let neighbor = MbNeighborPush {
            size,
            tiles,
            shutter: m.shutter,
            search_tiles: p.search_tiles,
            gather_from_px: GATHER_FROM_PX,
        };
        neighbor::record(&self.edges.neighbor, rec, &tile_motion, &lists, &neighbor)?;
        rec.begin_pass(gather::NAME);
        let output = rec.create_image("color (motion blur)", m.width, m.height, vk::Format::R32G32B32A32_SFLOAT)?;
        // args: written by mb_neighbor with atomics, read as the indirect dispatches' sizes.
        // neighbor_motion, tile_list: written by mb_neighbor (read-after-write). color: written by
        //   the upload (its own barrier) or an earlier compute pass; the gather reads it anywhere
        //   around a pixel, so all of it must be written and visible. output: written from
        //   scratch, each pixel by one of the two dispatches.
        // tile_motion: written by mb_tiles, read by mb_neighbor since (read-after-read: the
        //   barrier before mb_neighbor made it visible to compute reads).
        rec.buffer_barriers(&[
            args_for_indirect(&args),
            buffer_after_compute_write(&neighbor_motion),
            buffer_after_compute_write(&tile_list),
        ]);
        rec.image_barriers(&[after_compute_write(&color), overwrite(&output)]);
        let bindings = MbGatherBindings {
            color_in: &color,
            depth_m: &depth,
            velocity: &velocity,
            color_out: &output,
            neighbor_motion: &neighbor_motion,
            tile_motion: &tile_motion,
            tile_list: &tile_list,
        };
        let push = MbGatherPush {
            size,
            tiles,
            shutter: m.shutter,
            max_speed_px: m.max_speed_px,
            samples_per_line: p.samples_per_line,
        };
        self.gather.dispatch_indirect(rec, &bindings, &push, &args, MB_TILE_ARGS_MOVING as u64 * 4)?;
        rec.begin_pass(still::NAME);
        // output: the gather wrote the moving tiles' pixels, this writes the still tiles': other
        //   texels of the same image, which synchronization validation tracks as one (WAW).
        rec.image_barriers(&[write_after_write(&output)]);
        let bindings = MbStillBindings { color_in: &color, color_out: &output, tile_list: &tile_list };
        self.still.dispatch_indirect(
            rec,
            &bindings,
            &MbStillPush { size, tiles },
            &args,
            MB_TILE_ARGS_STILL as u64 * 4,
        )?;
        rec.end_pass();
        images.set_color(None, output);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::camera::Motion;
    use crate::model::frame::Frame;
    use crate::optics::shutter::{RollingDirection, ShutterCurve, ShutterPosition, ShutterTiming};
    use crate::passes::motion::path::clamped_velocity;

    #[test]
    fn the_extent_is_that_of_the_clamped_vectors_the_shaders_move() {
        // The plan's extent (the reach sizes the gather's neighbourhood and a band's apron) must
        // be that of the velocities after clamp_speed, the clamp every shader applies: measured
        // here in f64 from path.rs's clamped_velocity, on ordinary, clamped, overflowing and NaN
        // vectors, with a shutter opening before the frame time and a rolling readout.
        let values = [3.0f32, -40.0, 0.2, 250.0, 1e30, f32::NAN, -0.0, 7.5, f32::INFINITY, -12.0, 0.0, 60.0];
        let next: Vec<f32> = values.iter().cycle().take(2 * 30).copied().collect();
        let prev: Vec<f32> = values.iter().rev().cycle().take(2 * 30).map(|v| -0.5 * v).collect();
        let timing = ShutterTiming::new(0.6 / 24.0, 24.0, ShutterPosition::Centred, ShutterCurve::Box).with_rolling(
            0.01,
            24.0,
            RollingDirection::Down,
        );
        let motion = Motion { fps: 24.0, fps_given: true, timing, mode: MotionBlurMode::Fast, max_blur_px: 48.0 };
        let frame = Frame::new(6, 5, vec![0.0; 4 * 30], vec![1.0; 30]).with_velocity(next.clone(), Some(prev.clone()));
        let got = motion_extent(&frame, &motion).expect("a velocity pass");
        let max_speed = (48.0 / timing.open_length_frames()) as f32;
        let (earliest, latest) = timing.extent_frames();
        let (o, c) = (timing.open_frames, timing.close_frames);
        let (mut speed, mut reach, mut blur) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..30 {
            let v = clamped_velocity(&[next[2 * i], next[2 * i + 1], prev[2 * i], prev[2 * i + 1]], max_speed);
            let (n, p) = ((v[0] as f64).hypot(v[1] as f64), (v[2] as f64).hypot(v[3] as f64));
            speed = speed.max(n).max(p);
            reach = reach.max(n * latest.max(0.0)).max(p * (-earliest).max(0.0));
            blur = blur.max(n * (c.max(0.0) - o.max(0.0)) + p * ((-o).max(0.0) - (-c).max(0.0)));
        }
        reach = reach.max(speed * timing.readout_frames);
        assert!(speed > 0.99 * max_speed as f64, "some vector is clamped: {speed} against {max_speed}");
        for (what, g, want) in
            [("speed", got.speed_px, speed), ("reach", got.reach_px, reach), ("blur", got.blur_px, blur)]
        {
            assert!((g - want).abs() <= 1e-5 * want, "{what}: {g} px, the clamped vectors' {want} px");
        }
    }
}
