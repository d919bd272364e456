//! Walch 2017's measured ghosts (ch. 6) on the GPU, a shader of the ghost-sprite family
//! (glsl/tools/bezier_ghosts.comp): a list of primitives ([`BezierGhost`]), each adding eq 6.4's light
//! of its signed distance times its colour to the pixels of its bounds. The signed distance is
//! the 12-step search of glsl/include/bezier_ghost.glsl, whose f32 twin is
//! [`search_signed_distance`](crate::passes::flare::ghost_shape::search_signed_distance); src/optics/bezier_ghost.rs has the exact one it is tested against.
//! `realcam flare` draws the fitted primitives with it beside the matrix ghosts.

use crate::gpu::shaders::bezier_ghost::{
    BEZIER_BOUNDS, BEZIER_COLOUR, BEZIER_ROLL, BEZIER_SHAPE, BEZIER_TRANSFER, BEZIER_WORDS,
};
use crate::gpu::{GpuResult, HostData, Kernel, Profile, Recorder, Shader, Twin, TwinCheck};
use crate::optics::bezier_ghost::BezierGhost;
use crate::passes::barriers::overwrite;
use crate::passes::flare::ghost_shape::primitive_light;
use crate::passes::groups_for;
use ash::vk;

pub const NAME: &str = "bezier_ghosts";

crate::shader_bindings! {
    /// The bindings of glsl/tools/bezier_ghosts.comp.
    pub struct BezierGhostsBindings {
        color_in: image(color_in),
        color_out: image(color_out),
        ghosts: buffer(BezierGhosts),
    }
}

/// The push constants: the image size and the number of primitives.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BezierGhostsPush {
    pub size: [i32; 2],
    pub count: u32,
}

/// glsl/tools/bezier_ghosts.comp: one invocation per pixel.
pub struct BezierGhostsShader;

impl Shader for BezierGhostsShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = BezierGhostsBindings<'a>;
    type Push = BezierGhostsPush;
}

/// One primitive drawn: the ghost in its own frame, its colour, and eq 8.2's roll (radians,
/// counter-clockwise on screen) about `pivot_px`, the image centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawnGhost {
    pub ghost: BezierGhost,
    pub colour: [f64; 3],
    pub roll_rad: f64,
    pub pivot_px: [f64; 2],
}

impl DrawnGhost {
    /// The primitive's words (glsl/include/bezier_ghost.glsl); None for non-finite parameters
    /// (nothing is drawn rather than NaN).
    pub fn words(&self) -> Option<[f32; BEZIER_WORDS as usize]> {
        let g = &self.ghost;
        let p = g.to_params();
        let roll = [self.roll_rad];
        let mut all = p.iter().chain(&self.colour).chain(&roll).chain(&self.pivot_px);
        if !all.all(|v| v.is_finite()) {
            return None;
        }
        let mut w = [0.0f32; BEZIER_WORDS as usize];
        // The bounds of the turned box: its corners turned about the pivot.
        let b = g.bounds_px();
        let (c, s) = (self.roll_rad.cos(), self.roll_rad.sin());
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for (x, y) in [(b[0], b[1]), (b[2], b[1]), (b[0], b[3]), (b[2], b[3])] {
            let o = [x - self.pivot_px[0], y - self.pivot_px[1]];
            // Counter-clockwise on screen (y down): the inverse of the shader's turn back.
            let t = [self.pivot_px[0] + c * o[0] + s * o[1], self.pivot_px[1] - s * o[0] + c * o[1]];
            (0..2).for_each(|a| {
                lo[a] = lo[a].min(t[a]);
                hi[a] = hi[a].max(t[a]);
            });
        }
        let bounds = [lo[0], lo[1], hi[0], hi[1]];
        for k in 0..4 {
            w[(BEZIER_BOUNDS + k) as usize] = bounds[k as usize] as f32;
        }
        for k in 0..7 {
            w[(BEZIER_SHAPE + k) as usize] = p[k as usize] as f32;
        }
        for k in 0..6 {
            w[(BEZIER_TRANSFER + k) as usize] = p[7 + k as usize] as f32;
        }
        for k in 0..3 {
            w[(BEZIER_COLOUR + k) as usize] = self.colour[k as usize] as f32;
        }
        let roll = [c, -s, self.pivot_px[0], self.pivot_px[1]];
        for k in 0..4 {
            w[(BEZIER_ROLL + k) as usize] = roll[k as usize] as f32;
        }
        Some(w)
    }
}

