//! Walch 2017's fitted ghosts (ch. 6-8) in the flare pass: a lens file's `[[fitted_ghost]]`
//! entries, each one ghost in one channel as the measured-ghost primitive (ch. 6) whose 13
//! parameters are polynomials of the angle between the camera's axis and the light (ch. 8).
//! Per light, `flare_lights` evaluates them at the light's angle (eq 8.1), turns the primitive
//! towards the light (eq 8.2's roll about the frame's centre) and scales it by the light's
//! energy (eq 8.3): a sprite of kind KIND_FITTED, binned and drawn like the matrix ghosts'.
//!
//! Eq 8.3 here: the fits (`realcam flare-fit`) give the light per frame pixel per unit of the
//! light's own image's energy, so the scale from the fitted flare to the frame's is the light's
//! energy in the channel (scene value x px), as the matrix ghosts' is. The ratio of f-numbers,
//! ISOs and exposure times of eq 8.3 is already in that energy: the light and its ghosts pass
//! the same aperture and exposure.
//!
//! The frame-size rule: a fit is of a frame of `frame_px` pixels, of the lens's image plane at
//! that frame's pixel pitch. Drawn on a frame of another size, its pixels are scaled to this
//! frame's by the ratio of the two pitches on this camera's sensor (a distance in mm on the
//! sensor is kept; the light per pixel goes with the pixels' area), about the frame's centre.
//!
//! This is the twin of the fitted parts of glsl/flare/flare_lights.comp (`fitted_sprite`) and
//! glsl/include/fitted_ghost.glsl (`fitted_distance`, the sorting); `fitted_ghosts` shades them.

use super::ghost_shape::{primitive_light, search_signed_distance};
use super::sprite::TILE_REACH_PX;
use super::types::FlareConstants;
use crate::gpu::shaders::bezier_ghost::{BEZIER_BOUNDS, BEZIER_COLOUR, BEZIER_ROLL, BEZIER_SHAPE, BEZIER_TRANSFER};
use crate::gpu::shaders::flare::{
    BIN_COVERING_SHIFT, FITTED_ANGLES, FITTED_CHANNEL, FITTED_PARAMS, FITTED_PARAM_COUNT, FITTED_PARAM_WORDS,
    FITTED_PIVOT, FITTED_SCALE, FITTED_TERMS, FITTED_WORDS, GHOST_CHANNEL_WORDS, KIND_FITTED, LIGHT_ENERGY, LIGHT_X,
    LIGHT_Y, SPRITE_BOUNDS, SPRITE_DATA, SPRITE_INNER, SPRITE_KIND, SPRITE_LIGHT, SPRITE_SOFTNESS,
};
use crate::io::lens_file::FittedGhostSpec;
use crate::model::camera::Camera;
use crate::optics::bezier_ghost::{PARAMS, PARAM_NAMES, PARAM_RANGES};
use crate::passes::TILE_SIZE;

/// How far (px) the 12-step search's distance may be from the exact one where a sprite is
/// sorted against a tile (FITTED_MARGIN in glsl/include/ghost_sprite.glsl): the search is within
/// 1e-3 px of the exact root on ghosts of tens of px (src/tools/bezier_ghosts.rs's test), a
/// margin kept for the Tessar's primitives of over 1000 px.
pub const FITTED_MARGIN_PX: f64 = 1.0;

/// A light this far (deg) outside a fit's range of angles is still drawn, at the range's end
/// (f32 rounding of the angle at the range's ends).
pub const ANGLE_SLACK_DEG: f64 = 1e-3;

/// The fitted ghosts a frame draws: the lens file's entries and, per entry, this frame's pixels
/// per pixel of the fit's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FittedGhosts {
    pub specs: Vec<FittedGhostSpec>,
    /// Per spec: this frame's px per px of its frame (1 on a frame of its size).
    pub scales: Vec<f64>,
}

impl FittedGhosts {
    /// The fits of `camera`'s lens file drawn on a frame of pixel pitch `pixel_pitch_mm`.
    pub fn new(camera: &Camera, pixel_pitch_mm: f64) -> FittedGhosts {
        let specs = camera.flare.fitted.clone();
        let scales =
            specs.iter().map(|s| camera.pixel_pitch_mm(s.frame_px[0], s.frame_px[1]) / pixel_pitch_mm).collect();
        FittedGhosts { specs, scales }
    }

