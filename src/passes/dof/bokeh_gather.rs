//! Depth-of-field gather pass: aperture-shaped circles of confusion, background and foreground
//! kept apart (see glsl/dof/bokeh_gather.comp for the rules), energy spread over each CoC's area.

use super::aperture::{shape_radius_for, tap_disc_rows, tap_weight, ApertureConstants, ApertureData};
use crate::gpu::{Gpu, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::model::aperture::ApertureShape;
use crate::model::camera::{BokehMode, Camera};
use crate::passes::barriers::{after_compute_write, overwrite};
use crate::passes::scene::{Channel, PlanInput, VISIBLE_COC_PX};
use crate::passes::twin::finite_or_zero;
use crate::passes::{groups_for, Decision, FrameImages, Pass};
use ash::vk;

pub const NAME: &str = "bokeh_gather";

/// Push constants of glsl/dof/bokeh_gather.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherPush {
    pub size: [i32; 2],
    pub radius_px: i32,
    pub aperture: ApertureConstants,
    pub layer_transition_px: f32,
}

impl GatherPush {
    /// `sa_max_coc_px`: the CoC diameter at which spherical aberration reaches its full amount
    /// (the user's CoC clamp, like the appendix shader's largest CoC).
    pub fn new(
        width: u32,
        height: u32,
        max_abs_coc_px: f64,
        aperture: &ApertureShape,
        sa_max_coc_px: f64,
        centre_px: [f64; 2],
    ) -> GatherPush {
        GatherPush {
            size: [width as i32, height as i32],
            radius_px: (0.5 * max_abs_coc_px).ceil() as i32 + 1,
            aperture: ApertureConstants::new(aperture, sa_max_coc_px, centre_px, width, height),
            layer_transition_px: 1.0,
        }
    }
}

/// CPU twin of the gather, same rules and f32 arithmetic, for tiny images.
pub fn gather_cpu(rgba: &[f32], coc_px: &[f32], p: &GatherPush, aperture: &ApertureData) -> Vec<f32> {
    let (w, h) = (p.size[0], p.size[1]);
    let mut out = vec![0.0f32; rgba.len()];
    // radius_px - 1: the largest CoC radius, rounded up.
    let disc_px = aperture.tap_disc_px((p.radius_px - 1) as f32);
    for y in 0..h {
        for x in 0..w {
            let texel =
                gather_exact(rgba, coc_px, [w, h], [x, y], disc_px, &p.aperture, p.layer_transition_px, aperture);
            let o = (y * w + x) as usize * 4;
            out[o..o + 4].copy_from_slice(&texel);
        }
    }
    out
}

