//! One flare sprite's geometry, the CPU twin of glsl/include/ghost_sprite.glsl: a ghost sprite's
//! channel as a shape, a ray (a starburst spike) against a box, and a sprite's bin byte against a
//! tile. Shared by the twins of `bins` (which sorts sprites into the tiles) and `ghost_sprites`
//! (which draws them). The fitted sprites' geometry is `fitted`'s.

use crate::gpu::shaders::flare::{
    BIN_COVERING_SHIFT, GHOST_SPRITE_CHANNEL_WORDS, KIND_FITTED, KIND_GHOST, KIND_GLOW, KIND_SPIKE, SPRITE_BOUNDS,
    SPRITE_DATA, SPRITE_KIND, SPRITE_SOFTNESS,
};
use crate::optics::flare::ghosts::GhostShape;
use crate::optics::flare::AperturePolygon;
use crate::passes::TILE_SIZE;

/// Half the diagonal of a tile's pixel centres (TILE_REACH in glsl/include/ghost_sprite.glsl):
/// a 1-Lipschitz distance changes by at most this between the tile's centre and its pixels.
pub const TILE_REACH_PX: f64 = 0.5 * (TILE_SIZE - 1) as f64 * std::f64::consts::SQRT_2;

/// A ghost sprite's channel `c` as a shape (words of glsl/include/flare.glsl).
pub fn ghost_channel(s: &[f32], c: usize) -> GhostShape {
    let g = |k: u32| s[(SPRITE_DATA + c as u32 * GHOST_SPRITE_CHANNEL_WORDS + k) as usize] as f64;
    GhostShape {
        centre_px: [g(0), g(1)],
        radius_px: g(2).abs(),
        flip: if g(2) < 0.0 { -1.0 } else { 1.0 },
        clip_centre_px: [g(4), g(5)],
        clip_radius_px: g(6),
        irradiance_per_energy: 0.0,
        clip_surface: None,
        blocked: false,
    }
}

/// Sprite `s` (its words) against the tile whose first pixel is `origin`: its bin byte, bits
/// 0-2 the channels crossing the tile, bits 3-5 those covering it, 0 away from it
/// (glsl/include/ghost_sprite.glsl's sprite_bin).
pub fn sprite_bin(s: &[f32], aperture: &AperturePolygon, origin: [u32; 2]) -> u32 {
    let bx = &s[SPRITE_BOUNDS as usize..][..4];
    let (ox, oy) = (origin[0] as f32, origin[1] as f32);
    let tile = TILE_SIZE as f32;
    let meets = bx[0] <= bx[2] && bx[0] < ox + tile && bx[2] >= ox && bx[1] < oy + tile && bx[3] >= oy;
    if !meets {
        return 0;
    }
    let f = |k: u32| s[(SPRITE_DATA + k) as usize] as f64;
    match s[SPRITE_KIND as usize] as u32 {
        KIND_GHOST => {
            let centre = [ox as f64 + 0.5 * TILE_SIZE as f64, oy as f64 + 0.5 * TILE_SIZE as f64];
            let reach = TILE_REACH_PX + 0.5 * s[SPRITE_SOFTNESS as usize] as f64;
            (0..3).fold(0, |mode, c| {
                if f(c as u32 * GHOST_SPRITE_CHANNEL_WORDS + 3) <= 0.0 {
                    return mode;
                }
                let d = ghost_channel(s, c).sdf(centre, aperture);
                if d <= -reach {
                    mode | 1 << (c as u32 + BIN_COVERING_SHIFT)
                } else if d < reach {
                    mode | 1 << c
                } else {
                    mode
                }
            })
        }
        KIND_SPIKE => {
            let lo = [ox as f64, oy as f64];
            let (t0, t1) =
                ray_in_box([f(0), f(1)], [f(2), f(3)], f(4), f(5), lo, [lo[0] + tile as f64, lo[1] + tile as f64]);
            if t1 > t0 {
                7
            } else {
                0
            }
        }
        KIND_GLOW => 7,
        KIND_FITTED => super::fitted::fitted_bin(s, origin),
        _ => 0,
    }
}

/// The part [t0, t1] of the ray o + t d, t in [t_min, t_max], inside the box lo..hi (t0 >= t1:
/// none); an axis the ray runs along counts the box half-open.
pub fn ray_in_box(o: [f64; 2], d: [f64; 2], t_min: f64, t_max: f64, lo: [f64; 2], hi: [f64; 2]) -> (f64, f64) {
    let (mut t0, mut t1) = (t_min, t_max);
    for a in 0..2 {
        if d[a].abs() < 1e-12 {
            if o[a] < lo[a] || o[a] >= hi[a] {
                return (1.0, 0.0);
            }
        } else {
            let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    (t0, t1)
}
