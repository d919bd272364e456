//! The tiled depth-of-field path (`--bokeh tiled`, the default), in order: tiles -> classify ->
//! copy tiles and exact small-CoC tiles at full resolution; for the rest a pyramid of the
//! blurring pixels (halving down to 1/16, highlights taken out as sprites), a gather per tile at
//! the level where its radius is a couple of texels, sprites binned per tile, a composite at full
//! resolution, and the sprites drawn over the tiles that have any. Its cost is nearly flat in the
//! CoC radius: full-resolution gathers are bounded by `small_radius_px`, a level's gather has a
//! bounded number of taps per texel while the texels are 4x fewer per level, and only highlights
//! are scattered. Each step is its own
//! module with its shader and CPU twin; this pass plans the path, owns the buffers the steps
//! share and the barriers between the classification and its indirect dispatches.

use super::aperture::{shape_radius_for, ApertureConstants, ApertureData};
use super::bin::{BinBindings, BinPush, BinShader};
use super::bin_order::{BinOrderBindings, BinOrderShader};
use super::classify::{exact_radius_px, ClassifyBindings, ClassifyPush, ClassifyShader};
use super::composite::{CompositeBindings, CompositePush, CompositeShader};
use super::downsample::{
    candidate_buffer_bytes, sprite_buffer_bytes, DownsampleBindings, DownsamplePush, DownsampleShader,
};
use super::highlights::{HighlightsBindings, HighlightsPush, HighlightsShader};
use super::level_gather::{LevelGatherBindings, LevelGatherPush, LevelGatherShader};
use super::level_lists::{LevelListsBindings, LevelListsShader};
use super::pyramid::{PyramidBindings, PyramidShader};
use super::sprite_excess::{saved_buffer_bytes, SpriteExcessBindings, SpriteExcessPush, SpriteExcessShader};
use super::sprites::{SpritesBindings, SpritesPush, SpritesShader};
use super::tile_gather::{TileGatherBindings, TileGatherPush, TileGatherShader};
use super::tiles::{TilesPush, TilesShader};
use super::{
    bin, bin_order, classify, composite, downsample, highlights, level_gather, level_lists, pyramid, sprite_excess,
    sprites, tile_gather, tiles,
};
use crate::gpu::shaders::dof_tiles::{
    ARGS_BIN_DISPATCH, ARGS_WORDS, BIN_CAPACITY, CLASS_LEVEL1, EXACT_MAX_RADIUS_PX, LEVELS, LIST_BLURRED_LEVEL1,
    LIST_COUNT,
};
use crate::gpu::{Gpu, GpuBuffer, GpuError, GpuImage, GpuResult, Kernel, Recorder, SpecializedKernel};
use crate::model::aperture::ApertureShape;
use crate::model::camera::{BokehMode, Camera};
use crate::passes::barriers::{after_compute_write, args_for_indirect, buffer_after_compute_write, overwrite};
use crate::passes::scene::{Channel, PlanInput, VISIBLE_COC_PX};
use crate::passes::{Decision, FrameImages, Pass, TILE_SIZE};
use ash::vk;
use std::sync::Arc;

pub const NAME: &str = "bokeh_tiled";

/// Settings of one run of the tiled path.
#[derive(Clone, Debug, PartialEq)]
pub struct TiledDofParams {
    pub width: u32,
    pub height: u32,
    /// Tiles whose gather radius is at most this use the exact full-resolution gather; so do
    /// the pixels of a smaller own CoC radius in the other tiles.
    pub small_radius_px: f32,
    /// A highlight is at least this bright (luminance, in input units) ...
    pub highlight_min: f32,
    /// ... and this many times brighter than its neighbours' mean.
    pub highlight_ratio: f32,
    pub sprite_capacity: u32,
    /// A highlight becomes a sprite only if its excess spread over its CoC is at least this
    /// fraction of its surroundings' luminance per pixel.
    pub sprite_visibility: f32,
    /// Luminance of R, G and B in the frame's colour space (the Y row of its RGB to XYZ
    /// matrix): what `highlight_min` and the background compare.
    pub luminance_weights: [f32; 3],
    /// Largest |CoC| diameter in the frame (after the clamp), for the dilation search.
    pub max_abs_coc_px: f32,
    /// The aperture, in full-resolution pixel units.
    pub aperture: ApertureConstants,
    /// The aperture image and the shape table.
    pub aperture_data: ApertureData,
    /// The channel of this run (longitudinal colour), or all.
    pub channel: Option<Channel>,
}

