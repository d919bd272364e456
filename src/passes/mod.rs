//! The passes, and the one shape every pass has.
//!
//! The passes sit in one folder per effect (`dof/`, `motion/`, `lens/`, `flare/`, `film/`, each
//! with a README.md), their shaders in the same folders under `glsl/`; the helpers every effect
//! shares (barriers, the scene facts, the filter shape, the bare copy) stay here.
//!
//! A pass is a module (and its shader `glsl/<effect>/<name>.comp`; several for the tiled depth of
//! field) that implements [`Pass`]: it plans itself from the frame and the camera (run or skip,
//! and the reason `--explain` prints), builds its own push constants and buffer data, creates its
//! pipelines, and records its dispatches with hand-written barriers, each commented with why.
//! Its shaders are declared once ([`Shader`](crate::gpu::Shader): bindings and push constants,
//! checked against the SPIR-V when the pipeline is created) and each has a CPU twin
//! ([`Twin`](crate::gpu::Twin)) that the tests run every dispatch against.
//!
//! [`PASS_ORDER`] lists every pass in the order the renderer records them: adding a pass is its
//! module, its shader and one line there.

pub mod barriers;
pub mod copy;
pub mod dof;
pub mod edge_layers;
pub mod film;
pub mod filter;
pub mod flare;
pub mod lens;
pub mod motion;
pub mod scene;

pub use scene::{Channel, PlanInput, SceneFacts};

use crate::gpu::{Gpu, GpuError, GpuImage, GpuResult, Recorder};
use crate::model::camera::Camera;
use std::any::Any;
use std::sync::Arc;

/// The pass order: every pass the renderer can record, in recording order. Motion blur and depth
/// of field come first (they need the pinhole image and its depth and velocity, before anything
/// moves pixels), then the lens's aberrations of the image, its flare around the bright lights,
/// then the light's falloff and the film.
///
/// Motion blur before depth of field: both act while the shutter is open. The film integrates,
/// over the open time, the defocused image of each instant; for one surface point that is its
/// aperture disk swept along its path, a convolution of the two that is the same in either order.
/// The orders differ only at depth edges, in which pinhole attributes the second pass sees where
/// the first moved light. Motion first keeps each velocity and depth with the sharp pixel it
/// describes (blurring first would leave a moving object's defocused halo on static background
/// pixels, which then would not streak); the streak then takes the CoC of the surface it lies
/// over, wrong only where a defocused object moves over a surface at another depth. Kyaw 2013
/// sec 7.3 orders its passes the same way.
pub static PASS_ORDER: &[PassEntry] = &[
    entry::<motion::blur::MotionBlur>(),
    entry::<motion::reference::MotionReference>(),
    entry::<dof::coc::Coc>(),
    entry::<dof::bokeh_gather::BokehGather>(),
    entry::<dof::tiled::TiledDof>(),
    entry::<dof::diffraction::Diffraction>(),
    entry::<lens::longitudinal_color::LongitudinalColor>(),
    entry::<lens::distortion::Distortion>(),
    entry::<lens::astigmatism::Astigmatism>(),
    entry::<lens::coma::Coma>(),
    entry::<flare::Flare>(),
    entry::<lens::vignette::Vignette>(),
    entry::<film::Film>(),
];

/// A frame input beyond the colour that a pass reads (the renderer uploads only what the
/// running passes need).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// Planar depth in metres.
    Depth,
    /// Velocity toward the next and the previous frame (px per frame, x right, y down).
    Velocity,
}

