//! Motion blur, step 3: the reconstruction gather (see glsl/motion/mb_gather.comp for the model).
//! Shader: glsl/motion/mb_gather.comp.

use super::path::{clamped_velocity, depth_classes, motion_jitter, path_coverage, ShutterPush};
use crate::gpu::{HostData, HostImage, Shader, Twin};
use crate::passes::twin::finite_or_zero;

pub const NAME: &str = "mb_gather";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MbGatherPush {
    pub size: [i32; 2],
    pub tiles: [i32; 2],
    pub shutter: ShutterPush,
    pub max_speed_px: f32,
    /// Samples on each of the four lines (the cost does not depend on the speed).
    pub samples_per_line: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/motion/mb_gather.comp.
    pub struct MbGatherBindings {
        color_in: image(color_in),
        depth_m: image(depth_m),
        velocity: image(velocity),
        color_out: image(color_out),
        neighbor_motion: buffer(NeighborMotion),
        tile_motion: buffer(TileMotion),
        tile_list: buffer(TileList),
    }
}

/// glsl/motion/mb_gather.comp: one invocation per pixel of the listed tiles (mb_neighbor's).
pub struct MbGatherShader;

impl Shader for MbGatherShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = MbGatherBindings<'a>;
    type Push = MbGatherPush;
}

/// The four layers a pixel gathers (glsl `Layers`).
#[derive(Default)]
struct Layers {
    fg: [f32; 4],
    fg_a: f32,
    own: [f32; 4],
    own_a: f32,
    behind: [f32; 4],
    behind_a: f32,
    guess: [f32; 4],
    guess_n: f32,
}

fn add(acc: &mut [f32; 4], w: f32, c: &[f32; 4]) {
    for k in 0..4 {
        acc[k] += w * c[k];
    }
}

fn unit(v: [f32; 2]) -> [f32; 2] {
    let l = (v[0] * v[0] + v[1] * v[1]).sqrt();
    if l > 0.0 {
        [v[0] / l, v[1] / l]
    } else {
        [0.0, 0.0]
    }
}

fn length(v: [f32; 2]) -> f32 {
    (v[0] * v[0] + v[1] * v[1]).sqrt()
}

fn same_direction(a: [f32; 2], b: [f32; 2]) -> f32 {
    ((a[0] * b[0] + a[1] * b[1] - 0.9) / 0.08).clamp(0.0, 1.0)
}

/// The frame's images as the gather reads them.
pub struct GatherInputs<'a> {
    pub color: &'a HostImage,
    pub depth: &'a HostImage,
    pub velocity: &'a HostImage,
    /// (next.xy, prev.xy) per tile: the neighbourhood maximum.
    pub neighbor: &'a [f32],
    /// (next.xy, prev.xy) per tile: the tile's own maximum.
    pub tile: &'a [f32],
}

impl GatherInputs<'_> {
    fn color(&self, x: i32, y: i32) -> [f32; 4] {
        let c = self.color.clamped(x, y);
        [0, 1, 2, 3].map(|k| finite_or_zero(c[k]))
    }

    fn velocity(&self, x: i32, y: i32, max_speed: f32) -> [f32; 4] {
        clamped_velocity(self.velocity.clamped(x, y), max_speed)
    }
}