    /// The table of glsl/include/flare.glsl (FITTED_WORDS per spec), after the matrix ghosts'.
    pub fn table(&self) -> Vec<f32> {
        let mut table = Vec::with_capacity(self.specs.len() * FITTED_WORDS as usize);
        for (spec, &scale) in self.specs.iter().zip(&self.scales) {
            let mut w = vec![0.0f32; FITTED_WORDS as usize];
            w[FITTED_CHANNEL as usize] = spec.channel as f32;
            w[FITTED_ANGLES as usize] = spec.angles_deg[0] as f32;
            w[FITTED_ANGLES as usize + 1] = spec.angles_deg[1] as f32;
            w[FITTED_SCALE as usize] = scale as f32;
            w[FITTED_PIVOT as usize] = (spec.frame_px[0] as f64 / 2.0) as f32;
            w[FITTED_PIVOT as usize + 1] = (spec.frame_px[1] as f64 / 2.0) as f32;
            let polynomials = spec.polynomials();
            for (k, (coefficients, &(lo, hi))) in polynomials.coefficients.iter().zip(&PARAM_RANGES).enumerate() {
                let p = (FITTED_PARAMS + k as u32 * FITTED_PARAM_WORDS) as usize;
                for (i, c) in coefficients.iter().take(FITTED_TERMS as usize).enumerate() {
                    w[p + i] = *c as f32;
                }
                w[p + FITTED_TERMS as usize] = lo.max(f32::MIN as f64) as f32;
                w[p + FITTED_TERMS as usize + 1] = hi.min(f32::MAX as f64) as f32;
            }
            table.extend(w);
        }
        table
    }

    /// Spec `k`'s brightest pixel per unit of the light's energy in its channel, over its range
    /// of angles (sampled at 0.25 deg and the ends), per channel (0 in the others).
    pub fn peak_per_energy(&self, k: usize) -> [f64; 3] {
        let (spec, scale) = (&self.specs[k], self.scales[k]);
        let p = spec.polynomials();
        let [lo, hi] = spec.angles_deg;
        let steps = ((hi - lo) / 0.25).ceil().max(1.0) as usize;
        let peak = (0..=steps)
            .map(|i| p.at(lo + (hi - lo) * i as f64 / steps as f64).transfer)
            .map(|t| t.border.max(t.inner))
            .fold(0.0, f64::max);
        std::array::from_fn(|c| if c == spec.channel as usize { peak / (scale * scale) } else { 0.0 })
    }

    /// What `--explain` says of them on a frame of `size` px.
    pub fn describe(&self, size: [u32; 2]) -> String {
        let names = ["red", "green", "blue"];
        let mut channels: Vec<&str> = self.specs.iter().map(|s| names[s.channel.min(2) as usize]).collect();
        channels.sort();
        channels.dedup();
        let ghosts = {
            let mut g: Vec<&str> = self.specs.iter().map(|s| s.ghost.as_str()).collect();
            g.sort();
            g.dedup();
            g.len()
        };
        let (lo, hi) = self
            .specs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| (a.min(s.angles_deg[0]), b.max(s.angles_deg[1])));
        let mut frames: Vec<[u32; 2]> = self.specs.iter().map(|s| s.frame_px).collect();
        frames.sort();
        frames.dedup();
        let scaled: Vec<String> = frames
            .iter()
            .filter(|f| **f != size)
            .map(|f| {
                let k = self.specs.iter().position(|s| s.frame_px == *f).unwrap_or(0);
                format!(
                    "the fits of a {}x{} frame drawn at {:.4}x their px on this {}x{} one (the ratio of the two pixel pitches on this sensor: a ghost's place and size in mm kept, its light per px over the px's area)",
                    f[0], f[1], self.scales[k], size[0], size[1]
                )
            })
            .collect();
        format!(
            "{} fitted ghosts (Walch ch. 6-8 primitives, the lens file's {} [[fitted_ghost]] entries, in {}) at the light's angle (eq 8.1, fitted over {lo}..{hi} deg: a light outside draws none of them), turned by its roll (eq 8.2), scaled by its energy (eq 8.3){}",
            ghosts,
            self.specs.len(),
            channels.join(", "),
            if scaled.is_empty() { String::new() } else { format!("; {}", scaled.join("; ")) }
        )
    }
}