impl TiledDofParams {
    pub fn new(
        width: u32,
        height: u32,
        max_abs_coc_px: f64,
        aperture: &ApertureShape,
        sa_max_coc_px: f64,
        centre_px: [f64; 2],
    ) -> Self {
        let constants = ApertureConstants::new(aperture, sa_max_coc_px, centre_px, width, height);
        let (aperture, aperture_data) = ApertureData::new(constants, None, shape_radius_for(max_abs_coc_px));
        TiledDofParams {
            width,
            height,
            small_radius_px: 2.0,
            highlight_min: 1.0,
            highlight_ratio: 2.0,
            sprite_capacity: 16384,
            sprite_visibility: 0.05,
            luminance_weights: crate::optics::colour::Chromaticities::REC709.luminance_weights().map(|w| w as f32),
            max_abs_coc_px: max_abs_coc_px as f32,
            aperture,
            aperture_data,
            channel: None,
        }
    }

    pub fn tiles(&self) -> [i32; 2] {
        [self.width.div_ceil(TILE_SIZE) as i32, self.height.div_ceil(TILE_SIZE) as i32]
    }

    /// The size of pyramid level `level` (1/2^level resolution, rounded up).
    fn level_size(&self, level: u32) -> [u32; 2] {
        [self.width.div_ceil(1 << level), self.height.div_ceil(1 << level)]
    }
}

/// The pipelines of the tiled path, one per step.
pub struct TiledDof {
    tiles: Kernel<TilesShader>,
    classify: Kernel<ClassifyShader>,
    tile_gather: SpecializedKernel<TileGatherShader>,
    downsample: Kernel<DownsampleShader>,
    highlights: Kernel<HighlightsShader>,
    sprite_excess: Kernel<SpriteExcessShader>,
    pyramid: Kernel<PyramidShader>,
    bin: Kernel<BinShader>,
    bin_order: Kernel<BinOrderShader>,
    level_lists: Kernel<LevelListsShader>,
    level_gather: SpecializedKernel<LevelGatherShader>,
    composite: SpecializedKernel<CompositeShader>,
    sprites: SpecializedKernel<SpritesShader>,
}

/// One level of the pyramid: its colour and CoC, and the layers its gather writes.
struct Level {
    color: Arc<GpuImage>,
    coc: Arc<GpuImage>,
    bg: Arc<GpuImage>,
    fg: Arc<GpuImage>,
    fg_big: Arc<GpuImage>,
    /// The foregrounds' coverages: (all foreground samples, the large-CoC ones).
    coverage: Arc<GpuImage>,
}

impl Pass for TiledDof {
    const NAME: &'static str = NAME;
    type Params = TiledDofParams;