/// One compute pass: see the module documentation.
pub trait Pass: Sized + Send + Sync + 'static {
    /// Its name in the plan, `--explain`, `--profile` and the debug labels.
    const NAME: &'static str;
    /// The frame inputs it reads besides the colour.
    const INPUTS: &'static [Input] = &[];
    /// One run's push constants and buffer data, decided by [`Pass::plan`].
    type Params: std::fmt::Debug + Send + Sync + 'static;

    /// Run (once, or once per channel) or skip, and why.
    fn plan(input: &PlanInput<'_>) -> Decision<Self::Params>;

    /// Its pipelines; created only when a plan runs the pass.
    fn new(gpu: &Gpu) -> GpuResult<Self>;

    /// Whether a frame through `camera` will likely run this pass, judged before the frame is
    /// read (`velocity`: the input files' headers name a velocity pass, `io::velocity_likely`):
    /// a session then creates its pipelines ([`Pass::new`]) while the first frame's files are
    /// still being read. Optional: a guess that is wrong costs CPU time beside the read, or
    /// leaves the pipelines to be created once the plan is known.
    fn likely(_camera: &Camera, _velocity: bool) -> bool {
        false
    }

    /// With [`Pass::likely`]: create now the specialised pipelines of the likely run that
    /// `camera` alone decides (see [`Pass::prepare`]).
    fn prepare_likely(&self, _camera: &Camera) -> GpuResult<()> {
        Ok(())
    }

    /// Record one run: barriers (with the reason for each) and dispatches. Reads the frame's
    /// images it needs from `images` and replaces those it writes.
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, params: &Self::Params) -> GpuResult<()>;

    /// How far (px) an output pixel of a run of `params` reads from it in the run's input: the
    /// apron a band of the frame needs for this pass (banded rendering, src/pipeline/bands.rs).
    /// `None`: the whole frame (the flare, whose lights are found over all of it). Default 0,
    /// for passes that read only their own pixel.
    fn reach_px(_params: &Self::Params) -> Option<f64> {
        Some(0.0)
    }

    /// Create now the pipelines a run of `params` will need that [`Pass::new`] could not (those
    /// specialised per run), so they compile beside the other passes' rather than while the
    /// frame is recorded. Optional: a pipeline not prepared is created on its first dispatch.
    fn prepare(&self, _params: &Self::Params) -> GpuResult<()> {
        Ok(())
    }
}

/// What a pass's plan decided.
#[derive(Debug)]
pub struct Decision<P> {
    /// One entry per run; empty: skipped.
    pub runs: Vec<P>,
    /// The `--explain` line.
    pub why: String,
    /// False for a method the user did not choose (another `--bokeh`): not listed by `--explain`.
    pub listed: bool,
}

impl<P> Decision<P> {
    pub fn run(params: P, why: impl Into<String>) -> Self {
        Decision { runs: vec![params], why: why.into(), listed: true }
    }

    /// Several runs (one per channel, for longitudinal colour).
    pub fn run_each(runs: Vec<P>, why: impl Into<String>) -> Self {
        Decision { runs, why: why.into(), listed: true }
    }

    pub fn skip(why: impl Into<String>) -> Self {
        Decision { runs: Vec::new(), why: why.into(), listed: true }
    }

    /// Not chosen by the user: skipped without a line in `--explain`.
    pub fn not_chosen() -> Self {
        Decision { runs: Vec::new(), why: String::new(), listed: false }
    }
}

/// A pass of [`PASS_ORDER`], its type erased so the order is one list.
pub struct PassEntry {
    pub name: &'static str,
    pub inputs: &'static [Input],
    plan: fn(&PlanInput<'_>) -> PlannedPass,
    create: fn(&Gpu) -> GpuResult<Box<dyn RecordPass>>,
    likely: fn(&Camera, bool) -> bool,
    reach: fn(&(dyn Any + Send + Sync)) -> Option<f64>,
}

/// The entry of pass `P`.
pub const fn entry<P: Pass>() -> PassEntry {
    PassEntry {
        name: P::NAME,
        inputs: P::INPUTS,
        plan: plan_erased::<P>,
        create: create_erased::<P>,
        likely: P::likely,
        reach: reach_erased::<P>,
    }
}

fn reach_erased<P: Pass>(params: &(dyn Any + Send + Sync)) -> Option<f64> {
    params.downcast_ref::<P::Params>().map_or(Some(0.0), P::reach_px)
}

fn plan_erased<P: Pass>(input: &PlanInput<'_>) -> PlannedPass {
    let d = P::plan(input);
    PlannedPass {
        name: P::NAME,
        why: d.why,
        listed: d.listed,
        runs: d.runs.into_iter().map(|p| Box::new(p) as Box<dyn Any + Send + Sync>).collect(),
    }
}

fn create_erased<P: Pass>(gpu: &Gpu) -> GpuResult<Box<dyn RecordPass>> {
    Ok(Box::new(P::new(gpu)?))
}

/// A created pass, recording runs whose parameters it downcasts.
pub trait RecordPass: Send + Sync {
    /// [`Pass::prepare`] for one run.
    fn prepare_run(&self, params: &(dyn Any + Send + Sync)) -> GpuResult<()>;