/// Eq 8.1's angle (deg) of a light of display slope `u` (tan of its angle off the axis) and
/// the roll that turns the fit's light (towards +x) to it on screen (y down), radians.
pub fn angle_and_roll(u: [f64; 2]) -> (f64, f64) {
    let slope = u[0].hypot(u[1]);
    let roll = if slope > 0.0 { (-u[1]).atan2(u[0]) } else { 0.0 };
    (slope.atan().to_degrees(), roll)
}

/// The twin of glsl/flare/flare_lights.comp's `fitted_sprite`: light `light` (LIGHT_WORDS,
/// index `l`) and fitted ghost `g` of `table` (the ghost table, the fitted ghosts after the
/// matrix ghosts). Returns false where the sprite is none (the caller writes it so).
pub fn fitted_sprite(
    fc: &FlareConstants,
    sprite: &mut [f32],
    light: &[f32],
    l: usize,
    table: &[f32],
    g: usize,
) -> bool {
    let t = &table[fc.ghost_count.max(0) as usize * GHOST_CHANNEL_WORDS as usize + g * FITTED_WORDS as usize..]
        [..FITTED_WORDS as usize];
    let centre = [fc.centre_x as f64, fc.centre_y as f64];
    let slope = fc.pitch_mm as f64 / fc.g0_mm as f64;
    let u =
        [(light[LIGHT_X as usize] as f64 - centre[0]) * slope, (light[LIGHT_Y as usize] as f64 - centre[1]) * slope];
    let (angle, roll) = angle_and_roll(u);
    let (lo, hi) = (t[FITTED_ANGLES as usize] as f64, t[FITTED_ANGLES as usize + 1] as f64);
    if !(angle >= lo - ANGLE_SLACK_DEG && angle <= hi + ANGLE_SLACK_DEG) {
        return false;
    }
    let angle = angle.clamp(lo, hi);
    let p: [f64; PARAMS] = std::array::from_fn(|k| {
        let w = &t[(FITTED_PARAMS + k as u32 * FITTED_PARAM_WORDS) as usize..][..FITTED_PARAM_WORDS as usize];
        let v = w[..FITTED_TERMS as usize].iter().rev().fold(0.0, |acc, &c| acc * angle + c as f64);
        v.clamp(w[FITTED_TERMS as usize] as f64, w[FITTED_TERMS as usize + 1] as f64)
    });
    debug_assert_eq!(FITTED_PARAM_COUNT as usize, PARAM_NAMES.len());
    let scale = t[FITTED_SCALE as usize] as f64;
    let pivot = [t[FITTED_PIVOT as usize] as f64, t[FITTED_PIVOT as usize + 1] as f64];
    let m = [centre[0] + scale * (p[0] - pivot[0]), centre[1] + scale * (p[1] - pivot[1])];
    let (h, left, right) = (scale * p[2], scale * p[3], scale * p[4]);
    let (fi, fo) = (scale * p[9], scale * p[10]);
    let channel = t[FITTED_CHANNEL as usize] as usize;
    let value = light[LIGHT_ENERGY as usize + channel.min(2)] as f64 / (scale * scale);
    // Not visible, or NaN.
    if (p[7].max(p[8]) * value).partial_cmp(&(fc.visible as f64)).is_none_or(|o| o.is_lt()) {
        return false;
    }
    let reach = fo + 1.0;
    let (cs, sn) = (roll.cos(), roll.sin());
    let (mut lo_px, mut hi_px) = ([1e30f64; 2], [-1e30f64; 2]);
    for k in 0..4 {
        let corner = [
            if k & 1 == 0 { m[0] - left - reach } else { m[0] + right + reach },
            if k & 2 == 0 { m[1] - h - reach } else { m[1] + h + reach },
        ];
        let o = [corner[0] - centre[0], corner[1] - centre[1]];
        let turned = [centre[0] + cs * o[0] + sn * o[1], centre[1] - sn * o[0] + cs * o[1]];
        for a in 0..2 {
            lo_px[a] = lo_px[a].min(turned[a]);
            hi_px[a] = hi_px[a].max(turned[a]);
        }
    }
    let lo_px = [lo_px[0].max(0.0), lo_px[1].max(0.0)];
    let hi_px = [hi_px[0].min(fc.width as f64), hi_px[1].min(fc.height as f64)];
    if !(lo_px[0] < hi_px[0] && lo_px[1] < hi_px[1]) {
        return false;
    }
    let bounds = [lo_px[0] as f32, lo_px[1] as f32, hi_px[0] as f32, hi_px[1] as f32];
    sprite[SPRITE_BOUNDS as usize..][..4].copy_from_slice(&bounds);
    sprite[SPRITE_KIND as usize] = KIND_FITTED as f32;
    sprite[SPRITE_LIGHT as usize] = l as f32;
    sprite[SPRITE_SOFTNESS as usize] = 0.0;
    sprite[SPRITE_INNER as usize] = (p[8] * value) as f32;
    let w = SPRITE_DATA as usize;
    sprite[w + BEZIER_BOUNDS as usize..][..4].copy_from_slice(&bounds);
    let shape = [m[0], m[1], h, left, right, p[5], p[6]];
    let transfer = [p[7], p[8], fi, fo, p[11], p[12]];
    let colour: [f64; 3] = std::array::from_fn(|c| if c == channel { value } else { 0.0 });
    let roll_words = [cs, -sn, centre[0], centre[1]];
    for (at, words) in [
        (BEZIER_SHAPE, &shape[..]),
        (BEZIER_TRANSFER, &transfer[..]),
        (BEZIER_COLOUR, &colour[..]),
        (BEZIER_ROLL, &roll_words[..]),
    ] {
        for (k, v) in words.iter().enumerate() {
            sprite[w + at as usize + k] = *v as f32;
        }
    }
    true
}