    /// The largest CoC radius, and three tiles beyond it: the tiles' dilation, a pyramid texel
    /// (at most a tile at 1/16) and the composite's bilinear upsampling.
    fn reach_px(p: &TiledDofParams) -> Option<f64> {
        Some(p.max_abs_coc_px as f64 / 2.0 + 3.0 * TILE_SIZE as f64 + 2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<TiledDofParams> {
        let (f, camera) = (&input.facts, input.camera);
        if let Some(gated) = input.dof_method_gate(BokehMode::Tiled) {
            return gated;
        }
        let (w, h) = input.size();
        let max_abs_coc_px = f.max_abs_coc_px();
        let mut base = TiledDofParams::new(
            w,
            h,
            max_abs_coc_px,
            &camera.aperture,
            f.sa_full_strength_coc_px,
            input.frame.centre_px,
        );
        base.luminance_weights = input.frame.working_space.luminance_weights().map(|w| w as f32);
        if input.frame.band.is_some() {
            // A band's cat's eye grows towards the whole frame's farthest corner.
            base.aperture.cats_eye_per_px = camera.aperture.cats_eye_per_px_at(input.frame.farthest_corner_px()) as f32;
        }
        (base.aperture, base.aperture_data) = ApertureData::new(
            base.aperture.with_pitch(camera, f.pixel_pitch_mm),
            camera.aperture_mask.as_ref(),
            shape_radius_for(max_abs_coc_px),
        );
        let why = format!(
            "largest CoC {max_abs_coc_px:.1} px > {VISIBLE_COC_PX} px: {}x{} tiles of {TILE_SIZE} px; in-focus tiles copied, CoC radius <= {} px gathered exactly (up to {EXACT_MAX_RADIUS_PX} px where a tile's level is coarser than the pixel's CoC), larger on a pyramid of 1/2 to 1/16 resolution with highlight sprites; {}",
            base.tiles()[0],
            base.tiles()[1],
            base.small_radius_px,
            input.aperture_text()
        );
        let runs =
            input.dof_runs().into_iter().map(|(channel, _)| TiledDofParams { channel, ..base.clone() }).collect();
        Decision::run_each(runs, why)
    }

    /// The method the camera chose.
    fn likely(camera: &Camera, _velocity: bool) -> bool {
        camera.bokeh == BokehMode::Tiled
    }

    /// The gathers' and the composite's specialisation switches paths on for the lens alone (an
    /// aperture image, a cat's eye, spherical aberration), whatever the frame's size and CoCs:
    /// the parameters of a stand-in frame give the plan's.
    fn prepare_likely(&self, camera: &Camera) -> GpuResult<()> {
        const STAND_IN_PX: u32 = 64;
        const STAND_IN_COC_PX: f64 = 8.0;
        let pitch_mm = camera.pixel_pitch_mm(STAND_IN_PX, STAND_IN_PX);
        let centre_px = [0.5 * STAND_IN_PX as f64; 2];
        let p = TiledDofParams::new(STAND_IN_PX, STAND_IN_PX, STAND_IN_COC_PX, &camera.aperture, 1.0, centre_px);
        let (aperture, aperture_data) = ApertureData::new(
            p.aperture.with_pitch(camera, pitch_mm),
            camera.aperture_mask.as_ref(),
            shape_radius_for(STAND_IN_COC_PX),
        );
        self.prepare(&TiledDofParams { aperture, aperture_data, ..p })
    }

    /// Nine pipelines compile here (on lavapipe 0.5-8 ms of CPU each): dof_highlights', the
    /// largest, and dof_downsample's on a thread of their own beside the others.
    fn new(gpu: &Gpu) -> GpuResult<Self> {
        std::thread::scope(|scope| {
            let beside = scope.spawn(|| Ok::<_, GpuError>((Kernel::new(gpu)?, Kernel::new(gpu)?)));
            let (tiles, classify, sprite_excess) = (Kernel::new(gpu)?, Kernel::new(gpu)?, Kernel::new(gpu)?);
            let (pyramid, bin, bin_order, level_lists) =
                (Kernel::new(gpu)?, Kernel::new(gpu)?, Kernel::new(gpu)?, Kernel::new(gpu)?);
            let (highlights, downsample) =
                beside.join().unwrap_or_else(|_| Err(GpuError::Internal("creating a pipeline panicked".into())))?;
            Ok(TiledDof {
                tiles,
                classify,
                tile_gather: SpecializedKernel::new(gpu)?,
                downsample,
                highlights,
                sprite_excess,
                pyramid,
                bin,
                bin_order,
                level_lists,
                level_gather: SpecializedKernel::new(gpu)?,
                composite: SpecializedKernel::new(gpu)?,
                sprites: SpecializedKernel::new(gpu)?,
            })
        })
    }

    /// The gathers', the composite's and the sprites' pipelines for this lens (the composite with
    /// and without its exact gather), compiled side by side.
    fn prepare(&self, p: &TiledDofParams) -> GpuResult<()> {
        let specialization = p.aperture_data.specialization(&p.aperture);
        let constants = &specialization[..];
        let [exact, blurred] = [true, false].map(|on| composite::specialization(specialization, on));
        std::thread::scope(|scope| {
            let gathers = scope.spawn(|| {
                self.tile_gather.prepare(constants)?;
                self.level_gather.prepare(constants)?;
                self.sprites.prepare(constants)
            });
            let composites = self.composite.prepare(&exact).and(self.composite.prepare(&blurred));
            gathers.join().unwrap_or_else(|_| Err(GpuError::Internal("creating a pipeline panicked".into())))?;
            composites
        })
    }

    /// The whole path: the colour and the run's CoC in, a new colour written for every pixel.
    /// The sprites' excess is taken out of the input colour itself (a pixel each) once every step
    /// that reads it as it was has; a per-channel run (longitudinal colour) puts those pixels
    /// back at its end, for the next channel's run and the passes after.
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &TiledDofParams) -> GpuResult<()> {
        let run = Run::create(rec, images, p)?;
        self.record_classification(rec, &run, p)?;
        self.record_full_resolution(rec, &run)?;
        self.record_highlights(rec, &run, p)?;
        self.record_pyramid_and_bins(rec, &run, p)?;
        self.record_level_gathers(rec, &run, p)?;
        self.record_composites(rec, &run, p)?;
        self.record_sprites(rec, &run, p)?;
        images.set_color(p.channel, run.output);
        Ok(())
    }
}

/// One run's images and buffers, shared by its steps: created by [`Run::create`], then each
/// stage of [`TiledDof::record`] records its steps on them, in this order.
struct Run {
    /// The frame's colour (the sprites' excess is taken out of it, and for a per-channel run put
    /// back) and the run's CoC.
    color: Arc<GpuImage>,
    coc: Arc<GpuImage>,
    /// The new colour, written for every pixel by the tile passes.
    output: Arc<GpuImage>,
    args: Arc<GpuBuffer>,
    tile_coc: Arc<GpuBuffer>,
    tile_lists: Arc<GpuBuffer>,
    level_lists: Arc<GpuBuffer>,
    tile_radius: Arc<GpuBuffer>,
    sprites: Arc<GpuBuffer>,
    candidates: Arc<GpuBuffer>,
    bin_counts: Arc<GpuBuffer>,
    bins: Arc<GpuBuffer>,
    saved: Arc<GpuBuffer>,
    levels: Vec<Level>,
    aperture_mask: Arc<GpuBuffer>,
    aperture_shape: Arc<GpuImage>,
    aperture: ApertureConstants,
    size: [i32; 2],
    tiles: [i32; 2],
    layer_transition_px: f32,
    /// The gathers' and sprites' pipelines without the aperture paths this lens never takes.
    specialization: [u32; 2],
}

impl Run {
    fn create(rec: &mut Recorder, images: &FrameImages, p: &TiledDofParams) -> GpuResult<Run> {
        let (color, coc) = (images.color().clone(), images.coc(p.channel)?.clone());
        let tiles = p.tiles();
        let tile_count = (tiles[0] * tiles[1]) as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let args = rec.create_args_buffer("dof args (indirect dispatches, counters)", ARGS_WORDS)?;
        let tile_coc = rec.create_buffer("dof tile CoC range", tile_count * 8, storage)?;
        let tile_lists = rec.create_buffer("dof tile lists", tile_count * 4 * LIST_COUNT as u64, storage)?;
        let level_lists = rec.create_buffer("dof level gather lists", tile_count * 4 * LEVELS as u64, storage)?;
        // Per tile: the gather radius, the largest foreground radius reaching it, the class.
        let tile_radius = rec.create_buffer("dof tile radius and class", tile_count * 4 * 3, storage)?;
        let sprites = rec.create_buffer("dof sprites", sprite_buffer_bytes(p.sprite_capacity), storage)?;
        let [half_w, half_h] = p.level_size(1);
        let candidates = rec.create_buffer(
            "dof highlight candidates",
            candidate_buffer_bytes(half_w as u64 * half_h as u64),
            storage,
        )?;
        let bin_counts =
            rec.create_buffer("dof sprite bin counts", tile_count * 4, storage | vk::BufferUsageFlags::TRANSFER_DST)?;
        let bins = rec.create_buffer("dof sprite bins", tile_count * 4 * BIN_CAPACITY as u64, storage)?;
        let saved =
            rec.create_buffer("dof sprite pixels as they were", saved_buffer_bytes(p.sprite_capacity), storage)?;
        let rgba = vk::Format::R32G32B32A32_SFLOAT;
        let output = rec.create_image("color (depth of field)", p.width, p.height, rgba)?;
        let mut levels = Vec::new();
        for level in 1..=LEVELS {
            let [lw, lh] = p.level_size(level);
            let image = |rec: &mut Recorder, what: &str, format| {
                rec.create_image(&format!("dof {what} (level {level})"), lw, lh, format)
            };
            levels.push(Level {
                color: image(rec, "colour", rgba)?,
                coc: image(rec, "CoC and weight", vk::Format::R32G32_SFLOAT)?,
                bg: image(rec, "background", rgba)?,
                fg: image(rec, "foreground", rgba)?,
                fg_big: image(rec, "large-CoC foreground", rgba)?,
                coverage: image(rec, "foreground coverage", vk::Format::R32G32_SFLOAT)?,
            });
        }
        let (aperture_mask, aperture_shape) = p.aperture_data.upload(rec)?;
        let (aperture, size, layer_transition_px) = (p.aperture, [p.width as i32, p.height as i32], 1.0);
        // The gathers' and sprites' pipelines without the aperture paths this lens never takes.
        let specialization = p.aperture_data.specialization(&aperture);
        Ok(Run {
            color,
            coc,
            output,
            args,
            tile_coc,
            tile_lists,
            level_lists,
            tile_radius,
            sprites,
            candidates,
            bin_counts,
            bins,
            saved,
            levels,
            aperture_mask,
            aperture_shape,
            aperture,
            size,
            tiles,
            layer_transition_px,
            specialization,
        })
    }

