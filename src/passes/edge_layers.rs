//! Anti-aliased edges: which layer's light a pixel holds, where its one-sample depth (and
//! velocity) belongs to one surface but its filtered colour mostly to another. Shared by the
//! depth of field's edge resolve (`dof::coc_edges`: which depth) and the motion blur's
//! (`motion::edges`: which velocity and depth). The CPU twin of glsl/include/edge_layers.glsl,
//! which says how it decides, in the same f32 arithmetic.

pub use crate::gpu::shaders::edge_layers::{EDGE_FAR, EDGE_NEAR, EDGE_OWN};

/// The layer whose light a pixel holds (glsl/include/edge_layers.glsl's `edge_layer`): `w` the
/// layer keys of its 3x3 neighbourhood in row order (inverse depth, larger nearer; `w[4]` its
/// own), `w_near` and `w_far` their largest and smallest, `c9` the neighbours' colours (`c9[4]`
/// unused), `c_p` its own; `min_share`: the share of its light the other layer must bring for the
/// pixel to change layers. [`EDGE_OWN`], [`EDGE_NEAR`] or [`EDGE_FAR`].
pub fn edge_layer(w: &[f32; 9], c9: &[[f32; 3]; 9], c_p: [f32; 3], w_near: f32, w_far: f32, min_share: f32) -> u32 {
    let w_p = w[4];
    let w_mid = 0.5 * (w_near + w_far);
    let brightness = |c: [f32; 3]| c.iter().map(|v| v.max(0.0)).sum::<f32>();
    let b9: Vec<f32> = c9.iter().map(|&c| brightness(c)).collect();
    let is_near = |i: usize| w[i] > w_mid;
    let (mut near_sum, mut near_n, mut far_n) = ([0.0f32; 3], 0.0f32, 0.0f32);
    for i in (0..9).filter(|&i| i != 4) {
        if is_near(i) {
            for (sum, v) in near_sum.iter_mut().zip(c9[i]) {
                *sum += v;
            }
            near_n += 1.0;
        } else {
            far_n += 1.0;
        }
    }
    if near_n == 0.0 || far_n == 0.0 {
        return EDGE_OWN;
    }
    let c_near = near_sum.map(|v| v / near_n);
    // The far layer's colour: its neighbour of median brightness (the darker middle one of an
    // even count, ties by position), not its mean, which a small highlight's other fringe
    // pixels inflate (glsl/include/edge_layers.glsl).
    let rank = (far_n - 1.0) as usize / 2;
    let far_of = || (0..9).filter(|&i| i != 4 && !is_near(i));
    let c_far = far_of()
        .find(|&i| far_of().filter(|&j| b9[j] < b9[i] || (b9[j] == b9[i] && j < i)).count() == rank)
        .map_or([0.0; 3], |i| c9[i]);
    let d: [f32; 3] = std::array::from_fn(|k| c_near[k] - c_far[k]);
    let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if dd <= 1.0e-12 {
        return EDGE_OWN;
    }
    // Along the line from the far layer's colour to the near one's mean, the own layer's pixels
    // span a range of alpha: a near pixel inside it (a textured surface at a hard edge) stays.
    let own_near = w_p > w_mid;
    let alpha_of = |c: [f32; 3]| (0..3).map(|k| (c[k] - c_far[k]) * d[k]).sum::<f32>() / dd;
    let (lo, hi) = (0..9)
        .filter(|&i| i != 4 && is_near(i) == own_near)
        .map(|i| alpha_of(c9[i]))
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), a| (lo.min(a), hi.max(a)));
    let alpha_p = alpha_of(c_p);
    if own_near && alpha_p >= lo && alpha_p <= hi {
        return EDGE_OWN;
    }
    let alpha = alpha_p.clamp(0.0, 1.0);
    let (near_light, far_light) = (alpha * brightness(c_near), (1.0 - alpha) * brightness(c_far));
    let to_near = near_light > far_light;
    // The other layer's share of the pixel's light, not of its area (see the shader).
    let other_share = (if to_near { near_light } else { far_light }) / (near_light + far_light).max(1.0e-30);
    if to_near == own_near || other_share < min_share {
        EDGE_OWN
    } else if to_near {
        EDGE_NEAR
    } else {
        EDGE_FAR
    }
}