/// The light fitted sprite `s` (its words) adds to the pixel of centre `q`, per channel (the
/// twin of ghost_sprites.comp's fitted loop: eq 6.4 of the 12-step search times its colour).
pub fn fitted_light(s: &[f32], q: [f32; 2]) -> [f64; 3] {
    let words = &s[SPRITE_DATA as usize..];
    let light = primitive_light(words, q) as f64;
    std::array::from_fn(|c| light * words[BEZIER_COLOUR as usize + c] as f64)
}

/// Fitted sprite `s` against the tile whose tile centre is `centre`: its bin byte (the twin of
/// ghost_sprite.glsl's KIND_FITTED sorting): covering its channels where the tile lies past F_i
/// inside (eq 6.4: I_i there), away past F_o outside (0 there), crossing between.
pub fn fitted_bin(s: &[f32], origin: [u32; 2]) -> u32 {
    let w = &s[SPRITE_DATA as usize..];
    let channels = (0..3).filter(|&c| w[BEZIER_COLOUR as usize + c] > 0.0).fold(0u32, |m, c| m | 1 << c);
    let q = [origin[0] as f32 + 0.5 * TILE_SIZE as f32, origin[1] as f32 + 0.5 * TILE_SIZE as f32];
    let d = fitted_distance(w, q);
    let reach = (TILE_REACH_PX + FITTED_MARGIN_PX) as f32;
    let t = &w[BEZIER_TRANSFER as usize..];
    if d >= t[2] + reach {
        channels << BIN_COVERING_SHIFT
    } else if d <= -(t[3] + reach) {
        0
    } else {
        channels
    }
}

/// The signed distance (px, > 0 inside) of the primitive of BEZIER words `w` at `q`, q turned
/// back by its roll (glsl/include/ghost_sprite.glsl's `fitted_distance`).
pub fn fitted_distance(w: &[f32], q: [f32; 2]) -> f32 {
    let r = BEZIER_ROLL as usize;
    let (c, s, pivot) = (w[r], w[r + 1], [w[r + 2], w[r + 3]]);
    let o = [q[0] - pivot[0], q[1] - pivot[1]];
    let local = [pivot[0] + c * o[0] + s * o[1], pivot[1] - s * o[0] + c * o[1]];
    search_signed_distance(&w[BEZIER_SHAPE as usize..][..7], local)
}