    /// The bindings of both sprite_excess dispatches: the excess taken out, and put back.
    fn excess_bindings(&self) -> SpriteExcessBindings<'_> {
        SpriteExcessBindings { color: &self.color, args: &self.args, sprites: &self.sprites, saved: &self.saved }
    }
}

/// The stages of [`TiledDof::record`], in recording order.
impl TiledDof {
    /// The tiles' CoC ranges, their classes and lists, and the level gathers' lists.
    fn record_classification(&self, rec: &mut Recorder, r: &Run, p: &TiledDofParams) -> GpuResult<()> {
        let (size, tiles) = (r.size, r.tiles);
        tiles::record(&self.tiles, rec, &r.coc, &r.tile_coc, &TilesPush { size, tiles })?;
        let search_tiles = (0.5 * p.max_abs_coc_px / TILE_SIZE as f32).ceil() as i32 + 1;
        let classify = ClassifyPush { tiles, search_tiles, small_radius_px: p.small_radius_px };
        let classify_bindings = ClassifyBindings {
            tile_coc: &r.tile_coc,
            args: &r.args,
            tile_lists: &r.tile_lists,
            tile_radius: &r.tile_radius,
        };
        classify::record(&self.classify, rec, &classify_bindings, &classify)?;

        // The classification -> everything after it: the args feed indirect dispatches
        // (DRAW_INDIRECT stage, indirect-command reads) and the counters; the lists and radii are
        // read by the tile passes. `output` is written from scratch by the tile passes. `color`:
        // written by the pass before (the motion blur) or uploaded; no step of this run has
        // waited for those writes yet (the CoC pass reads the colour only at edges it resolves,
        // and not at all with --keep-edge-depth), and the tile passes read it.
        rec.buffer_barriers(&[
            args_for_indirect(&r.args),
            buffer_after_compute_write(&r.tile_lists),
            buffer_after_compute_write(&r.tile_radius),
        ]);
        rec.image_barriers(&[overwrite(&r.output), after_compute_write(&r.color)]);
        let lists_bindings =
            LevelListsBindings { args: &r.args, tile_radius: &r.tile_radius, level_lists: &r.level_lists };
        level_lists::record(&self.level_lists, rec, &lists_bindings, tiles)?;
        // The level lists and their counts -> the level gathers' indirect dispatches and reads.
        rec.buffer_barriers(&[args_for_indirect(&r.args), buffer_after_compute_write(&r.level_lists)]);
        Ok(())
    }

