//! The flare's shared data: the constants every step of the pass reads (the `FlareConstants`
//! struct of glsl/include/flare.glsl) and the ghost table, with the twins' readers of both. The
//! pass (`flare/mod.rs`) writes them; its steps (`tiles`, `lights`, `bins`, `ghost_sprites`) read
//! them from here, so no step imports the pass.

use crate::gpu::shaders::flare::{GHOST_CLIP0, GHOST_WORDS, MAX_CLIPS};
use crate::gpu::HostData;
use crate::optics::flare::channel_nm;
use crate::optics::flare::ghosts::{Clip, GhostChannel, MatrixGhost};
use crate::optics::prescription::RayMatrix;

/// The frame's flare settings, the `FlareConstants` struct of glsl/include/flare.glsl (a
/// storage buffer every step reads; 4-byte fields only).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FlareConstants {
    pub width: i32,
    pub height: i32,
    pub tiles_x: i32,
    pub tiles_y: i32,
    /// A pixel with a channel at least this (scene value) belongs to a light.
    pub threshold: f32,
    /// An element is drawn where it adds at least this (scene value).
    pub visible: f32,
    pub pitch_mm: f32,
    pub centre_x: f32,
    pub centre_y: f32,
    /// The light's image height per unit slope (mm).
    pub g0_mm: f32,
    pub ghost_count: i32,
    /// A lit tile joins a light whose tiles are at most this many tiles away.
    pub merge_tiles: i32,
    pub explicit_count: i32,
    pub min_ghost_radius_px: f32,
    pub spike_count: i32,
    /// Per channel: one edge's spike carries coef x E / r^2 per px of its length at r px.
    pub spike_coef_px: [f32; 4],
    /// Per channel: the round diffraction is coef x E / r^3 per px^2.
    pub glow_coef_px: [f32; 4],
    pub halo_fraction: f32,
    pub halo_radius_px: f32,
    pub max_radius_px: f32,
    pub slots_per_light: i32,
    pub blades: i32,
    pub rotation: f32,
    pub curvature: f32,
    /// Area of the aperture of circumradius 1.
    pub aperture_area: f32,
    /// Fitted ghosts in the table, after the `ghost_count` matrix ghosts (`fitted`).
    pub fitted_count: i32,
    /// The first row of the band drawn (banded rendering: the constants are the whole frame's,
    /// the image a band of it); 0 for a whole frame.
    pub band_top_px: i32,
    /// The band's rows (0: the whole frame's): the sprites are drawn on its tiles only.
    pub band_height_px: i32,
}

/// The constants a twin finds in its binding.
pub fn constants_of(b: &HostData) -> FlareConstants {
    let bytes: &[u8] = bytemuck::cast_slice(b.words());
    bytemuck::pod_read_unaligned(&bytes[..std::mem::size_of::<FlareConstants>()])
}

/// The constants as the words of their buffer.
pub fn constants_words(c: &FlareConstants) -> Vec<f32> {
    bytemuck::cast_slice(bytemuck::bytes_of(c)).to_vec()
}

/// The ghost table of glsl/include/flare.glsl: per ghost, per channel, its matrix form.
pub fn ghost_table(ghosts: &[MatrixGhost], g0_mm: f64) -> Vec<f32> {
    let mut table = Vec::with_capacity(ghosts.len() * 3 * GHOST_WORDS as usize);
    for g in ghosts {
        for c in &g.channels {
            let mut words = vec![0.0f32; GHOST_WORDS as usize];
            // The most restrictive clips when there are more than the table holds.
            let mut clips = c.clips.clone();
            clips.sort_by(|a, b| a.radius_mm.total_cmp(&b.radius_mm));
            clips.truncate(MAX_CLIPS as usize);
            words[..7].copy_from_slice(&[
                c.centre_mm as f32,
                c.sensor.a as f32,
                c.aperture_radius_mm as f32,
                c.flip as f32,
                c.energy_ratio as f32,
                clips.len() as f32,
                (c.centre_mm / g0_mm) as f32,
            ]);
            for (k, clip) in clips.iter().enumerate() {
                words[GHOST_CLIP0 as usize + 2 * k] = clip.offset_mm as f32;
                words[GHOST_CLIP0 as usize + 2 * k + 1] = clip.radius_mm as f32;
            }
            table.extend(words);
        }
    }
    if table.is_empty() {
        table.push(0.0);
    }
    table
}

/// Ghost `g`, channel `c` of a table, as the matrix model's channel (for the twins).
pub fn ghost_from_table(table: &[f32], g: usize, c: usize) -> GhostChannel {
    let t = &table[(g * 3 + c) * GHOST_WORDS as usize..][..GHOST_WORDS as usize];
    let clips = (0..t[5] as usize)
        .map(|k| Clip {
            surface: k,
            offset_mm: t[GHOST_CLIP0 as usize + 2 * k] as f64,
            radius_mm: t[GHOST_CLIP0 as usize + 2 * k + 1] as f64,
        })
        .collect();
    GhostChannel {
        lambda_nm: channel_nm(c),
        sensor: RayMatrix { a: t[1] as f64, b: 0.0, c: 0.0, d: 0.0 },
        centre_mm: t[0] as f64,
        aperture_radius_mm: t[2] as f64,
        aperture_crossing: 0,
        flip: t[3] as f64,
        clips,
        energy_ratio: t[4] as f64,
    }
}