    /// [`Pass::prepare_likely`].
    fn prepare_likely(&self, camera: &Camera) -> GpuResult<()>;

    fn record_run(
        &self,
        rec: &mut Recorder,
        images: &mut FrameImages,
        params: &(dyn Any + Send + Sync),
    ) -> GpuResult<()>;
}

impl<P: Pass> RecordPass for P {
    fn prepare_run(&self, params: &(dyn Any + Send + Sync)) -> GpuResult<()> {
        match params.downcast_ref::<P::Params>() {
            Some(p) => self.prepare(p),
            None => Err(GpuError::Internal(format!("pass {}: a run's parameters are of another pass", P::NAME))),
        }
    }

    fn prepare_likely(&self, camera: &Camera) -> GpuResult<()> {
        Pass::prepare_likely(self, camera)
    }

    fn record_run(
        &self,
        rec: &mut Recorder,
        images: &mut FrameImages,
        params: &(dyn Any + Send + Sync),
    ) -> GpuResult<()> {
        match params.downcast_ref::<P::Params>() {
            Some(p) => self.record(rec, images, p),
            None => Err(GpuError::Internal(format!("pass {}: a run's parameters are of another pass", P::NAME))),
        }
    }
}

impl PassEntry {
    pub fn plan(&self, input: &PlanInput<'_>) -> PlannedPass {
        (self.plan)(input)
    }

    pub fn create(&self, gpu: &Gpu) -> GpuResult<Box<dyn RecordPass>> {
        (self.create)(gpu)
    }

    /// [`Pass::likely`].
    pub fn likely(&self, camera: &Camera, velocity: bool) -> bool {
        (self.likely)(camera, velocity)
    }

    /// [`Pass::reach_px`] of one run of this pass.
    pub fn reach_px(&self, params: &(dyn Any + Send + Sync)) -> Option<f64> {
        (self.reach)(params)
    }
}

/// One pass of a plan: whether and how often it runs, why, and each run's parameters.
#[derive(Debug)]
pub struct PlannedPass {
    pub name: &'static str,
    pub why: String,
    pub listed: bool,
    runs: Vec<Box<dyn Any + Send + Sync>>,
}

impl PlannedPass {
    /// A line of the plan for an effect no pass of this version renders.
    pub fn not_built(name: &'static str, why: String) -> PlannedPass {
        PlannedPass { name, why, listed: true, runs: Vec::new() }
    }

    pub fn runs(&self) -> bool {
        !self.runs.is_empty()
    }

    pub fn run_params(&self) -> impl Iterator<Item = &(dyn Any + Send + Sync)> {
        self.runs.iter().map(|r| r.as_ref())
    }

    /// The runs' parameters, if this is pass `P`.
    pub fn params<P: Pass>(&self) -> impl Iterator<Item = &P::Params> {
        self.runs.iter().filter_map(|r| r.downcast_ref::<P::Params>())
    }

    pub fn params_mut<P: Pass>(&mut self) -> impl Iterator<Item = &mut P::Params> {
        self.runs.iter_mut().filter_map(|r| r.downcast_mut::<P::Params>())
    }

    /// Run no more (banded rendering: a round of bands runs some of the passes).
    pub fn clear_runs(&mut self, why: impl Into<String>) {
        self.runs.clear();
        self.why = why.into();
    }