    /// The copy tiles and the exact small-CoC tiles, at full resolution.
    fn record_full_resolution(&self, rec: &mut Recorder, r: &Run) -> GpuResult<()> {
        let gather_bindings = TileGatherBindings {
            color: &r.color,
            coc: &r.coc,
            output: &r.output,
            tile_lists: &r.tile_lists,
            tile_radius: &r.tile_radius,
            aperture_mask: &r.aperture_mask,
            aperture_shape: &r.aperture_shape,
        };
        let tile_gather = TileGatherPush {
            size: r.size,
            tiles: r.tiles,
            tile_class: 0,
            aperture: r.aperture,
            layer_transition_px: r.layer_transition_px,
        };
        tile_gather::record(&self.tile_gather, &r.specialization, rec, &gather_bindings, &r.args, &tile_gather)
    }

    /// The first level of the pyramid with its highlight candidates, the highlights taken as
    /// sprites, and the sprites' excess taken out of the colour.
    fn record_highlights(&self, rec: &mut Recorder, r: &Run, p: &TiledDofParams) -> GpuResult<()> {
        let size = r.size;
        let level1 = &r.levels[0];
        let downsample = DownsamplePush {
            size,
            half_size: [level1.color.width as i32, level1.color.height as i32],
            small_radius_px: p.small_radius_px,
            highlight_min: p.highlight_min,
            luminance_weights: p.luminance_weights,
        };
        let downsample_bindings = DownsampleBindings {
            color: &r.color,
            coc: &r.coc,
            color_half: &level1.color,
            coc_half: &level1.coc,
            args: &r.args,
            candidates: &r.candidates,
        };
        downsample::record(&self.downsample, rec, &downsample_bindings, &downsample)?;
        let highlights = HighlightsPush {
            size,
            small_radius_px: p.small_radius_px,
            highlight_min: p.highlight_min,
            highlight_ratio: p.highlight_ratio,
            sprite_capacity: p.sprite_capacity as i32,
            sprite_visibility: p.sprite_visibility,
            luminance_weights: p.luminance_weights,
        };
        let highlights_bindings = HighlightsBindings {
            color: &r.color,
            coc: &r.coc,
            color_half: &level1.color,
            args: &r.args,
            candidates: &r.candidates,
            sprites: &r.sprites,
        };
        highlights::record(&self.highlights, rec, &highlights_bindings, &highlights)?;
        // Every step that reads the colour as it was has recorded its reads (the copy and small
        // tiles, dof_downsample, dof_highlights; the pyramid and the level gathers read the
        // levels): the sprites' excess now leaves their pixels, for the composite's exact gathers.
        let excess = SpriteExcessPush { sprite_capacity: p.sprite_capacity as i32, restore: 0 };
        sprite_excess::record(&self.sprite_excess, rec, &r.excess_bindings(), &excess)
    }