/// The exact gather at pixel `p` over the taps in the disc of radius `disc_px` (gather_exact in
/// glsl/include/gather.glsl): RGBA `color` and signed `coc_px` of a `size[0] x size[1]` image.
#[allow(clippy::too_many_arguments)]
pub fn gather_exact(
    color: &[f32],
    coc_px: &[f32],
    size: [i32; 2],
    p: [i32; 2],
    disc_px: f32,
    aperture: &ApertureConstants,
    layer_transition_px: f32,
    data: &ApertureData,
) -> [f32; 4] {
    let (w, h) = (size[0], size[1]);
    let coc_p = coc_px[(p[1] * w + p[0]) as usize];
    let radius_p = (0.5 * coc_p.abs()).max(0.5);
    // A sample spread over p's own CoC would carry 1 / (this) at p.
    let area_p_px2 = aperture.area_factor * radius_p * radius_p;
    let (mut bg, mut fg, mut hidden) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
    let (mut bg_w, mut fg_w, mut own_n) = (0.0f32, 0.0f32, 0.0f32);
    let (mut hidden_n, mut hidden_near_w) = (0.0f32, 0.0f32);
    for (dy, half_width) in tap_disc_rows(disc_px) {
        for dx in -half_width..=half_width {
            // Clamp to edge, like the shader.
            let (ux, uy) = (p[0] + dx, p[1] + dy);
            let qi = (uy.clamp(0, h - 1) * w + ux.clamp(0, w - 1)) as usize;
            let coc_q = coc_px[qi];
            let sample_px = [ux as f32 + 0.5, uy as f32 + 0.5];
            let wgt = tap_weight([dx, dy], coc_p, coc_q, aperture, sample_px, data);
            let f = ((coc_p - coc_q) / layer_transition_px).clamp(0.0, 1.0);
            // Within p's own CoC: the positions not in front of p, and the ones behind p whose
            // light does not reach p (the shader's hidden background).
            let in_p = if ((dx * dx + dy * dy) as f32) <= radius_p * radius_p { 1.0 } else { 0.0 };
            let behind = ((coc_q - coc_p) / layer_transition_px).clamp(0.0, 1.0);
            let unreached = in_p * behind * (1.0 - (wgt * area_p_px2).min(1.0));
            // Its colour from the nearest such positions on the scale of their own CoC,
            // weighted 1 / (1 + d^2 / radius_q^2)^3: the background's blurred image at p,
            // hidden by p's surface (see the shader).
            let radius_q = (0.5 * coc_q.abs()).max(0.5);
            let closeness = 1.0 / (1.0 + (dx * dx + dy * dy) as f32 / (radius_q * radius_q));
            let near = unreached * closeness * closeness * closeness;
            for (c, h) in hidden.iter_mut().enumerate() {
                *h += near * finite_or_zero(color[qi * 4 + c]);
            }
            hidden_n += unreached;
            hidden_near_w += near;
            own_n += in_p * (1.0 - f);
            if wgt <= 0.0 {
                continue;
            }
            for c in 0..4 {
                let v = finite_or_zero(color[qi * 4 + c]);
                fg[c] += f * wgt * v;
                bg[c] += (1.0 - f) * wgt * v;
            }
            fg_w += f * wgt;
            bg_w += (1.0 - f) * wgt;
        }
    }
    // The weight missing from p's own layer and behind, up to the share of p's disc that is
    // background not reaching p, is filled with that background's colour nearest p (see the shader: a
    // defocused object smaller than its CoC keeps only its share of the light at its pixels);
    // the rest normalises.
    let hidden_share = if own_n > 0.0 { hidden_n / own_n } else { 0.0 };
    let missing = (1.0 - bg_w).max(0.0).min(hidden_share);
    let lit_w = bg_w + missing;
    let alpha = fg_w.clamp(0.0, 1.0);
    std::array::from_fn(|c| {
        let hidden_colour = if hidden_near_w > 0.0 { hidden[c] / hidden_near_w } else { 0.0 };
        let b = if lit_w > 0.0 { (bg[c] + missing * hidden_colour) / lit_w } else { 0.0 };
        let f = if fg_w > 0.0 { fg[c] / fg_w } else { 0.0 };
        b + (f - b) * alpha
    })
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/bokeh_gather.comp.
    pub struct GatherBindings {
        color_in: image(color_in),
        coc_px: image(coc_px),
        color_out: image(color_out),
        aperture_mask: buffer(ApertureMask),
        aperture_shape: image(aperture_shape),
    }
}

/// glsl/dof/bokeh_gather.comp.
pub struct GatherShader;

impl Shader for GatherShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = GatherBindings<'a>;
    type Push = GatherPush;
}

impl Twin for GatherShader {
    fn cpu(push: &GatherPush, _groups: [u32; 3], b: &mut [HostData]) {
        let data = ApertureData::from_bindings(&b[3], &b[4], push.aperture.shape_radius);
        let out = gather_cpu(&b[0].image().texels, &b[1].image().texels, push, &data);
        b[2].image_mut().texels = out;
    }

    /// The hidden background's fill mixes by the weights' sum itself (1 - bg_w), not only by
    /// their ratios, in which a relative difference of the aperture's weights between the GPU
    /// and the CPU (their transcendental functions: spherical aberration, cat's eye, an aperture
    /// image) cancels: measured 1.5e-4 on the twin cases with all of those. A little more room.
    const TOLERANCE: f32 = 3e-4;
}

/// One run: the constants, the aperture's data, and the channel it is for.
#[derive(Clone, Debug)]
pub struct GatherParams {
    pub push: GatherPush,
    pub aperture: ApertureData,
    pub channel: Option<Channel>,
}

/// The reference depth of field (`--bokeh reference`).
pub struct BokehGather {
    kernel: Kernel<GatherShader>,
}

impl From<GatherPush> for GatherParams {
    /// One run for all channels, without an aperture image.
    fn from(push: GatherPush) -> GatherParams {
        let (aperture, data) = ApertureData::new(push.aperture, None, push.radius_px as u32 + 1);
        GatherParams { push: GatherPush { aperture, ..push }, aperture: data, channel: None }
    }
}

impl Pass for BokehGather {
    const NAME: &'static str = NAME;
    type Params = GatherParams;