    /// Make pass `P` run with these parameters (tests that force a pass the planner skipped).
    pub fn set_runs<P: Pass>(&mut self, runs: Vec<P::Params>, why: impl Into<String>) {
        self.runs = runs.into_iter().map(|p| Box::new(p) as Box<dyn Any + Send + Sync>).collect();
        self.why = why.into();
        self.listed = true;
    }
}

/// The frame's images on the GPU while a plan is recorded, by role. A pass that changes the
/// colour reads [`FrameImages::color`] and replaces it with its own output image: each pass
/// writes images of its own, so no pass overwrites what an earlier one still has to read. Two
/// exceptions change the colour pixel by pixel in place, each after its barrier has waited for
/// every earlier read. The flare adds to it (it leaves a frame without a light untouched
/// instead of copying it), and nothing recorded later reads the colour as it was. The tiled
/// depth of field takes its highlight sprites' excess out of their pixels (sparing a copy of
/// the frame), after its own steps that read the colour as it was; its output then replaces
/// the colour, or, for a per-channel run (longitudinal colour), it puts those pixels back.
pub struct FrameImages {
    pub width: u32,
    pub height: u32,
    color: Arc<GpuImage>,
    depth: Option<Arc<GpuImage>>,
    velocity: Option<Arc<GpuImage>>,
    /// Signed CoC (px) of each run: one for all channels, or one per channel.
    coc: Vec<(Option<Channel>, Arc<GpuImage>)>,
    /// Longitudinal colour: one channel's depth of field, joined by the longitudinal_color pass.
    channel_color: Vec<(Channel, Arc<GpuImage>)>,
}

impl FrameImages {
    pub fn new(color: Arc<GpuImage>, depth: Option<Arc<GpuImage>>) -> FrameImages {
        FrameImages {
            width: color.width,
            height: color.height,
            color,
            depth,
            velocity: None,
            coc: Vec::new(),
            channel_color: Vec::new(),
        }
    }

    /// The current colour (RGBA32F).
    pub fn color(&self) -> &Arc<GpuImage> {
        &self.color
    }

    /// A pass's output becomes the colour; for a per-channel run of the depth of field
    /// (`channel` set) it is kept for the longitudinal_color pass instead.
    pub fn set_color(&mut self, channel: Option<Channel>, image: Arc<GpuImage>) {
        match channel {
            None => self.color = image,
            Some(c) => self.channel_color.push((c, image)),
        }
    }

    /// One channel's depth of field (longitudinal colour).
    pub fn channel_color(&self, channel: Channel) -> GpuResult<&Arc<GpuImage>> {
        self.channel_color
            .iter()
            .find(|(c, _)| *c == channel)
            .map(|(_, i)| i)
            .ok_or_else(|| missing(&format!("the {channel:?} channel's depth of field")))
    }

    /// Planar depth in metres (R32F), for passes that declare [`Input::Depth`].
    pub fn depth(&self) -> GpuResult<&Arc<GpuImage>> {
        self.depth.as_ref().ok_or_else(|| missing("the depth"))
    }

    /// These images with the velocity (RGBA32F: next.xy, previous.xy px per frame).
    pub fn with_velocity(mut self, velocity: Option<Arc<GpuImage>>) -> FrameImages {
        self.velocity = velocity;
        self
    }

    /// The velocity, for passes that declare [`Input::Velocity`].
    pub fn velocity(&self) -> GpuResult<&Arc<GpuImage>> {
        self.velocity.as_ref().ok_or_else(|| missing("the velocity"))
    }

    /// The signed CoC of a run (R32F px), written by the coc pass.
    pub fn coc(&self, channel: Option<Channel>) -> GpuResult<&Arc<GpuImage>> {
        self.coc.iter().find(|(c, _)| *c == channel).map(|(_, i)| i).ok_or_else(|| missing("the CoC"))
    }

    /// The CoC read back by `keep_coc`: the only run's, or green's.
    pub fn main_coc(&self) -> Option<&Arc<GpuImage>> {
        self.coc(None).or_else(|_| self.coc(Some(Channel::Green))).ok()
    }

    pub fn set_coc(&mut self, channel: Option<Channel>, image: Arc<GpuImage>) {
        self.coc.retain(|(c, _)| *c != channel);
        self.coc.push((channel, image));
    }
}

fn missing(what: &str) -> GpuError {
    GpuError::Internal(format!("{what} image is needed but no earlier pass made it"))
}

/// Workgroup edge of every 2D pass (TILE_SIZE in glsl/include/common.glsl).
pub const TILE_SIZE: u32 = crate::gpu::shaders::common::TILE_SIZE;

/// Workgroups covering a width x height image.
pub fn groups_for(width: u32, height: u32) -> [u32; 3] {
    [width.div_ceil(TILE_SIZE), height.div_ceil(TILE_SIZE), 1]
}

/// Linear lookup in a height-table buffer (`n` heights, then columns of `n` values), the twin of
/// glsl/include/height_table.glsl.
pub fn height_table_lookup(table: &[f32], column: usize, n: usize, h_mm: f32) -> f32 {
    if h_mm <= table[0] {
        return table[column * n];
    }
    for i in 1..n {
        if h_mm <= table[i] {
            let t = (h_mm - table[i - 1]) / (table[i] - table[i - 1]);
            return table[column * n + i - 1] + (table[column * n + i] - table[column * n + i - 1]) * t;
        }
    }
    table[column * n + n - 1]
}

/// The twins' image helpers: the shaders' `load_clamped` + bilinear sampling at a position in
/// pixel units (texel centres at +0.5), and `finite_or_zero` (glsl/include/common.glsl).
pub mod twin {
    use crate::gpu::HostImage;