    /// The rest of the pyramid, and the sprites binned per tile.
    fn record_pyramid_and_bins(&self, rec: &mut Recorder, r: &Run, p: &TiledDofParams) -> GpuResult<()> {
        let tiles = r.tiles;
        for (level, pair) in (2..).zip(r.levels.windows(2)) {
            let b = PyramidBindings {
                color_fine: &pair[0].color,
                coc_fine: &pair[0].coc,
                color_coarse: &pair[1].color,
                coc_coarse: &pair[1].coc,
            };
            pyramid::record(&self.pyramid, rec, &b, level)?;
        }
        let bin_bindings = BinBindings {
            args: &r.args,
            sprites: &r.sprites,
            tile_radius: &r.tile_radius,
            bin_counts: &r.bin_counts,
            bins: &r.bins,
        };
        let bin_push = BinPush { tiles, sprite_capacity: p.sprite_capacity as i32 };
        bin::record(&self.bin, rec, &bin_bindings, &bin_push, ARGS_BIN_DISPATCH as u64 * 4)?;
        let order_bindings = BinOrderBindings {
            sprites: &r.sprites,
            bin_counts: &r.bin_counts,
            bins: &r.bins,
            args: &r.args,
            tile_lists: &r.tile_lists,
        };
        bin_order::record(&self.bin_order, rec, &order_bindings, (tiles[0] * tiles[1]) as u32)
    }

