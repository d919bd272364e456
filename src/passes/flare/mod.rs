//! Lens flare (Walch 2017 sec. 3.2): the ghosts of the lens's inner reflections, the starburst
//! of its aperture's diffraction and the halo of its scattering, around the lights of the frame
//! (pixels the exposure saturates by the chosen factor) and the lights given explicitly. One
//! pass of four shaders, each a module (named here by its shader):
//!   1. `flare_tiles` (`tiles`): per 16x16 tile, the light pixels' energy, count and position;
//!   2. `flare_lights` (`lights`): the tiles gathered into a short list of lights, and each
//!      light's flare elements as sprites with tight bounds (the ghosts of the matrix model,
//!      src/optics/flare/ghosts.rs, or Walch's fitted primitives, `fitted`; the starburst's
//!      spikes and glow and the halo, src/optics/flare/starburst.rs), none where an element
//!      would not show;
//!   3. `flare_bins` (`bins`): each sprite sorted against the tiles its bounds touch (away,
//!      covering, crossing), once per frame, into per-tile bin words;
//!   4. `ghost_sprites`: the ghost-sprite kernel, each tile's binned sprites added, every output
//!      pixel written once;
//!   5. `fitted_ghosts` (a lens with Walch's fitted ghosts only): the fitted sprites' light on
//!      the tiles they cross, one invocation per tile.
//!
//! The steps read the constants and the ghost table this pass writes from `types`, and one
//! sprite's geometry from `sprite`; none imports this module or another step.
//!
//! The plan skips the pass when no light in the frame could make an element add a thousandth of
//! the sensor's saturation, and says how bright a light would have to be.

pub mod bins;
pub mod fitted;
pub mod fitted_ghosts;
pub mod ghost_shape;
pub mod ghost_sprites;
pub mod lights;
pub mod sprite;
pub mod tiles;
pub mod types;

use crate::gpu::shaders::flare::{ARGS_WORDS, EXPLICIT_WORDS, LIGHT_WORDS, SPRITE_WORDS, TILE_WORDS};
use crate::gpu::{Gpu, GpuResult, Kernel, Recorder, SpecializedKernel};
use crate::model::camera::Camera;
use crate::optics::flare::ghosts::{GhostCatalogue, GhostPath, MatrixGhost};
use crate::optics::flare::starburst::{Halo, Starburst};
use crate::optics::flare::{channel_nm, AperturePolygon, FlareLens};
use crate::passes::scene::PlanInput;
use crate::passes::{Decision, FrameImages, Pass, TILE_SIZE};
use ash::vk;
use bins::{FlareBinsBindings, FlareBinsShader};
use fitted::FittedGhosts;
use fitted_ghosts::{FittedGhostsBindings, FittedGhostsShader};
use ghost_sprites::{GhostSpritesBindings, GhostSpritesShader};
use lights::{FlareLightsBindings, FlareLightsShader};
use tiles::{light_weight, FlareTilesShader};
use types::{constants_words, ghost_table, FlareConstants};

pub const NAME: &str = "flare";

/// A flare element is drawn where it adds at least this share of the sensor's saturation.
pub const VISIBLE_FLARE: f64 = 1.0e-3;
/// How many lights the list holds (the shader's MAX_LIGHTS is the most).
pub const MAX_LIGHTS: u32 = 32;
/// A ghost focused to a point is drawn with this radius (px), its energy kept.
pub const MIN_GHOST_RADIUS_PX: f64 = 1.0;

/// The camera's flare model on a frame of this pixel pitch: the lens's ghosts (with a
/// prescription), its starburst and halo, and what a light of unit energy makes of them.
#[derive(Clone, Debug)]
pub struct FlareModel {
    pub lens: Option<FlareLens>,
    pub catalogue: Option<GhostCatalogue>,
    pub starburst: Starburst,
    pub halo: Halo,
    pub pixel_pitch_mm: f64,
    pub centre_px: [f64; 2],
    /// Walch's fitted primitives, when they draw the ghosts instead of the matrices
    /// ([`FlareModel::chosen`]).
    pub fitted: Option<FittedGhosts>,
}

