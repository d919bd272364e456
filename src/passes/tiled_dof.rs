//! The tiled depth-of-field path, in order: tiles -> classify -> (copy | exact small gather)
//! tiles, and for large-CoC tiles downsample (+ highlight sprites) -> half-resolution fixed-tap
//! gather -> composite -> sprites. Its cost is nearly flat in the CoC radius: full-resolution
//! work is bounded by `small_radius_px`, the half-resolution gather has a fixed tap count, and
//! only highlights are scattered. Each step is its own pass module; this file only owns the
//! buffers they share and the barriers between the classification and its indirect dispatches.

use super::aperture::ApertureConstants;
use super::dof_classify::{ClassifyParams, DofClassifyPass};
use super::dof_composite::{CompositeBindings, CompositeParams, DofCompositePass};
use super::dof_downsample::{DofDownsamplePass, DownsampleParams};
use super::dof_half_gather::{DofHalfGatherPass, HalfGatherParams};
use super::dof_sprites::{DofSpritesPass, SpritesParams};
use super::dof_tile_gather::{DofTileGatherPass, TileGatherBindings, TileGatherParams};
use super::dof_tiles::{DofTilesPass, TilesParams};
use super::TILE_SIZE;
use crate::gpu::{Gpu, GpuBuffer, GpuImage, GpuResult, Recorder};
use crate::model::aperture::ApertureShape;
use ash::vk;
use gpu_allocator::MemoryLocation;

/// Words in the args buffer (glsl/include/dof_tiles.glsl ARGS_WORDS).
const ARGS_WORDS: u64 = 12;
/// Bytes of one sprite (struct Sprite in glsl/include/dof_tiles.glsl).
const SPRITE_BYTES: u64 = 32;

/// Settings of the tiled path.
#[derive(Clone, Copy, Debug, PartialEq)]
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
        }
    }

    pub fn tiles(&self) -> [i32; 2] {
        [self.width.div_ceil(TILE_SIZE) as i32, self.height.div_ceil(TILE_SIZE) as i32]
    }

    fn half_size(&self) -> [i32; 2] {
        [self.width.div_ceil(2) as i32, self.height.div_ceil(2) as i32]
    }
}

/// The pipelines of the tiled path.
pub struct TiledDof {
    tiles: DofTilesPass,
    classify: DofClassifyPass,
    tile_gather: DofTileGatherPass,
    downsample: DofDownsamplePass,
    half_gather: DofHalfGatherPass,
    composite: DofCompositePass,
    sprites: DofSpritesPass,
}

/// Buffers and images of one frame, kept alive until the recording is submitted.
pub struct TiledFrame {
    pub args: GpuBuffer,
    pub tile_coc: GpuBuffer,
    pub tile_lists: GpuBuffer,
    pub tile_radius: GpuBuffer,
    pub sprites: GpuBuffer,
    pub images: Vec<GpuImage>,
}