#[allow(clippy::too_many_arguments)]
fn sample_line(
    l: &mut Layers,
    input: &GatherInputs,
    pc: &MbGatherPush,
    p: [i32; 2],
    z_x: f32,
    win: [f32; 2],
    dir: [f32; 2],
    reach: f32,
    same: f32,
    other_reach: f32,
    own_line: bool,
    k: i32,
) {
    let n = pc.samples_per_line;
    if reach <= 0.5 || n <= 0 {
        return;
    }
    let spacing = (reach - 0.5) / n as f32;
    // In the whole frame's rows (a band's from band_top_px), as the shader.
    let top = pc.shutter.band_top_px;
    let jitter = motion_jitter([p[0], p[1] + top], k);
    let total = pc.shutter.total();
    for i in 0..n {
        let r = 0.5 + (i as f32 + jitter) * spacing;
        let at = [p[0] as f32 + 0.5 + r * dir[0], (p[1] + top) as f32 + 0.5 + r * dir[1]];
        let y =
            [(at[0].floor() as i32).clamp(0, pc.size[0] - 1), (at[1].floor() as i32 - top).clamp(0, pc.size[1] - 1)];
        let o = [(p[0] - y[0]) as f32, (p[1] - y[1]) as f32];
        let v = input.velocity(y[0], y[1], pc.max_speed_px);
        let light = path_coverage(o, [v[0], v[1]], [v[2], v[3]], win, pc.shutter.ramp_frames) / total;
        let share =
            if own_line { 1.0 - 0.5 * same } else { 1.0 - 0.5 * same * (other_reach + 0.5 - r).clamp(0.0, 1.0) };
        let w = light * spacing * share;
        let c = input.color(y[0], y[1]);
        let cls = depth_classes(z_x, input.depth.clamped(y[0], y[1])[0]);
        add(&mut l.fg, cls[0] * w, &c);
        l.fg_a += cls[0] * w;
        add(&mut l.own, cls[1] * w, &c);
        l.own_a += cls[1] * w;
        add(&mut l.behind, cls[2] * w, &c);
        l.behind_a += cls[2] * w;
        // The hidden background's estimate, by nearness to X (the shader's comment).
        let near = 1.0 - r / (reach + 0.5);
        add(&mut l.guess, cls[2] * share * near, &c);
        l.guess_n += cls[2] * share * near;
    }
}

/// The gather at pixel `p` (the shader's `main`).
pub fn gather_pixel(input: &GatherInputs, pc: &MbGatherPush, p: [i32; 2]) -> [f32; 4] {
    let c = input.color(p[0], p[1]);
    let tile = [p[0] / crate::passes::TILE_SIZE as i32, p[1] / crate::passes::TILE_SIZE as i32];
    let nm = &input.neighbor[4 * (tile[1] * pc.tiles[0] + tile[0]) as usize..][..4];
    let win = pc.shutter.window([p[0] as f32 + 0.5, p[1] as f32 + 0.5]);
    let (t_fwd, t_back) = (win[1].max(0.0), (-win[0]).max(0.0));
    let reach_next_n = t_fwd * length([nm[0], nm[1]]);
    let reach_prev_n = t_back * length([nm[2], nm[3]]);
    if reach_next_n.max(reach_prev_n) < 0.5 {
        return c;
    }
    let z_x = input.depth.clamped(p[0], p[1])[0];
    let v = input.velocity(p[0], p[1], pc.max_speed_px);
    let (mut reach_next_x, mut reach_prev_x) = (t_fwd * length([v[0], v[1]]), t_back * length([v[2], v[3]]));
    let total = pc.shutter.total();
    // A still pixel samples along its own tile's longest velocities instead, where they point
    // another way than the neighbourhood's (the shader).
    let tm = &input.tile[4 * (tile[1] * pc.tiles[0] + tile[0]) as usize..][..4];
    let (mut line_next, mut line_prev) = ([v[0], v[1]], [v[2], v[3]]);
    if reach_next_x <= 0.5 && same_direction(unit([nm[0], nm[1]]), unit([tm[0], tm[1]])) <= 0.0 {
        line_next = [tm[0], tm[1]];
        reach_next_x = t_fwd * length(line_next);
    }
    if reach_prev_x <= 0.5 && same_direction(unit([nm[2], nm[3]]), unit([tm[2], tm[3]])) <= 0.0 {
        line_prev = [tm[2], tm[3]];
        reach_prev_x = t_back * length(line_prev);
    }
    let mut l = Layers::default();
    l.own_a = path_coverage([0.0, 0.0], [v[0], v[1]], [v[2], v[3]], win, pc.shutter.ramp_frames) / total;
    l.own = c.map(|x| l.own_a * x);
    let (next_n, prev_n) = (unit([nm[0], nm[1]]), unit([nm[2], nm[3]]));
    let next_x = if reach_next_x > 0.5 { unit(line_next) } else { [0.0; 2] };
    let prev_x = if reach_prev_x > 0.5 { unit(line_prev) } else { [0.0; 2] };
    let (same_next, same_prev) = (same_direction(next_n, next_x), same_direction(prev_n, prev_x));
    let neg = |d: [f32; 2]| [-d[0], -d[1]];
    let lines = [
        (neg(next_n), reach_next_n, same_next, reach_next_x, false),
        (neg(next_x), reach_next_x, same_next, reach_next_n, true),
        (neg(prev_n), reach_prev_n, same_prev, reach_prev_x, false),
        (neg(prev_x), reach_prev_x, same_prev, reach_prev_n, true),
    ];
    for (k, (dir, reach, same, other, own_line)) in lines.into_iter().enumerate() {
        sample_line(&mut l, input, pc, p, z_x, win, dir, reach + 0.5, same, other + 0.5, own_line, k as i32);
    }
    let fg_a = l.fg_a.min(1.0);
    let fg = if l.fg_a > 0.0 { l.fg.map(|x| x * (fg_a / l.fg_a)) } else { [0.0; 4] };
    let own_a = l.own_a.min(1.0);
    let own = if l.own_a > 0.0 { l.own.map(|x| x * (own_a / l.own_a)) } else { [0.0; 4] };
    let behind = if l.behind_a > 0.05 {
        l.behind.map(|x| x / l.behind_a)
    } else if l.guess_n > 0.0 {
        l.guess.map(|x| x / l.guess_n)
    } else if l.own_a > 0.0 {
        l.own.map(|x| x / l.own_a)
    } else {
        c
    };
    std::array::from_fn(|k| finite_or_zero(fg[k] + (1.0 - fg_a) * (own[k] + (1.0 - own_a) * behind[k])))
}

