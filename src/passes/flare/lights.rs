//! Lens flare, step 2: the lit tiles gathered into a short list of lights (and the explicit
//! lights after them), each light's starburst and halo radii, and every (light, element) pair
//! as a sprite for the ghost-sprite kernel. One workgroup. Shader: glsl/flare/flare_lights.comp.

use super::types::{constants_of, ghost_from_table, FlareConstants};
use crate::gpu::shaders::flare::{
    ARGS_BIN_GROUPS, ARGS_LIGHTS, ARGS_LIT_TILES, ARGS_SPRITE_GROUPS, EXPLICIT_AREA, EXPLICIT_ENERGY, EXPLICIT_WORDS,
    EXPLICIT_X, EXPLICIT_Y, GHOST_POSITION, GHOST_SPRITE_CHANNEL_WORDS, GHOST_WORDS, KIND_GHOST, KIND_GLOW, KIND_NONE,
    KIND_SPIKE, LIGHT_AREA, LIGHT_BOX, LIGHT_ENERGY, LIGHT_GLOW_REACH, LIGHT_MOVED, LIGHT_R0, LIGHT_SPIKE_REACH,
    LIGHT_SPIKE_SHARE, LIGHT_TILES, LIGHT_WORDS, LIGHT_X, LIGHT_Y, SPRITE_BOUNDS, SPRITE_DATA, SPRITE_KIND,
    SPRITE_LIGHT, SPRITE_SOFTNESS, SPRITE_WORDS, TILE_COUNT, TILE_LIGHT, TILE_WORDS,
};
use crate::gpu::{GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};
use crate::passes::barriers::buffer_after_compute_write;
use crate::passes::twin::floats;
use crate::passes::TILE_SIZE;
use std::f64::consts::PI;

pub const NAME: &str = "flare_lights";

/// The most lights the shader's list holds (MAX_LIGHTS in glsl/flare/flare_lights.comp).
pub const SHADER_MAX_LIGHTS: i32 = 64;

crate::shader_bindings! {
    /// The bindings of glsl/flare/flare_lights.comp.
    pub struct FlareLightsBindings {
        constants: buffer(FlareParams),
        tiles: buffer(FlareTiles),
        explicit: buffer(ExplicitLights),
        ghost_table: buffer(GhostTable),
        lights: buffer(FlareLights),
        sprites: buffer(FlareSprites),
        args: buffer(FlareArgs),
        lit: buffer(LitTiles),
    }
}

/// glsl/flare/flare_lights.comp; its push constant is the list's capacity.
pub struct FlareLightsShader;

impl Shader for FlareLightsShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FlareLightsBindings<'a>;
    type Push = i32;
}

/// What a light makes of its starburst and halo (step 3 of the shader).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightReach {
    /// Radius from which they are drawn (px): the light's own, at least 1.
    pub r0: f64,
    /// Outer radius of the spikes (0: none drawn) and of the glow (px).
    pub spike_reach: f64,
    pub glow_reach: f64,
    /// Share of each channel of the light they take, at most a half.
    pub moved: [f64; 3],
    /// Share of the spikes' light on their centre line
    /// ([`spike_share`](crate::optics::flare::starburst::spike_share) of the light's area).
    pub spike_share: f64,
}