/// The brightest flare element of a light, per unit of its energy.
#[derive(Clone, Debug, PartialEq)]
pub struct Peak {
    pub what: String,
    /// Scene value per pixel, per channel, per unit of the light's energy (value x pixels).
    pub per_energy: [f64; 3],
}

impl FlareModel {
    pub fn new(camera: &Camera, pixel_pitch_mm: f64, centre_px: [f64; 2]) -> FlareModel {
        let shape = &camera.aperture;
        let aperture = AperturePolygon {
            blades: if shape.blades >= 3 { shape.blades } else { 0 },
            rotation_rad: shape.rotation_deg.to_radians(),
            curvature: if shape.blades >= 3 { shape.curvature.clamp(0.0, 1.0) } else { 1.0 },
        };
        let lens = camera.flare.prescription.as_ref().map(|p| {
            let extension_mm = camera.lens.image_distance_mm() - camera.lens.focal_length_mm;
            FlareLens::new(p, camera.lens.f_number, extension_mm, camera.flare.coating_design_nm, aperture)
        });
        let catalogue = lens.as_ref().map(|l| GhostCatalogue::new(l, 1e-12));
        FlareModel {
            lens,
            catalogue,
            starburst: Starburst { aperture, working_f_number: camera.lens.effective_f_number() },
            halo: camera.flare.halo,
            pixel_pitch_mm,
            centre_px,
            fitted: None,
        }
    }

    /// The model `--flare-ghosts` chooses: the matrix ghosts of [`FlareModel::new`], or the lens
    /// file's fitted primitives drawing the ghosts instead (auto: when it has them).
    pub fn chosen(camera: &Camera, pixel_pitch_mm: f64, centre_px: [f64; 2]) -> FlareModel {
        let mut model = FlareModel::new(camera, pixel_pitch_mm, centre_px);
        if camera.flare.ghosts.draws_fitted(camera.flare.fitted.len()) {
            model.fitted = Some(FittedGhosts::new(camera, pixel_pitch_mm));
        }
        model
    }

    /// The light's image height per unit slope (mm): the prescription's, or the focal length.
    pub fn g0_mm(&self, camera: &Camera) -> f64 {
        self.catalogue.as_ref().map_or(camera.lens.focal_length_mm, |c| c.direct.centre_mm[1])
    }

    /// A ghost's light per pixel for a light of unit energy on the axis, per channel.
    pub fn ghost_peak(&self, ghost: &MatrixGhost) -> [f64; 3] {
        let af = self.starburst.aperture.area_factor();
        std::array::from_fn(|c| {
            ghost.channels[c]
                .shape([0.0; 2], self.centre_px, self.pixel_pitch_mm, MIN_GHOST_RADIUS_PX, af)
                .irradiance_per_energy
        })
    }

    /// The spikes' light in the pixel next to the light, per channel, per unit energy.
    pub fn spike_peak(&self) -> [f64; 3] {
        let edges = if self.starburst.aperture.blades.is_multiple_of(2) { 2.0 } else { 1.0 };
        std::array::from_fn(|c| edges * self.starburst.spike_coefficient(channel_nm(c)) / self.pixel_pitch_mm)
    }

    /// The glow's (round diffraction and halo) light a pixel from the light, per unit energy.
    pub fn glow_peak(&self) -> [f64; 3] {
        let rho_px = self.halo.radius_mm / self.pixel_pitch_mm;
        let halo = if rho_px > 0.0 {
            self.halo.fraction / (2.0 * std::f64::consts::PI * rho_px * rho_px)
                * (1.0 + 1.0 / (rho_px * rho_px)).powf(-1.5)
        } else {
            0.0
        };
        std::array::from_fn(|c| self.starburst.glow_coefficient(channel_nm(c)) / self.pixel_pitch_mm + halo)
    }