impl Twin for BezierGhostsShader {
    fn cpu(push: &BezierGhostsPush, groups: [u32; 3], b: &mut [HostData]) {
        let ghosts = crate::passes::twin::floats(b[2].words());
        let input = b[0].image().clone();
        let w = (groups[0] * crate::passes::TILE_SIZE).min(push.size[0].max(0) as u32);
        let h = (groups[1] * crate::passes::TILE_SIZE).min(push.size[1].max(0) as u32);
        let out = b[1].image_mut();
        for y in 0..h {
            for x in 0..w {
                let q = [x as f32 + 0.5, y as f32 + 0.5];
                let mut sum = [0.0f32; 3];
                for g in ghosts.chunks_exact(BEZIER_WORDS as usize).take(push.count as usize) {
                    let inside = q[0] >= g[0] && q[0] <= g[2] && q[1] >= g[1] && q[1] <= g[3];
                    if !inside {
                        continue;
                    }
                    let light = primitive_light(g, q);
                    (0..3).for_each(|k| sum[k] += light * g[BEZIER_COLOUR as usize + k]);
                }
                let c = input.clamped(x as i32, y as i32);
                let texel = out.texel_mut(x, y);
                for k in 0..3 {
                    texel[k] = crate::passes::twin::finite_or_zero(c[k]) + sum[k];
                }
                texel[3] = crate::passes::twin::finite_or_zero(c[3]);
            }
        }
    }

    /// Branches of the search (a halving's side, the best coarse sample) may fall the other way
    /// on a GPU where two are within rounding; the secant ends within the same rounding.
    const TOLERANCE: f32 = 2e-4;
}

/// Record the shader: `color_in` plus every primitive of `ghosts` (count words) into `color_out`.
pub fn record(
    kernel: &Kernel<BezierGhostsShader>,
    rec: &mut Recorder,
    b: &BezierGhostsBindings<'_>,
    count: u32,
) -> GpuResult<()> {
    rec.begin_pass(NAME);
    // color_in and ghosts: uploaded, and the upload's own barriers made them visible to compute
    //   reads. color_out: written from scratch; its old contents are discarded.
    rec.image_barriers(&[overwrite(b.color_out)]);
    let push = BezierGhostsPush { size: [b.color_in.width as i32, b.color_in.height as i32], count };
    kernel.dispatch(rec, b, &push, groups_for(b.color_in.width, b.color_in.height))?;
    rec.end_pass();
    Ok(())
}