    /// The gather's disc: the largest CoC radius.
    fn reach_px(p: &GatherParams) -> Option<f64> {
        Some(p.push.radius_px as f64 + 2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<GatherParams> {
        let (f, camera) = (&input.facts, input.camera);
        if let Some(gated) = input.dof_method_gate(BokehMode::Reference) {
            return gated;
        }
        let (w, h) = input.size();
        let max_abs_coc_px = f.max_abs_coc_px();
        let mut push =
            GatherPush::new(w, h, max_abs_coc_px, &camera.aperture, f.sa_full_strength_coc_px, input.frame.centre_px);
        if input.frame.band.is_some() {
            // A band's cat's eye grows towards the whole frame's farthest corner.
            push.aperture.cats_eye_per_px = camera.aperture.cats_eye_per_px_at(input.frame.farthest_corner_px()) as f32;
        }
        let (aperture, data) = ApertureData::new(
            push.aperture.with_pitch(camera, f.pixel_pitch_mm),
            camera.aperture_mask.as_ref(),
            shape_radius_for(max_abs_coc_px),
        );
        push.aperture = aperture;
        let why = format!(
            "--bokeh reference: largest CoC {max_abs_coc_px:.1} px > {VISIBLE_COC_PX} px, exact gather of radius {} px everywhere, {}",
            push.radius_px,
            input.aperture_text()
        );
        let runs = input
            .dof_runs()
            .into_iter()
            .map(|(channel, _)| GatherParams { push, aperture: data.clone(), channel })
            .collect();
        Decision::run_each(runs, why)
    }

    /// The method the camera chose.
    fn likely(camera: &Camera, _velocity: bool) -> bool {
        camera.bokeh == BokehMode::Reference
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(BokehGather { kernel: Kernel::new(gpu)? })
    }

    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &GatherParams) -> GpuResult<()> {
        rec.begin_pass(NAME);
        let (color, coc) = (images.color().clone(), images.coc(p.channel)?.clone());
        let output =
            rec.create_image("color (depth of field)", images.width, images.height, vk::Format::R32G32B32A32_SFLOAT)?;
        let (mask, shape) = p.aperture.upload(rec)?;
        // coc: written by the CoC pass just before: wait for it (read-after-write).
        // color: the upload's barrier already made it visible to compute reads; waiting on
        //   compute writes as well keeps this pass correct if a compute pass ever precedes it.
        // output: written from scratch.
        rec.image_barriers(&[after_compute_write(&coc), after_compute_write(&color), overwrite(&output)]);
        let bindings = GatherBindings {
            color_in: &color,
            coc_px: &coc,
            color_out: &output,
            aperture_mask: &mask,
            aperture_shape: &shape,
        };
        self.kernel.dispatch(rec, &bindings, &p.push, groups_for(color.width, color.height))?;
        rec.end_pass();
        images.set_color(p.channel, output);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One row (clamp to edge continues it up and down: a scene infinite in height) of `w`
    /// pixels: a defocused wall (`wall`, signed CoC `wall_coc_px`) left of `edge`, an in-focus
    /// background (`background`, CoC 0) from `edge` on; the gather's output.
    fn wall_over_background(w: i32, edge: i32, wall: f32, wall_coc_px: f32, background: f32) -> Vec<f32> {
        let rgba: Vec<f32> =
            (0..w).flat_map(|x| if x < edge { [wall, wall, wall, 1.0] } else { [background; 4] }).collect();
        let coc: Vec<f32> = (0..w).map(|x| if x < edge { wall_coc_px } else { 0.0 }).collect();
        let push =
            GatherPush::new(w as u32, 1, wall_coc_px.abs() as f64, &ApertureShape::CIRCLE, 64.0, [0.5 * w as f64, 0.5]);
        let params = GatherParams::from(push);
        gather_cpu(&rgba, &coc, &params.push, &params.aperture).chunks_exact(4).map(|p| p[0]).collect()
    }

    #[test]
    fn a_blurred_foreground_edge_over_a_sharp_background_fades_symmetrically_and_its_inside_stays_flat() {
        // A wall in front of the focus (CoC 12 px: radius 6) ends over an in-focus background.
        // Physically the edge is a ramp: at distance d inside the edge a pixel sees the wall
        // over the share A of its disc that the wall covers and the background behind it over
        // the rest; at d outside, the wall covers the background by the share 1 - A. So the
        // wall's share inside and outside sum to 1 at every d, and the frame's energy is kept.
        // Measured: the sums within 0.6% of 1 (the discrete discs' weights). Normalising the
        // wall's own layer (as before) kept the inside at full strength up to the edge (the
        // shares summed to 1.45 there). Beyond its CoC the wall stays exactly flat.
        let (w, edge, wall, background, radius_px) = (64, 32, 2.0f32, 0.4f32, 6);
        let out = wall_over_background(w, edge, wall, -2.0 * radius_px as f32, background);
        let share = |x: i32| (out[x as usize] - background) / (wall - background);
        for d in 0..radius_px {
            let (inside, outside) = (share(edge - 1 - d), share(edge + d));
            assert!(
                (inside + outside - 1.0).abs() < 0.01,
                "{d} px from the edge: the wall's share {inside:.3} inside and {outside:.3} outside"
            );
        }
        for x in 0..edge - radius_px - 1 {
            assert!((out[x as usize] - wall).abs() <= 1e-5 * wall, "x {x}: the wall's inside is {}", out[x as usize]);
        }
        for x in edge + radius_px + 2..w {
            assert_eq!(out[x as usize], background, "x {x}: the sharp background beyond the wall's reach changed");
        }
        let moved: f32 =
            out.iter().enumerate().map(|(x, &v)| v - if (x as i32) < edge { wall } else { background }).sum();
        assert!(moved.abs() < 0.03 * (wall - background), "the row's energy moved by {moved}");
    }

    #[test]
    fn a_small_defocused_highlight_shows_the_background_it_hides_not_the_mean_of_its_disc() {
        // Scene A's HL15 in small: a bright 3x3 px sphere in front of the focus (CoC 16 px:
        // radius 8) over an in-focus background that is bright (0.7) up to 3 px right of the
        // sphere and dark (0) beyond, like the Siemens star's edge beside HL15. An in-focus
        // background sends each pixel the light of the one point behind it, so inside the
        // sphere's disc every pixel holds the sphere's spread light plus the background behind
        // it times the share of the aperture the sphere leaves open. The sphere's own pixels
        // hide the bright background (its pinhole image continues under them), so they must
        // match the bright disc pixels beside them, as they do in Cycles. The hidden
        // background's colour was the mean over the sphere's whole disc, which takes in the dark
        // side: the sphere's pixels were 0.06-0.16 below their neighbours (up to 3.5% of the
        // disc's light above the background; HL15's reference disc was 0.2 below its ring).
        // Now the nearest visible background gives it; measured: within 0.004. The frame's
        // sum moved by -1.6 before, -0.6 now.
        let (w, h, c, sphere, bright, coc_px) = (41i32, 41i32, 20i32, 100.0f32, 0.7f32, -16.0f32);
        let is_sphere = |x: i32, y: i32| (x - c).abs() <= 1 && (y - c).abs() <= 1;
        let background = |x: i32| if x < c + 5 { bright } else { 0.0 };
        let (mut rgba, mut coc) = (Vec::new(), Vec::new());
        for y in 0..h {
            for x in 0..w {
                let v = if is_sphere(x, y) { sphere } else { background(x) };
                rgba.extend_from_slice(&[v, v, v, 1.0]);
                coc.push(if is_sphere(x, y) { coc_px } else { 0.0 });
            }
        }
        let push = GatherPush::new(w as u32, h as u32, 16.0, &ApertureShape::CIRCLE, 64.0, [20.5, 20.5]);
        let params = GatherParams::from(push);
        let out = gather_cpu(&rgba, &coc, &params.push, &params.aperture);
        let at = |x: i32, y: i32| out[((y * w + x) * 4) as usize];
        // The bright disc pixels left of the sphere, well inside its disc (radius 8 around each
        // of its pixels): the plateau there.
        let ring: Vec<f32> = (-1..=1).flat_map(|dy| [at(c - 3, c + dy), at(c - 4, c + dy)]).collect();
        let plateau = ring.iter().sum::<f32>() / ring.len() as f32;
        assert!(ring.iter().all(|v| (v - plateau).abs() < 0.01), "the bright ring is not flat: {ring:?}");
        // The sphere's spread light is 9 x 100 over the disc's area (pi 64 px2), about 4.5.
        assert!((plateau - bright - 900.0 / (std::f32::consts::PI * 64.0)).abs() < 0.3, "plateau {plateau}");
        for y in c - 1..=c + 1 {
            for x in c - 1..=c + 1 {
                assert!(
                    (at(x, y) - plateau).abs() < 0.02,
                    "sphere pixel ({x}, {y}): {} where the bright disc beside it is {plateau}",
                    at(x, y)
                );
            }
        }
        // The light is kept: the frame's sum moves by less than 1% of the sphere's.
        let moved: f32 = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| at(x, y) - if is_sphere(x, y) { sphere } else { background(x) })
            .sum();
        assert!(moved.abs() < 9.0, "the frame's energy moved by {moved}");
    }
}