    /// Every element's peak, named.
    pub fn peaks(&self) -> Vec<(Option<GhostPath>, Peak)> {
        let mut peaks = Vec::new();
        if let Some(f) = &self.fitted {
            for (k, spec) in f.specs.iter().enumerate() {
                let what = format!("the fitted ghost {} (channel {})", spec.ghost, spec.channel);
                peaks.push((None, Peak { what, per_energy: f.peak_per_energy(k) }));
            }
        }
        let matrix = if self.fitted.is_some() { None } else { self.catalogue.as_ref() };
        for g in matrix.iter().flat_map(|c| &c.ghosts) {
            let what = format!("the ghost of surfaces {} and {}", g.path.first, g.path.second);
            peaks.push((Some(g.path), Peak { what, per_energy: self.ghost_peak(g) }));
        }
        let spikes = self.starburst.spikes().len();
        if spikes > 0 {
            peaks.push((None, Peak { what: format!("the {spikes}-spike starburst"), per_energy: self.spike_peak() }));
        }
        let glow = self.glow_peak();
        if glow.iter().any(|&v| v > 0.0) {
            let what = if self.halo.fraction > 0.0 { "the halo" } else { "the aperture's diffraction" };
            peaks.push((None, Peak { what: what.into(), per_energy: glow }));
        }
        peaks
    }
}

/// The light of the frame's pixels over a threshold: how many, and their energy per channel.
fn lit_pixels(color: &[f32], threshold: f32) -> (usize, [f64; 3]) {
    let mut count = 0;
    let mut energy = [0.0; 3];
    for px in color.chunks_exact(4) {
        if light_weight(&px[..3], threshold).is_some() {
            count += 1;
            energy.iter_mut().zip(px).for_each(|(e, &v)| *e += v as f64);
        }
    }
    (count, energy)
}

/// One run of the pass: its constants and tables.
#[derive(Clone, Debug)]
pub struct FlareParams {
    pub constants: FlareConstants,
    pub ghost_table: Vec<f32>,
    /// The explicit lights (EXPLICIT_WORDS each; [0] for none).
    pub explicit: Vec<f32>,
    /// The ghosts in the table, in order.
    pub ghosts: Vec<GhostPath>,
    pub max_lights: u32,
    /// Banded rendering: the whole frame's tile records ([`tiles::tile_records`]), uploaded
    /// instead of summed from the band, so the lights are the whole frame's.
    pub whole_frame_tiles: Option<std::sync::Arc<Vec<f32>>>,
}