/// Draw `ghosts` onto a black `width x height` frame on the GPU: the RGBA image, the profile
/// (the shader's GPU time under [`NAME`]) and, with `twin_checks`, the dispatch against its twin.
pub fn draw(
    kernel: &Kernel<BezierGhostsShader>,
    rec_label: &str,
    gpu: &crate::gpu::Gpu,
    width: u32,
    height: u32,
    ghosts: &[DrawnGhost],
    twin_checks: bool,
) -> GpuResult<(Vec<f32>, Profile, Vec<TwinCheck>)> {
    let mut rec =
        if twin_checks { Recorder::with_twin_checks(gpu, rec_label)? } else { Recorder::new(gpu, rec_label)? };
    let words: Vec<f32> = ghosts.iter().filter_map(DrawnGhost::words).flatten().collect();
    let count = (words.len() / BEZIER_WORDS as usize) as u32;
    rec.begin_pass("upload");
    let color_in = rec.create_image("color (black)", width, height, vk::Format::R32G32B32A32_SFLOAT)?;
    rec.upload_images(&[(&color_in, &vec![0.0f32; (width * height * 4) as usize])])?;
    let buffer = rec.upload_buffer("bezier ghosts", &words)?;
    rec.end_pass();
    let color_out = rec.create_image("color (bezier ghosts)", width, height, vk::Format::R32G32B32A32_SFLOAT)?;
    let bindings = BezierGhostsBindings { color_in: &color_in, color_out: &color_out, ghosts: &buffer };
    record(kernel, &mut rec, &bindings, count)?;
    rec.begin_pass("download");
    rec.download_image(&color_out, 4)?;
    rec.end_pass();
    let (profile, mut images, checks) = rec.submit_checked()?;
    Ok((images.pop().unwrap_or_default(), profile, checks))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::bezier_ghost::{Transfer, CIRCLE_CONTROL};
    use crate::passes::flare::ghost_shape::{search_signed_distance, transfer};

    fn ghost(left_control: f64, right_control: f64) -> BezierGhost {
        BezierGhost {
            centre_px: [412.3, 287.9],
            height_px: 38.0,
            left_px: 24.0,
            right_px: 51.0,
            left_control,
            right_control,
            transfer: Transfer {
                border: 1.0,
                inner: 0.2,
                inner_falloff_px: 6.0,
                outer_falloff_px: 3.0,
                inner_exponent: 1.0,
                outer_exponent: 1.0,
            },
        }
    }

    #[test]
    fn the_12_step_search_is_within_1e_3_px_of_the_exact_root() {
        // Random points inside, outside and near the joins (the assembly points top, bottom,
        // left and right), at several controls (0: corners at the joins), at a place in the
        // image where f32 has 3e-5 px of resolution.
        let mut seed = 99u64;
        let mut rand = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut inside, mut outside, mut joins, mut worst) = (0, 0, 0, 0.0f64);
        for (cl, cr) in [(CIRCLE_CONTROL, CIRCLE_CONTROL), (0.2, 0.9), (0.0, 0.6), (1.0, 0.4)] {
            let g = ghost(cl, cr);
            let words = DrawnGhost { ghost: g, colour: [1.0; 3], roll_rad: 0.0, pivot_px: [0.0; 2] }.words().unwrap();
            let shape = &words[BEZIER_SHAPE as usize..][..7];
            let [mx, my] = g.centre_px;
            let join_points = [[mx, my - 38.0], [mx, my + 38.0], [mx - 24.0, my], [mx + 51.0, my]];
            for i in 0..1500 {
                let q = if i % 3 == 0 {
                    let j = join_points[i / 3 % 4];
                    [j[0] + 4.0 * (rand() - 0.5), j[1] + 4.0 * (rand() - 0.5)]
                } else {
                    [mx - 40.0 + 110.0 * rand(), my - 55.0 + 110.0 * rand()]
                };
                let exact = g.signed_distance(q);
                let search = search_signed_distance(shape, [q[0] as f32, q[1] as f32]) as f64;
                // f32 query points: the exact distance of the f32 point.
                let exact_f32 = g.signed_distance([q[0] as f32 as f64, q[1] as f32 as f64]);
                let err = (search - exact_f32).abs();
                worst = worst.max(err);
                assert!(err < 1e-3, "controls {cl}/{cr}, {q:?}: search {search}, exact {exact}");
                if i % 3 == 0 {
                    joins += 1;
                } else if exact > 0.0 {
                    inside += 1;
                } else {
                    outside += 1;
                }
            }
        }
        assert!(inside > 500 && outside > 1000 && joins >= 2000, "{inside} {outside} {joins}");
        assert!(worst > 0.0);
    }

    #[test]
    fn the_f32_transfer_is_eq_6_4() {
        let g = ghost(0.5, 0.5);
        let t = [1.0f32, 0.2, 6.0, 3.0, 1.0, 1.0];
        for d in [-5.0, -3.0, -1.5, -0.1, 0.0, 0.1, 2.0, 5.9, 8.0] {
            assert!((transfer(d as f32, &t) as f64 - g.transfer.intensity(d)).abs() < 1e-6, "{d}");
        }
        assert_eq!(transfer(f32::NAN, &t), 0.0);
    }

    #[test]
    fn a_rolled_primitive_is_the_primitive_turned_about_the_pivot() {
        // Turned by 90 degrees counter-clockwise on screen about (400, 300): a point right of
        // the pivot moves straight up.
        let g = ghost(0.5, 0.5);
        let pivot = [400.0, 300.0];
        let plain = DrawnGhost { ghost: g, colour: [1.0; 3], roll_rad: 0.0, pivot_px: pivot }.words().unwrap();
        let turned = DrawnGhost {
            roll_rad: std::f64::consts::FRAC_PI_2,
            ..DrawnGhost { ghost: g, colour: [1.0; 3], roll_rad: 0.0, pivot_px: pivot }
        }
        .words()
        .unwrap();
        for q in [[412.0f32, 290.0], [440.0, 270.0], [380.0, 330.0]] {
            let o = [q[0] - 400.0, q[1] - 300.0];
            let moved = [400.0 + o[1], 300.0 - o[0]];
            let (a, b) = (primitive_light(&plain, q), primitive_light(&turned, moved));
            assert!((a - b).abs() < 1e-4, "{q:?}: {a} vs {b}");
        }
        // The turned box holds the turned shape: the right end (463.3, 287.9) goes to
        // (387.9, 236.7).
        let w = &turned;
        assert!(w[0] <= 387.9 && w[2] >= 387.9 && w[1] <= 236.7 && w[3] >= 236.7);
        // Non-finite parameters draw nothing.
        let bad = BezierGhost { height_px: f64::NAN, ..g };
        assert!(DrawnGhost { ghost: bad, colour: [1.0; 3], roll_rad: 0.0, pivot_px: pivot }.words().is_none());
    }
}