/// The starburst and halo of a light of `energy` per channel and `area_px` pixels.
pub fn light_reach(fc: &FlareConstants, energy: [f64; 3], area_px: f64) -> LightReach {
    let visible = fc.visible as f64;
    let r0 = (area_px.max(1.0) / PI).sqrt().max(1.0);
    let share = crate::optics::flare::starburst::spike_share(area_px);
    let spike_peak = (0..3).map(|c| share * fc.spike_coef_px[c] as f64 * energy[c]).fold(0.0, f64::max);
    let spike_reach = if fc.spike_count > 0 && spike_peak / (r0 * r0) >= visible {
        (spike_peak / visible).sqrt().min(fc.max_radius_px as f64)
    } else {
        0.0
    };
    let rho = fc.halo_radius_px as f64;
    let glow_peak = (0..3).map(|c| fc.glow_coef_px[c] as f64 * energy[c]).fold(0.0, f64::max);
    let e_max = energy.iter().fold(0.0, |m: f64, &e| m.max(e));
    let halo_peak = if rho > 0.0 { fc.halo_fraction as f64 * e_max / (2.0 * PI * rho * rho) } else { 0.0 };
    let mut glow_reach = (glow_peak / visible).cbrt();
    if halo_peak > visible {
        glow_reach = glow_reach.max(rho * ((halo_peak / visible).powf(2.0 / 3.0) - 1.0).max(0.0).sqrt());
    }
    glow_reach = glow_reach.min(fc.max_radius_px as f64);
    let halo_at = |r: f64| if rho > 0.0 { (1.0 + r * r / (rho * rho)).powf(-1.5) } else { 0.0 };
    let at_r0 = glow_peak / r0.powi(3) + halo_peak * halo_at(r0);
    if at_r0.is_nan() || at_r0 < visible {
        glow_reach = 0.0;
    }
    let moved = std::array::from_fn(|c| {
        let mut m = 0.0;
        if spike_reach > r0 {
            m += 2.0 * fc.blades as f64 * share * fc.spike_coef_px[c] as f64 * (1.0 / r0 - 1.0 / spike_reach);
        }
        if glow_reach > r0 {
            m += 2.0 * PI * fc.glow_coef_px[c] as f64 * (1.0 / r0 - 1.0 / glow_reach);
            if rho > 0.0 {
                let outside = |r: f64| 1.0 / (1.0 + r * r / (rho * rho)).sqrt();
                m += fc.halo_fraction as f64 * (outside(r0) - outside(glow_reach));
            }
        }
        m.min(0.5)
    });
    LightReach { r0, spike_reach, glow_reach, moved, spike_share: share }
}

/// The sprite's words with its bounds clamped to the frame, or none.
fn bounds(fc: &FlareConstants, sprite: &mut [f32], lo: [f64; 2], hi: [f64; 2], kind: u32, light: usize) -> bool {
    let lo = [lo[0].max(0.0), lo[1].max(0.0)];
    let hi = [hi[0].min(fc.width as f64), hi[1].min(fc.height as f64)];
    if !(lo[0] < hi[0] && lo[1] < hi[1]) {
        none(sprite);
        return false;
    }
    sprite[SPRITE_BOUNDS as usize..][..4].copy_from_slice(&[lo[0] as f32, lo[1] as f32, hi[0] as f32, hi[1] as f32]);
    sprite[SPRITE_KIND as usize] = kind as f32;
    sprite[SPRITE_LIGHT as usize] = light as f32;
    true
}

fn none(sprite: &mut [f32]) {
    sprite[SPRITE_BOUNDS as usize..][..4].copy_from_slice(&[1.0, 1.0, 0.0, 0.0]);
    sprite[SPRITE_KIND as usize] = KIND_NONE as f32;
}

/// The twin of the shader's ghost sprite: `light` (LIGHT_WORDS) and ghost `g` of the table.
fn ghost_sprite(fc: &FlareConstants, sprite: &mut [f32], light: &[f32], l: usize, table: &[f32], g: usize) {
    let at = [light[LIGHT_X as usize] as f64, light[LIGHT_Y as usize] as f64];
    let centre = [fc.centre_x as f64, fc.centre_y as f64];
    let slope = fc.pitch_mm as f64 / fc.g0_mm as f64;
    let u = [(at[0] - centre[0]) * slope, (at[1] - centre[1]) * slope];
    let source_radius = (light[LIGHT_AREA as usize] as f64 / PI).sqrt();
    let (mut lo, mut hi) = ([1e30f64; 2], [-1e30f64; 2]);
    let mut softness: f64 = 1.0;
    for c in 0..3 {
        let ghost = ghost_from_table(table, g, c);
        let shape = ghost.shape(u, centre, fc.pitch_mm as f64, fc.min_ghost_radius_px as f64, fc.aperture_area as f64);
        let value = light[LIGHT_ENERGY as usize + c] as f64 * shape.irradiance_per_energy;
        let shown = !shape.blocked && value >= fc.visible as f64;
        let w = SPRITE_DATA as usize + c * GHOST_SPRITE_CHANNEL_WORDS as usize;
        sprite[w..w + 8].copy_from_slice(&[
            shape.centre_px[0] as f32,
            shape.centre_px[1] as f32,
            (shape.radius_px * shape.flip) as f32,
            if shown { value as f32 } else { 0.0 },
            shape.clip_centre_px[0] as f32,
            shape.clip_centre_px[1] as f32,
            shape.clip_radius_px as f32,
            0.0,
        ]);
        let position = table[(g * 3 + c) * GHOST_WORDS as usize + GHOST_POSITION as usize] as f64;
        softness = softness.max(1.0 + 2.0 * position.abs() * source_radius);
        if shown {
            for k in 0..2 {
                let (r, cr) = (shape.radius_px + 1.0, shape.clip_radius_px + 1.0);
                lo[k] = lo[k].min((shape.centre_px[k] - r).max(shape.clip_centre_px[k] - cr));
                hi[k] = hi[k].max((shape.centre_px[k] + r).min(shape.clip_centre_px[k] + cr));
            }
        }
    }
    let half = 0.5 * softness;
    if bounds(fc, sprite, [lo[0] - half, lo[1] - half], [hi[0] + half, hi[1] + half], KIND_GHOST, l) {
        sprite[SPRITE_SOFTNESS as usize] = softness as f32;
    }
}