impl FlareParams {
    /// The constants and tables for `ghosts` of `model` (all of its catalogue's if None).
    pub fn new(input: &PlanInput<'_>, model: &FlareModel, ghosts: Option<&[GhostPath]>) -> FlareParams {
        let (camera, frame) = (input.camera, input.frame);
        let gain = camera.exposure_gain();
        let pitch = model.pixel_pitch_mm;
        let g0 = model.g0_mm(camera);
        // The fitted primitives draw the ghosts instead of the matrices when the model has them.
        let chosen: Vec<MatrixGhost> = model
            .catalogue
            .iter()
            .filter(|_| model.fitted.is_none())
            .flat_map(|c| &c.ghosts)
            .filter(|g| !matches!(ghosts, Some(list) if !list.contains(&g.path)))
            .cloned()
            .collect();
        let fitted_count = model.fitted.as_ref().map_or(0, |f| f.specs.len());
        let spike_count = model.starburst.spikes().len() as i32;
        let a = model.starburst.aperture;
        let explicit: Vec<f32> = camera
            .flare
            .lights
            .iter()
            .flat_map(|l| {
                let mut w = vec![0.0f32; EXPLICIT_WORDS as usize];
                w[..6].copy_from_slice(&[
                    l.x_px as f32,
                    l.y_px as f32,
                    l.energy[0] as f32,
                    l.energy[1] as f32,
                    l.energy[2] as f32,
                    l.area_px as f32,
                ]);
                w
            })
            .collect();
        let constants = FlareConstants {
            width: frame.width as i32,
            height: frame.height as i32,
            tiles_x: frame.width.div_ceil(TILE_SIZE) as i32,
            tiles_y: frame.height.div_ceil(TILE_SIZE) as i32,
            threshold: (camera.flare.threshold / gain) as f32,
            visible: (VISIBLE_FLARE / gain) as f32,
            pitch_mm: pitch as f32,
            centre_x: frame.centre_px[0] as f32,
            centre_y: frame.centre_px[1] as f32,
            g0_mm: g0 as f32,
            ghost_count: chosen.len() as i32,
            merge_tiles: 1,
            explicit_count: camera.flare.lights.len().min(MAX_LIGHTS as usize) as i32,
            min_ghost_radius_px: MIN_GHOST_RADIUS_PX as f32,
            spike_count,
            spike_coef_px: std::array::from_fn(|c| {
                if c < 3 {
                    (model.starburst.spike_coefficient(channel_nm(c)) / pitch) as f32
                } else {
                    0.0
                }
            }),
            glow_coef_px: std::array::from_fn(|c| {
                if c < 3 {
                    (model.starburst.glow_coefficient(channel_nm(c)) / pitch) as f32
                } else {
                    0.0
                }
            }),
            halo_fraction: model.halo.fraction as f32,
            halo_radius_px: (model.halo.radius_mm / pitch) as f32,
            max_radius_px: (frame.width as f64).hypot(frame.height as f64) as f32,
            slots_per_light: (chosen.len() + fitted_count) as i32 + spike_count + 1,
            blades: a.blades as i32,
            rotation: a.rotation_rad as f32,
            curvature: a.curvature as f32,
            aperture_area: a.area_factor() as f32,
            fitted_count: fitted_count as i32,
            band_top_px: 0,
            band_height_px: 0,
        };
        // The matrix ghosts' table, then the fitted ghosts'.
        let mut table = if chosen.is_empty() { Vec::new() } else { ghost_table(&chosen, g0) };
        table.extend(model.fitted.iter().flat_map(FittedGhosts::table));
        if table.is_empty() {
            table.push(0.0);
        }
        FlareParams {
            constants,
            ghost_table: table,
            explicit: if explicit.is_empty() { vec![0.0] } else { explicit },
            ghosts: chosen.iter().map(|g| g.path).collect(),
            max_lights: MAX_LIGHTS,
            whole_frame_tiles: None,
        }
    }

    pub fn tile_grid(&self) -> [u32; 2] {
        [self.constants.tiles_x as u32, self.constants.tiles_y as u32]
    }

    /// The sprites' slots: every element of as many lights as the list holds.
    pub fn sprite_slots(&self) -> u64 {
        (self.max_lights as u64 * self.constants.slots_per_light.max(0) as u64).max(1)
    }
}

/// An energy as the plan prints it.
fn energy_text(e: f64) -> String {
    format!("{e:.3e}")
}

pub struct Flare {
    tiles: Kernel<FlareTilesShader>,
    lights: SpecializedKernel<FlareLightsShader>,
    bins: SpecializedKernel<FlareBinsShader>,
    sprites: SpecializedKernel<GhostSpritesShader>,
    fitted: SpecializedKernel<FittedGhostsShader>,
}

impl Pass for Flare {
    const NAME: &'static str = NAME;
    type Params = FlareParams;

    /// The whole frame: the lights are found over all of it and their ghosts land anywhere.
    fn reach_px(_p: &FlareParams) -> Option<f64> {
        None
    }