    /// Each level's gather over the tiles listed for it.
    fn record_level_gathers(&self, rec: &mut Recorder, r: &Run, p: &TiledDofParams) -> GpuResult<()> {
        for (level, l) in (1..).zip(&r.levels) {
            let to_level = 1.0 / (1u32 << level) as f32;
            let push = LevelGatherPush {
                level_size: [l.color.width as i32, l.color.height as i32],
                tiles: r.tiles,
                level: level as i32,
                aperture: r.aperture.at_level(level),
                layer_transition_px: r.layer_transition_px * to_level,
                small_radius_px: exact_radius_px(level, p.small_radius_px) * to_level,
            };
            let b = LevelGatherBindings {
                color_level: &l.color,
                coc_level: &l.coc,
                bg_level: &l.bg,
                fg_level: &l.fg,
                level_lists: &r.level_lists,
                tile_radius: &r.tile_radius,
                aperture_mask: &r.aperture_mask,
                fg_big_level: &l.fg_big,
                args: &r.args,
                aperture_shape: &r.aperture_shape,
                coverage_level: &l.coverage,
            };
            level_gather::record(&self.level_gather, &r.specialization, rec, &b, &push)?;
        }
        Ok(())
    }

    /// The levels' layers composited at full resolution.
    fn record_composites(&self, rec: &mut Recorder, r: &Run, p: &TiledDofParams) -> GpuResult<()> {
        // Per level two composites: the class list with the exact gather for nearly sharp pixels,
        // the blurred list (no such pixel) with a pipeline that has no exact gather in its code.
        let composite_exact = composite::specialization(r.specialization, true);
        let composite_blurred = composite::specialization(r.specialization, false);
        for (level, l) in (1..).zip(&r.levels) {
            let lists = [(CLASS_LEVEL1, &composite_exact), (LIST_BLURRED_LEVEL1, &composite_blurred)];
            for (first, constants) in lists {
                let list = first + level as u32 - 1;
                let push = CompositePush {
                    size: r.size,
                    level_size: [l.color.width as i32, l.color.height as i32],
                    tiles: r.tiles,
                    level,
                    small_radius_px: exact_radius_px(level as u32, p.small_radius_px),
                    aperture: r.aperture,
                    layer_transition_px: r.layer_transition_px,
                    list: list as i32,
                };
                let b = CompositeBindings {
                    // The exact gather of nearly sharp pixels reads the colour less the sprites' energy.
                    color: &r.color,
                    coc: &r.coc,
                    bg_level: &l.bg,
                    fg_level: &l.fg,
                    output: &r.output,
                    tile_lists: &r.tile_lists,
                    aperture_mask: &r.aperture_mask,
                    coc_level: &l.coc,
                    fg_big_level: &l.fg_big,
                    tile_radius: &r.tile_radius,
                    aperture_shape: &r.aperture_shape,
                    coverage_level: &l.coverage,
                };
                composite::record(&self.composite, &constants[..], rec, &b, &r.args, &push)?;
            }
        }
        Ok(())
    }

    /// The highlight sprites over the composites, and for a per-channel run the sprites' pixels
    /// put back in the colour.
    fn record_sprites(&self, rec: &mut Recorder, r: &Run, p: &TiledDofParams) -> GpuResult<()> {
        // The highlight sprites over the composites, on the tiles that have any.
        let sprites_bindings = SpritesBindings {
            output: &r.output,
            coc: &r.coc,
            tile_lists: &r.tile_lists,
            sprites: &r.sprites,
            bin_counts: &r.bin_counts,
            bins: &r.bins,
            args: &r.args,
            aperture_mask: &r.aperture_mask,
            aperture_shape: &r.aperture_shape,
        };
        let sprites_push = SpritesPush {
            size: r.size,
            tiles: r.tiles,
            aperture: r.aperture,
            sprite_capacity: p.sprite_capacity as i32,
        };
        sprites::record(&self.sprites, &r.specialization, rec, &sprites_bindings, &sprites_push)?;
        if p.channel.is_some() {
            // Longitudinal colour: each channel's run reads the input colour, which stays the
            // frame's colour after this run (the next channel's run and the passes before
            // longitudinal_color read it): the sprites' pixels as they were.
            let restore = SpriteExcessPush { sprite_capacity: p.sprite_capacity as i32, restore: 1 };
            sprite_excess::record(&self.sprite_excess, rec, &r.excess_bindings(), &restore)?;
            // Those readers take the colour as the upload left it, visible to compute reads with
            // no barrier of their own: this write made visible to them here.
            rec.image_barriers(&[after_compute_write(&r.color)]);
        }
        Ok(())
    }
}