/// The pixels of a tile list's tile (column | row << 16) within a `size` frame (the shaders'
/// `listed_tile_pixel` over a workgroup).
pub fn listed_tile_pixels(packed_tile: u32, size: [i32; 2]) -> impl Iterator<Item = [i32; 2]> {
    let side = crate::passes::TILE_SIZE as i32;
    let (tx, ty) = crate::passes::dof::coc_edges::unpack_pixel(packed_tile);
    let first = [tx * side, ty * side];
    (first[1]..(first[1] + side).min(size[1]))
        .flat_map(move |y| (first[0]..(first[0] + side).min(size[0])).map(move |x| [x, y]))
}

impl Twin for MbGatherShader {
    fn cpu(pc: &MbGatherPush, groups: [u32; 3], b: &mut [HostData]) {
        let (neighbor, tile) = (crate::passes::twin::floats(b[4].words()), crate::passes::twin::floats(b[5].words()));
        let (color, depth, velocity) = (b[0].image().clone(), b[1].image().clone(), b[2].image().clone());
        let input =
            GatherInputs { color: &color, depth: &depth, velocity: &velocity, neighbor: &neighbor, tile: &tile };
        let listed = b[6].words()[..groups[0] as usize].to_vec();
        let out = b[3].image_mut();
        for p in listed.into_iter().flat_map(|t| listed_tile_pixels(t, pc.size)) {
            let v = gather_pixel(&input, pc, p);
            out.texel_mut(p[0] as u32, p[1] as u32).copy_from_slice(&v);
        }
    }

    /// Sample positions land on texels by floor(): an ulp of difference in a product can pick
    /// the neighbouring texel at a rare sample; the tolerance allows one sample's share.
    const TOLERANCE: f32 = 2e-3;
}
