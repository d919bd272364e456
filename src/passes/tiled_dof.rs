//! The tiled depth-of-field path (`--bokeh tiled`, the default), in order: tiles -> classify ->
//! (copy | exact small gather) tiles, and for large-CoC tiles downsample (+ highlight sprites)
//! -> half-resolution fixed-tap gather -> composite -> sprites. Its cost is nearly flat in the
//! CoC radius: full-resolution work is bounded by `small_radius_px`, the half-resolution gather
//! has a fixed tap count, and only highlights are scattered. Each step is its own module with
//! its shader and CPU twin; this pass plans the path, owns the buffers the steps share and the
//! barriers between the classification and its indirect dispatches.

use super::aperture::{mask_buffer_data, ApertureConstants};
use super::barriers::{buffer_after_compute_write, overwrite};
use super::dof_classify::{ClassifyBindings, ClassifyPush, ClassifyShader};
use super::dof_composite::{CompositeBindings, CompositePush, CompositeShader};
use super::dof_downsample::{DownsampleBindings, DownsamplePush, DownsampleShader};
use super::dof_half_gather::{HalfGatherBindings, HalfGatherPush, HalfGatherShader};
use super::dof_sprites::{SpritesBindings, SpritesPush, SpritesShader};
use super::dof_tile_gather::{TileGatherBindings, TileGatherPush, TileGatherShader};
use super::dof_tiles::{TilesPush, TilesShader};
use super::scene::{Channel, PlanInput, VISIBLE_COC_PX};
use super::{dof_classify, dof_composite, dof_downsample, dof_half_gather, dof_sprites, dof_tile_gather, dof_tiles};
use super::{Decision, FrameImages, Pass, TILE_SIZE};
use crate::gpu::shaders::dof_tiles::{ARGS_WORDS, CLASS_COUNT, SPRITE_WORDS};
use crate::gpu::{Gpu, GpuResult, Kernel, Recorder};
use crate::model::aperture::ApertureShape;
use crate::model::camera::BokehMode;
use ash::vk;

pub const NAME: &str = "bokeh_tiled";

/// Settings of one run of the tiled path.
#[derive(Clone, Debug, PartialEq)]
pub struct TiledDofParams {
    pub width: u32,
    pub height: u32,
    /// Tiles whose gather radius is at most this use the exact full-resolution gather.
    pub small_radius_px: f32,
    /// Rings of the half-resolution gather (1 + 3 r (r + 1) taps).
    pub rings: i32,
    /// A highlight is at least this bright (luminance, in input units) ...
    pub highlight_min: f32,
    /// ... and this many times brighter than its neighbours' mean.
    pub highlight_ratio: f32,
    pub sprite_capacity: u32,
    /// A highlight becomes a sprite only if its excess spread over its CoC is at least this
    /// fraction of its surroundings' luminance per pixel.
    pub sprite_visibility: f32,
    /// Largest |CoC| diameter in the frame (after the clamp), for the dilation search.
    pub max_abs_coc_px: f32,
    /// The aperture, in full-resolution pixel units.
    pub aperture: ApertureConstants,
    /// The aperture image's buffer ([`mask_buffer_data`]).
    pub aperture_mask: Vec<f32>,
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
        TiledDofParams {
            width,
            height,
            small_radius_px: 8.0,
            rings: 8,
            highlight_min: 1.0,
            highlight_ratio: 4.0,
            sprite_capacity: 16384,
            sprite_visibility: 0.05,
            max_abs_coc_px: max_abs_coc_px as f32,
            aperture: ApertureConstants::new(aperture, sa_max_coc_px, centre_px, width, height),
            aperture_mask: mask_buffer_data(None),
            channel: None,
        }
    }

    pub fn tiles(&self) -> [i32; 2] {
        [self.width.div_ceil(TILE_SIZE) as i32, self.height.div_ceil(TILE_SIZE) as i32]
    }

    fn half_size(&self) -> [i32; 2] {
        [self.width.div_ceil(2) as i32, self.height.div_ceil(2) as i32]
    }
}