/// Spike `k` of a light: along an edge's normal; n of them for an even blade count (each two
/// edges'), 2n for an odd one.
pub fn spike_direction(blades: i32, rotation: f64, k: usize) -> ([f64; 2], f64) {
    let n = blades.max(1) as usize;
    let even = n.is_multiple_of(2);
    let sector = 2.0 * PI / n as f64;
    let edge = if even { k } else { k % n };
    let angle = 0.5 * PI + rotation + (edge as f64 + 0.5) * sector;
    let sign = if !even && k >= n { -1.0 } else { 1.0 };
    ([sign * angle.cos(), -sign * angle.sin()], if even { 2.0 } else { 1.0 })
}

fn spike_sprite(fc: &FlareConstants, sprite: &mut [f32], light: &[f32], l: usize, k: usize) {
    let (dir, edges) = spike_direction(fc.blades, fc.rotation as f64, k);
    let r0 = light[LIGHT_R0 as usize] as f64;
    let r1 = light[LIGHT_SPIKE_REACH as usize] as f64;
    let share = light[LIGHT_SPIKE_SHARE as usize] as f64;
    let coef: [f64; 3] =
        std::array::from_fn(|c| share * edges * fc.spike_coef_px[c] as f64 * light[LIGHT_ENERGY as usize + c] as f64);
    let o = [light[LIGHT_X as usize] as f64, light[LIGHT_Y as usize] as f64];
    if !(coef.iter().fold(0.0, |m: f64, &v| m.max(v)) / (r0 * r0) >= fc.visible as f64 && r1 > r0) {
        none(sprite);
        return;
    }
    let a = [o[0] + r0 * dir[0], o[1] + r0 * dir[1]];
    let e = [o[0] + r1 * dir[0], o[1] + r1 * dir[1]];
    let lo = [a[0].min(e[0]) - 1.0, a[1].min(e[1]) - 1.0];
    let hi = [a[0].max(e[0]) + 1.0, a[1].max(e[1]) + 1.0];
    if bounds(fc, sprite, lo, hi, KIND_SPIKE, l) {
        let d = SPRITE_DATA as usize;
        let words = [o[0], o[1], dir[0], dir[1], r0, r1, coef[0], coef[1], coef[2]];
        sprite[d..d + 9].iter_mut().zip(words).for_each(|(s, v)| *s = v as f32);
    }
}

fn glow_sprite(fc: &FlareConstants, sprite: &mut [f32], light: &[f32], l: usize) {
    let r0 = light[LIGHT_R0 as usize] as f64;
    let r1 = light[LIGHT_GLOW_REACH as usize] as f64;
    let o = [light[LIGHT_X as usize] as f64, light[LIGHT_Y as usize] as f64];
    if r1.partial_cmp(&r0) != Some(std::cmp::Ordering::Greater) {
        none(sprite);
        return;
    }
    if !bounds(fc, sprite, [o[0] - r1 - 1.0, o[1] - r1 - 1.0], [o[0] + r1 + 1.0, o[1] + r1 + 1.0], KIND_GLOW, l) {
        return;
    }
    let rho = fc.halo_radius_px as f64;
    let d = SPRITE_DATA as usize;
    sprite[d..d + 4].iter_mut().zip([o[0], o[1], r0, r1]).for_each(|(s, v)| *s = v as f32);
    for c in 0..3 {
        let e = light[LIGHT_ENERGY as usize + c] as f64;
        sprite[d + 4 + c] = (fc.glow_coef_px[c] as f64 * e) as f32;
        sprite[d + 7 + c] = if rho > 0.0 { (fc.halo_fraction as f64 * e / (2.0 * PI * rho * rho)) as f32 } else { 0.0 };
    }
    sprite[d + 10] = rho as f32;
}