    /// Bilinear sample of an RGBA image at `(x, y)`, edge texels continuing beyond the frame.
    pub fn bilinear(image: &HostImage, x: f32, y: f32) -> [f32; 4] {
        bilinear_in_band(image, x, y, 0)
    }

    /// [`bilinear`] at (x, y) in the whole frame's pixels of an image that is the band of the
    /// frame from row `top` (as the shaders that take `band_top_px`).
    pub fn bilinear_in_band(image: &HostImage, x: f32, y: f32, top: i32) -> [f32; 4] {
        let (tx, ty) = (x - 0.5, y - 0.5);
        let (ix, iy) = (tx.floor() as i32, ty.floor() as i32);
        let (fx, fy) = (tx - ix as f32, ty - iy as f32);
        let iy = iy - top;
        let (a, b) = (image.clamped(ix, iy), image.clamped(ix + 1, iy));
        let (c, d) = (image.clamped(ix, iy + 1), image.clamped(ix + 1, iy + 1));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }

    /// NaN and Inf become 0; the rest is clamped to +-3e38.
    pub fn finite_or_zero(v: f32) -> f32 {
        if v.is_finite() {
            v.clamp(-3.0e38, 3.0e38)
        } else {
            0.0
        }
    }

    /// A buffer binding's words as f32.
    pub fn floats(words: &[u32]) -> Vec<f32> {
        words.iter().map(|&w| f32::from_bits(w)).collect()
    }

    /// How many sprites the tiled path's sprite buffer holds, from its args buffer's words:
    /// dof_highlights' counter, at most `sprite_capacity` (a sprite past it is counted as
    /// dropped, not written).
    pub fn sprites_written(args: &[u32], sprite_capacity: i32) -> usize {
        let counted = args[crate::gpu::shaders::dof_tiles::ARGS_SPRITE_COUNT as usize] as usize;
        counted.min(sprite_capacity.max(0) as usize)
    }

    /// A tile read from a tile list by one workgroup of an indirect dispatch.
    pub struct ListedTile {
        /// The tile's index (row-major over the tile grid).
        pub index: usize,
        pub origin: [u32; 2],
        tile_px: u32,
        size: [i32; 2],
    }

    impl ListedTile {
        /// The tile's pixels inside the image, row by row.
        pub fn pixels(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
            let [x0, y0] = self.origin;
            (y0..y0 + self.tile_px)
                .flat_map(move |y| (x0..x0 + self.tile_px).map(move |x| (x, y)))
                .filter(|&(x, y)| (x as i32) < self.size[0] && (y as i32) < self.size[1])
        }
    }

    /// The tiles workgroups `0..groups` read from the list of `class` (dof_classify's layout:
    /// one list of `tiles.x * tiles.y` entries per class), each `tile_px` pixels wide in an
    /// image of `size`.
    pub fn listed_tiles(
        lists: &[u32],
        class: u32,
        tiles: [i32; 2],
        groups: u32,
        tile_px: u32,
        size: [i32; 2],
    ) -> impl Iterator<Item = ListedTile> + '_ {
        let tile_count = (tiles[0] * tiles[1]) as usize;
        (0..groups as usize).map(move |group| {
            let index = lists[class as usize * tile_count + group] as usize;
            let origin = [(index % tiles[0] as usize) as u32 * tile_px, (index / tiles[0] as usize) as u32 * tile_px];
            ListedTile { index, origin, tile_px, size }
        })
    }
}