    fn plan(input: &PlanInput<'_>) -> Decision<FlareParams> {
        let (camera, frame) = (input.camera, input.frame);
        let flare = &camera.flare;
        if !flare.enabled {
            return Decision::skip(flare.off_by.reason());
        }
        let gain = camera.exposure_gain();
        let threshold = flare.threshold / gain;
        let visible = VISIBLE_FLARE / gain;
        let model = FlareModel::chosen(camera, input.facts.pixel_pitch_mm, frame.centre_px);
        let peaks = model.peaks();
        let (lit, lit_energy) = lit_pixels(&frame.color, threshold as f32);
        // The brightest light there could be: every lit pixel in one, plus the given lights.
        let bound: [f64; 3] =
            std::array::from_fn(|c| lit_energy[c] + flare.lights.iter().map(|l| l.energy[c]).sum::<f64>());
        let value = |p: &Peak, e: &[f64; 3]| (0..3).map(|c| p.per_energy[c] * e[c]).fold(0.0, f64::max);
        let strongest = peaks.iter().max_by(|a, b| value(&a.1, &[1.0; 3]).total_cmp(&value(&b.1, &[1.0; 3])));
        let needed = match strongest {
            Some((_, p)) if value(p, &[1.0; 3]) > 0.0 => {
                format!(
                    "{} for {} to add 1/{} of saturation",
                    energy_text(visible / value(p, &[1.0; 3])),
                    p.what,
                    1.0 / VISIBLE_FLARE
                )
            }
            _ => "an energy no lens element shows".into(),
        };
        let lights_text = format!(
            "{lit} px from {} x saturation (scene value {threshold:.4}){}",
            flare.threshold,
            if flare.lights.is_empty() { String::new() } else { format!(" and {} given lights", flare.lights.len()) }
        );
        if lit == 0 && flare.lights.is_empty() {
            return Decision::skip(format!(
                "no pixel reaches {} x saturation (scene value {threshold:.4}) and no light is given: a light would need an energy (scene value x px) of {needed}",
                flare.threshold
            ));
        }
        let shown: Vec<&(Option<GhostPath>, Peak)> =
            peaks.iter().filter(|(_, p)| value(p, &bound) >= visible).collect();
        if shown.is_empty() {
            return Decision::skip(format!(
                "{lights_text} hold at most {} (scene value x px): a light needs {needed}; invisible",
                energy_text(bound.iter().fold(0.0, |m: f64, &v| m.max(v)))
            ));
        }
        let ghosts: Vec<GhostPath> = shown.iter().filter_map(|(g, _)| *g).collect();
        let params = FlareParams::new(input, &model, Some(&ghosts));
        let choice = format!("--flare-ghosts {}", flare.ghosts.name());
        let ghost_text = match (&model.fitted, &model.catalogue) {
            (Some(f), _) => format!("ghosts drawn by the fitted model ({choice}): {}", f.describe([frame.width, frame.height])),
            (None, Some(c)) => format!(
                "ghosts drawn by the matrix model ({choice}{}): {} of the prescription's {} ghosts (two reflections, Walch eq 3.3)",
                if flare.fitted.is_empty() { ", the lens file has no [[fitted_ghost]]" } else { "" },
                ghosts.len(),
                c.paths
            ),
            (None, None) => "no ghosts (the lens file has no prescription)".into(),
        };
        let spikes = params.constants.spike_count;
        let why = format!(
            "{lights_text}, up to {}: {ghost_text}, {}, halo {}%; each drawn where it adds 1/{} of saturation",
            energy_text(bound.iter().fold(0.0, |m: f64, &v| m.max(v))),
            if spikes > 0 { format!("a {spikes}-spike starburst") } else { "a round diffraction glow".into() },
            100.0 * model.halo.fraction,
            1.0 / VISIBLE_FLARE
        );
        Decision::run(params, why)
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Flare {
            tiles: Kernel::new(gpu)?,
            lights: SpecializedKernel::new(gpu)?,
            bins: SpecializedKernel::new(gpu)?,
            sprites: SpecializedKernel::new(gpu)?,
            fitted: SpecializedKernel::new(gpu)?,
        })
    }

    /// The lights' and the ghost-sprite kernels' pipelines for the kinds of sprite this frame has.
    fn prepare(&self, p: &FlareParams) -> GpuResult<()> {
        self.lights.prepare(&lights::specialization(&p.constants))?;
        self.bins.prepare(&bins::specialization(&p.constants))?;
        self.sprites.prepare(&ghost_sprites::specialization(&p.constants, bins::words_per_tile(p.sprite_slots())))?;
        if p.constants.fitted_count > 0 {
            self.fitted.prepare(&[])?;
        }
        Ok(())
    }

    /// The flare added to the colour in place (and the lights' starburst and halo taken from
    /// their own pixels): what reaches the flare is not read again by anything recorded before
    /// it, and without a light the colour is left untouched instead of copied.
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &FlareParams) -> GpuResult<()> {
        let color = images.color().clone();
        let [tx, ty] = p.tile_grid();
        let tile_count = (tx * ty) as u64;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        // Uploads record their own copy -> compute-read barriers.
        let constants = rec.upload_buffer("flare constants", &constants_words(&p.constants))?;
        let ghost_table = rec.upload_buffer("flare ghost table", &p.ghost_table)?;
        let explicit = rec.upload_buffer("flare explicit lights", &p.explicit)?;
        // A band's tiles are the whole frame's, summed before (their upload records its own
        // copy -> compute barrier); a frame's are summed here.
        let tiles = match &p.whole_frame_tiles {
            Some(whole) => rec.upload_buffer("flare tiles (the whole frame's)", whole)?,
            None => rec.create_buffer("flare tiles", tile_count * TILE_WORDS as u64 * 4, storage)?,
        };
        let lit = rec.create_buffer("flare lit tiles", tile_count * 4, storage)?;
        let lights = rec.create_buffer("flare lights", p.max_lights as u64 * LIGHT_WORDS as u64 * 4, storage)?;
        let sprite_slots = p.sprite_slots();
        let sprites = rec.create_buffer("flare sprites", sprite_slots * SPRITE_WORDS as u64 * 4, storage)?;
        // One byte per sprite slot per tile (1280x720, 32 lights of 22 sprites: 2.5 MB).
        let words_per_tile = bins::words_per_tile(sprite_slots);
        let bins = rec.create_buffer(
            "flare bins",
            tile_count * words_per_tile * 4,
            storage | vk::BufferUsageFlags::TRANSFER_DST,
        )?;
        let args =
            rec.create_buffer("flare counts", ARGS_WORDS as u64 * 4, storage | vk::BufferUsageFlags::INDIRECT_BUFFER)?;

        if p.whole_frame_tiles.is_none() {
            tiles::record(&self.tiles, rec, &color, &constants, &tiles, [tx, ty])?;
        }
        let light_bindings = FlareLightsBindings {
            constants: &constants,
            tiles: &tiles,
            explicit: &explicit,
            ghost_table: &ghost_table,
            lights: &lights,
            sprites: &sprites,
            args: &args,
            lit: &lit,
        };
        lights::record(&self.lights, rec, &lights::specialization(&p.constants), &light_bindings, p.max_lights as i32)?;
        let bin_bindings = FlareBinsBindings { constants: &constants, sprites: &sprites, args: &args, bins: &bins };
        bins::record(&self.bins, rec, &bins::specialization(&p.constants), &bin_bindings, sprite_slots as u32)?;
        let sprite_bindings = GhostSpritesBindings {
            color: &color,
            constants: &constants,
            tiles: &tiles,
            lights: &lights,
            sprites: &sprites,
            args: &args,
            bins: &bins,
        };
        let kinds = ghost_sprites::specialization(&p.constants, words_per_tile);
        ghost_sprites::record(&self.sprites, rec, &kinds, &sprite_bindings, words_per_tile)?;
        if p.constants.fitted_count > 0 {
            let fitted_bindings = FittedGhostsBindings {
                color: &color,
                constants: &constants,
                sprites: &sprites,
                args: &args,
                bins: &bins,
            };
            fitted_ghosts::record(&self.fitted, rec, &fitted_bindings, tx, words_per_tile)?;
        }
        Ok(())
    }
}