impl Twin for FlareLightsShader {
    fn cpu(max_lights: &i32, _groups: [u32; 3], b: &mut [HostData]) {
        let fc = constants_of(&b[0]);
        let max_lights = (*max_lights).clamp(0, SHADER_MAX_LIGHTS) as usize;
        let (tw, tiles_x) = (TILE_WORDS as usize, fc.tiles_x as usize);
        let tile_count = tiles_x * fc.tiles_y as usize;
        let tiles = floats(b[1].words());
        // 1. The lit tiles in order.
        let lit: Vec<usize> = (0..tile_count).filter(|&t| tiles[t * tw + TILE_COUNT as usize] > 0.0).collect();
        for (k, &t) in lit.iter().enumerate() {
            b[7].words_mut()[k] = t as u32;
        }
        // 2. Into lights, in order (f32 sums in the shader's order); then the explicit lights.
        let merge = fc.merge_tiles;
        let mut acc: Vec<[f32; 12]> = Vec::new();
        for &t in &lit {
            let (tx, ty) = ((t % tiles_x) as i32, (t / tiles_x) as i32);
            let mut join = acc.iter().position(|a| {
                tx >= a[8] as i32 - merge
                    && tx <= a[10] as i32 + merge
                    && ty >= a[9] as i32 - merge
                    && ty <= a[11] as i32 + merge
            });
            if join.is_none() && acc.len() < max_lights {
                let mut a = [0.0f32; 12];
                a[8..12].copy_from_slice(&[tx as f32, ty as f32, tx as f32, ty as f32]);
                acc.push(a);
                join = Some(acc.len() - 1);
            }
            let join = join.unwrap_or_else(|| {
                let mut best = (f32::MAX, 0);
                for (l, a) in acc.iter().enumerate() {
                    let c = [0.5 * (a[8] + a[10]), 0.5 * (a[9] + a[11])];
                    let d = (c[0] - tx as f32).hypot(c[1] - ty as f32);
                    if d < best.0 {
                        best = (d, l);
                    }
                }
                best.1
            });
            let a = &mut acc[join];
            for w in 0..7 {
                a[w] += tiles[t * tw + w];
            }
            a[7] += 1.0;
            a[8] = a[8].min(tx as f32);
            a[9] = a[9].min(ty as f32);
            a[10] = a[10].max(tx as f32);
            a[11] = a[11].max(ty as f32);
            b[1].words_mut()[t * tw + TILE_LIGHT as usize] = (join as f32).to_bits();
        }
        let explicit = floats(b[2].words());
        for e in 0..fc.explicit_count.max(0) as usize {
            if acc.len() >= max_lights {
                break;
            }
            let w = &explicit[e * EXPLICIT_WORDS as usize..];
            let energy = &w[EXPLICIT_ENERGY as usize..EXPLICIT_ENERGY as usize + 3];
            let (x, y, area) = (w[EXPLICIT_X as usize], w[EXPLICIT_Y as usize], w[EXPLICIT_AREA as usize]);
            acc.push([energy[0], energy[1], energy[2], x, y, 1.0, area, 0.0, -1.0, -1.0, -1.0, -1.0]);
        }
        let args = b[6].words_mut();
        args[ARGS_LIGHTS as usize] = acc.len() as u32;
        args[ARGS_LIT_TILES as usize] = lit.len() as u32;
        // The sprites are drawn on the band's tile rows (a whole frame's: all).
        let rows = if fc.band_height_px > 0 {
            (fc.band_height_px as u32).div_ceil(TILE_SIZE)
        } else {
            fc.tiles_y.max(0) as u32
        };
        let tiles = [fc.tiles_x.max(0) as u32, rows, 1];
        let none = [0, 1, 1];
        let sprites = if acc.is_empty() { none } else { tiles };
        let bins = [acc.len() as u32 * fc.slots_per_light.max(0) as u32, 1, 1];
        for (at, groups) in [(ARGS_BIN_GROUPS, bins), (ARGS_SPRITE_GROUPS, sprites)] {
            args[at as usize..][..3].copy_from_slice(&groups);
        }
        // 3. Each light.
        let mut lights: Vec<Vec<f32>> = Vec::new();
        for a in &acc {
            let energy = [a[0] as f64, a[1] as f64, a[2] as f64];
            let w = a[5];
            let box_centre =
                [(0.5 * (a[8] + a[10]) + 0.5) * TILE_SIZE as f32, (0.5 * (a[9] + a[11]) + 0.5) * TILE_SIZE as f32];
            let at = if w > 0.0 { [a[3] / w, a[4] / w] } else { box_centre };
            let area = a[6].max(1.0);
            let reach = light_reach(&fc, energy, area as f64);
            let mut light = vec![0.0f32; LIGHT_WORDS as usize];
            light[LIGHT_ENERGY as usize..][..3].copy_from_slice(&a[..3]);
            light[LIGHT_AREA as usize] = area;
            light[LIGHT_X as usize] = at[0];
            light[LIGHT_Y as usize] = at[1];
            light[LIGHT_R0 as usize] = reach.r0 as f32;
            light[LIGHT_TILES as usize] = a[7];
            light[LIGHT_BOX as usize..][..4].copy_from_slice(&a[8..12]);
            for c in 0..3 {
                light[LIGHT_MOVED as usize + c] = reach.moved[c] as f32;
            }
            light[LIGHT_SPIKE_REACH as usize] = reach.spike_reach as f32;
            light[LIGHT_GLOW_REACH as usize] = reach.glow_reach as f32;
            light[LIGHT_SPIKE_SHARE as usize] = reach.spike_share as f32;
            lights.push(light);
        }
        for (l, light) in lights.iter().enumerate() {
            let w = l * LIGHT_WORDS as usize;
            for (k, v) in light.iter().enumerate() {
                b[4].words_mut()[w + k] = v.to_bits();
            }
        }
        // 4. The sprites.
        let table = floats(b[3].words());
        let slots = fc.slots_per_light.max(0) as usize;
        let sprites = b[5].words_mut();
        for s in 0..lights.len() * slots {
            let (l, e) = (s / slots, s % slots);
            let mut sprite: Vec<f32> = sprites[s * SPRITE_WORDS as usize..][..SPRITE_WORDS as usize]
                .iter()
                .map(|&w| f32::from_bits(w))
                .collect();
            let fitted_end = (fc.ghost_count + fc.fitted_count).max(0) as usize;
            if e < fc.ghost_count as usize {
                ghost_sprite(&fc, &mut sprite, &lights[l], l, &table, e);
            } else if e < fitted_end {
                if !super::fitted::fitted_sprite(&fc, &mut sprite, &lights[l], l, &table, e - fc.ghost_count as usize) {
                    self::none(&mut sprite);
                }
            } else if e < fitted_end + fc.spike_count.max(0) as usize {
                spike_sprite(&fc, &mut sprite, &lights[l], l, e - fitted_end);
            } else {
                glow_sprite(&fc, &mut sprite, &lights[l], l);
            }
            for (k, v) in sprite.iter().enumerate() {
                sprites[s * SPRITE_WORDS as usize + k] = v.to_bits();
            }
        }
    }
}

/// The specialization constants of glsl/flare/flare_lights.comp for a frame of `constants`:
/// whether it has fitted ghosts, and matrix ghosts (without, the pipeline has none of their code).
pub fn specialization(constants: &FlareConstants) -> [u32; 2] {
    [(constants.fitted_count > 0) as u32, (constants.ghost_count > 0) as u32]
}

/// Record the step: one workgroup; `constants` from [`specialization`].
pub fn record(
    kernel: &SpecializedKernel<FlareLightsShader>,
    rec: &mut Recorder,
    constants: &[u32; 2],
    b: &FlareLightsBindings<'_>,
    max_lights: i32,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // tiles: written by flare_tiles, read here and its light index written (read-after-write).
    // lights, sprites, counts, lit tiles: buffers of this recording nothing has touched yet.
    // The ghost table and explicit lights: uploaded with their own barriers.
    rec.buffer_barriers(&[buffer_after_compute_write(b.tiles)]);
    kernel.dispatch(rec, constants, b, &max_lights, [1, 1, 1])?;
    rec.end_pass();
    Ok(())
}