impl TiledDof {
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(TiledDof {
            tiles: DofTilesPass::new(gpu)?,
            classify: DofClassifyPass::new(gpu)?,
            tile_gather: DofTileGatherPass::new(gpu)?,
            downsample: DofDownsamplePass::new(gpu)?,
            half_gather: DofHalfGatherPass::new(gpu)?,
            composite: DofCompositePass::new(gpu)?,
            sprites: DofSpritesPass::new(gpu)?,
        })
    }

    /// Record the whole path: `color` and `coc` in, `output` written for every pixel.
    pub fn record(
        &self,
        rec: &mut Recorder,
        color: &GpuImage,
        coc: &GpuImage,
        output: &GpuImage,
        aperture_mask: &GpuBuffer,
        p: &TiledDofParams,
    ) -> GpuResult<TiledFrame> {
        let gpu = rec.gpu().clone();
        let tiles = p.tiles();
        let tile_count = (tiles[0] * tiles[1]) as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let device = MemoryLocation::GpuOnly;
        let args = gpu.create_buffer(
            "dof args (indirect dispatches, sprite count)",
            ARGS_WORDS * 4,
            storage | vk::BufferUsageFlags::INDIRECT_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            device,
        )?;
        let tile_coc = gpu.create_buffer("dof tile CoC range", tile_count * 8, storage, device)?;
        let tile_lists = gpu.create_buffer("dof tile lists", tile_count * 4 * 3, storage, device)?;
        // Per tile: the gather radius, then the largest foreground radius reaching it.
        let tile_radius = gpu.create_buffer("dof tile radius", tile_count * 4 * 2, storage, device)?;
        let sprites = gpu.create_buffer("dof sprites", p.sprite_capacity as u64 * SPRITE_BYTES, storage, device)?;
        let [hw, hh] = p.half_size();
        let rgba = vk::Format::R32G32B32A32_SFLOAT;
        let color_half = gpu.create_image("dof colour (half)", hw as u32, hh as u32, rgba)?;
        let coc_half = gpu.create_image("dof coc (half)", hw as u32, hh as u32, vk::Format::R32_SFLOAT)?;
        let bg_half = gpu.create_image("dof background (half)", hw as u32, hh as u32, rgba)?;
        let fg_half = gpu.create_image("dof foreground (half)", hw as u32, hh as u32, rgba)?;
        let fg_big_half = gpu.create_image("dof large-CoC foreground (half)", hw as u32, hh as u32, rgba)?;
        let color_base = gpu.create_image("dof colour less sprites", p.width, p.height, rgba)?;
        let aperture = p.aperture;
        let size = [p.width as i32, p.height as i32];

        self.tiles.record(rec, coc, &tile_coc, &TilesParams { size, tiles })?;
        // The counters start at zero every frame.
        rec.fill_buffer(&args, 0);
        let search_tiles = (0.5 * p.max_abs_coc_px / TILE_SIZE as f32).ceil() as i32 + 1;
        let classify = ClassifyParams { tiles, search_tiles, small_radius_px: p.small_radius_px };
        self.classify.record(rec, &tile_coc, &args, &tile_lists, &tile_radius, &classify)?;

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
            super::buffer_after_compute_write(&tile_lists),
            super::buffer_after_compute_write(&tile_radius),
        ]);
        rec.image_barriers(&[super::overwrite(output)]);

        let layer_transition_px = 1.0;
        self.tile_gather.record(
            rec,
            &TileGatherBindings {
                color,
                coc,
                output,
                tile_lists: &tile_lists,
                tile_radius: &tile_radius,
                args: &args,
                aperture_mask,
            },
            &TileGatherParams { size, tiles, tile_class: 0, aperture, layer_transition_px },
        )?;
        let downsample = DownsampleParams {
            size,
            half_size: [hw, hh],
            small_radius_px: p.small_radius_px,
            highlight_min: p.highlight_min,
            highlight_ratio: p.highlight_ratio,
            sprite_capacity: p.sprite_capacity as i32,
            sprite_visibility: p.sprite_visibility,
        };
        self.downsample.record(rec, color, coc, &color_half, &coc_half, &args, &sprites, &color_base, &downsample)?;
        let half = HalfGatherParams {
            half_size: [hw, hh],
            tiles,
            rings: p.rings,
            // The half-resolution gather works in half-size pixel units.
            aperture: aperture.half_resolution(),
            layer_transition_px,
            small_radius_px: 0.5 * p.small_radius_px,
        };
        self.half_gather.record(
            rec,
            &color_half,
            &coc_half,
            &bg_half,
            &fg_half,
            &fg_big_half,
            &tile_lists,
            &tile_radius,
            &args,
            aperture_mask,
            &half,
        )?;
        let composite = CompositeParams {
            size,
            half_size: [hw, hh],
            tiles,
            small_radius_px: p.small_radius_px,
            aperture,
            layer_transition_px,
        };
        self.composite.record(
            rec,
            // The exact gather of nearly sharp pixels reads the colour less the sprites' energy.
            &CompositeBindings {
                color: &color_base,
                coc,
                bg_half: &bg_half,
                fg_half: &fg_half,
                output,
                tile_lists: &tile_lists,
                args: &args,
                aperture_mask,
                coc_half: &coc_half,
                fg_big_half: &fg_big_half,
                tile_radius: &tile_radius,
            },
            &composite,
        )?;
        let sprites_params = SpritesParams { size, tiles, aperture, sprite_capacity: p.sprite_capacity as i32 };
        self.sprites.record(rec, coc, output, &args, &sprites, &tile_lists, aperture_mask, &sprites_params)?;
        Ok(TiledFrame {
            args,
            tile_coc,
            tile_lists,
            tile_radius,
            sprites,
            images: vec![color_half, coc_half, bg_half, fg_half, fg_big_half, color_base],
        })
    }
}