/// The pipelines of the tiled path, one per step.
pub struct TiledDof {
    tiles: Kernel<TilesShader>,
    classify: Kernel<ClassifyShader>,
    tile_gather: Kernel<TileGatherShader>,
    downsample: Kernel<DownsampleShader>,
    half_gather: Kernel<HalfGatherShader>,
    composite: Kernel<CompositeShader>,
    sprites: Kernel<SpritesShader>,
}

impl Pass for TiledDof {
    const NAME: &'static str = NAME;
    type Params = TiledDofParams;

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
        base.aperture = base.aperture.with_pitch(camera, f.pixel_pitch_mm);
        base.aperture_mask = mask_buffer_data(camera.aperture_mask.as_ref());
        let why = format!(
            "largest CoC {max_abs_coc_px:.1} px > {VISIBLE_COC_PX} px: {}x{} tiles of {TILE_SIZE} px; in-focus tiles copied, CoC radius <= {} px gathered exactly, larger at half resolution ({} rings) with highlight sprites; {}",
            base.tiles()[0],
            base.tiles()[1],
            base.small_radius_px,
            base.rings,
            input.aperture_text()
        );
        let runs =
            input.dof_runs().into_iter().map(|(channel, _)| TiledDofParams { channel, ..base.clone() }).collect();
        Decision::run_each(runs, why)
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(TiledDof {
            tiles: Kernel::new(gpu)?,
            classify: Kernel::new(gpu)?,
            tile_gather: Kernel::new(gpu)?,
            downsample: Kernel::new(gpu)?,
            half_gather: Kernel::new(gpu)?,
            composite: Kernel::new(gpu)?,
            sprites: Kernel::new(gpu)?,
        })
    }

    /// The whole path: the colour and the run's CoC in, a new colour written for every pixel.
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &TiledDofParams) -> GpuResult<()> {
        let (color, coc) = (images.color().clone(), images.coc(p.channel)?.clone());
        let tiles = p.tiles();
        let tile_count = (tiles[0] * tiles[1]) as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let args = rec.create_buffer(
            "dof args (indirect dispatches, sprite count)",
            ARGS_WORDS as u64 * 4,
            storage | vk::BufferUsageFlags::INDIRECT_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
        )?;
        let tile_coc = rec.create_buffer("dof tile CoC range", tile_count * 8, storage)?;
        let tile_lists = rec.create_buffer("dof tile lists", tile_count * 4 * CLASS_COUNT as u64, storage)?;
        // Per tile: the gather radius, then the largest foreground radius reaching it.
        let tile_radius = rec.create_buffer("dof tile radius", tile_count * 4 * 2, storage)?;
        let sprites = rec.create_buffer("dof sprites", p.sprite_capacity as u64 * SPRITE_WORDS as u64 * 4, storage)?;
        let [hw, hh] = p.half_size();
        let rgba = vk::Format::R32G32B32A32_SFLOAT;
        let half_image = |rec: &mut Recorder, name: &str, format| rec.create_image(name, hw as u32, hh as u32, format);
        let color_half = half_image(rec, "dof colour (half)", rgba)?;
        let coc_half = half_image(rec, "dof coc (half)", vk::Format::R32_SFLOAT)?;
        let bg_half = half_image(rec, "dof background (half)", rgba)?;
        let fg_half = half_image(rec, "dof foreground (half)", rgba)?;
        let fg_big_half = half_image(rec, "dof large-CoC foreground (half)", rgba)?;
        let color_base = rec.create_image("dof colour less sprites", p.width, p.height, rgba)?;
        let output = rec.create_image("color (depth of field)", p.width, p.height, rgba)?;
        let aperture_mask = rec.upload_buffer("aperture image", &p.aperture_mask)?;
        let (aperture, size, layer_transition_px) = (p.aperture, [p.width as i32, p.height as i32], 1.0);

        dof_tiles::record(&self.tiles, rec, &coc, &tile_coc, &TilesPush { size, tiles })?;
        let search_tiles = (0.5 * p.max_abs_coc_px / TILE_SIZE as f32).ceil() as i32 + 1;
        let classify = ClassifyPush { tiles, search_tiles, small_radius_px: p.small_radius_px };
        let classify_bindings =
            ClassifyBindings { tile_coc: &tile_coc, args: &args, tile_lists: &tile_lists, tile_radius: &tile_radius };
        dof_classify::record(&self.classify, rec, &classify_bindings, &classify)?;

        // The classification -> everything after it: the args feed indirect dispatches
        // (DRAW_INDIRECT stage, indirect-command reads) and the sprite counter; the lists and
        // radii are read by the tile passes. `output` is written from scratch by the tile passes.
        let indirect = vk::BufferMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::DRAW_INDIRECT | vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(
                vk::AccessFlags2::INDIRECT_COMMAND_READ
                    | vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            )
            .buffer(args.buffer)
            .offset(0)
            .size(vk::WHOLE_SIZE);
        rec.buffer_barriers(&[
            indirect,
            buffer_after_compute_write(&tile_lists),
            buffer_after_compute_write(&tile_radius),
        ]);
        rec.image_barriers(&[overwrite(&output)]);

        let gather_bindings = TileGatherBindings {
            color: &color,
            coc: &coc,
            output: &output,
            tile_lists: &tile_lists,
            tile_radius: &tile_radius,
            aperture_mask: &aperture_mask,
        };
        let tile_gather = TileGatherPush { size, tiles, tile_class: 0, aperture, layer_transition_px };
        dof_tile_gather::record(&self.tile_gather, rec, &gather_bindings, &args, &tile_gather)?;
        let downsample = DownsamplePush {
            size,
            half_size: [hw, hh],
            small_radius_px: p.small_radius_px,
            highlight_min: p.highlight_min,
            highlight_ratio: p.highlight_ratio,
            sprite_capacity: p.sprite_capacity as i32,
            sprite_visibility: p.sprite_visibility,
        };
        let downsample_bindings = DownsampleBindings {
            color: &color,
            coc: &coc,
            color_half: &color_half,
            coc_half: &coc_half,
            args: &args,
            sprites: &sprites,
            color_base: &color_base,
        };
        dof_downsample::record(&self.downsample, rec, &downsample_bindings, &downsample)?;
        let half = HalfGatherPush {
            half_size: [hw, hh],
            tiles,
            rings: p.rings,
            // The half-resolution gather works in half-size pixel units.
            aperture: aperture.half_resolution(),
            layer_transition_px,
            small_radius_px: 0.5 * p.small_radius_px,
        };
        let half_bindings = HalfGatherBindings {
            color_half: &color_half,
            coc_half: &coc_half,
            bg_half: &bg_half,
            fg_half: &fg_half,
            fg_big_half: &fg_big_half,
            tile_lists: &tile_lists,
            tile_radius: &tile_radius,
            aperture_mask: &aperture_mask,
        };
        dof_half_gather::record(&self.half_gather, rec, &half_bindings, &args, &half)?;
        let composite = CompositePush {
            size,
            half_size: [hw, hh],
            tiles,
            small_radius_px: p.small_radius_px,
            aperture,
            layer_transition_px,
        };
        let composite_bindings = CompositeBindings {
            // The exact gather of nearly sharp pixels reads the colour less the sprites' energy.
            color: &color_base,
            coc: &coc,
            bg_half: &bg_half,
            fg_half: &fg_half,
            output: &output,
            tile_lists: &tile_lists,
            aperture_mask: &aperture_mask,
            coc_half: &coc_half,
            fg_big_half: &fg_big_half,
            tile_radius: &tile_radius,
        };
        dof_composite::record(&self.composite, rec, &composite_bindings, &args, &composite)?;
        let sprite_bindings = SpritesBindings {
            coc: &coc,
            output: &output,
            args: &args,
            sprites: &sprites,
            tile_lists: &tile_lists,
            aperture_mask: &aperture_mask,
        };
        let sprites_push = SpritesPush { size, tiles, aperture, sprite_capacity: p.sprite_capacity as i32 };
        dof_sprites::record(&self.sprites, rec, &sprite_bindings, &sprites_push)?;
        images.set_color(p.channel, output);
        Ok(())
    }
}
