//! Circle-of-confusion pass: signed CoC diameter in pixels per pixel, from planar depth
//! (Kyaw 2013 eq 5.3), and the anti-aliased-edge resolve over the pixels that need it. Shaders:
//! glsl/dof/coc.comp (every pixel's CoC from its own depth, and the list of edge pixels) and
//! glsl/dof/coc_edges.comp (an indirect dispatch over that list).

use super::coc_edges::{self, at_edge, pack_pixel, resolved_inverse_depth, CocEdgesBindings, CocEdgesShader};
use super::coc_push::{table_data, CocPush};
use crate::gpu::shaders::coc::{COC_ARGS_COUNT, COC_ARGS_DISPATCH, COC_ARGS_WORDS, EDGE_GROUP_SIZE};
use crate::gpu::{Gpu, GpuResult, HostData, HostImage, Recorder, Shader, SpecializedKernel, Twin};
use crate::model::camera::{BokehMode, Camera};
use crate::passes::barriers::{
    after_compute_write, args_for_indirect, buffer_after_compute_write, buffer_after_fill, overwrite, write_after_write,
};
use crate::passes::scene::{Channel, PlanInput, VISIBLE_COC_PX};
use crate::passes::twin::floats;
use crate::passes::{groups_for, Decision, FrameImages, Input, Pass};
use ash::vk;

pub const NAME: &str = "coc";

/// CPU twin of the whole pass: the CoC of every pixel from the depth its colour belongs to
/// (the edge resolve when `push.resolve_edges` is set). `rgba` is the colour pass.
pub fn coc_resolved_cpu(depth_m: &[f32], rgba: &[f32], push: &CocPush, table: &[f32]) -> Vec<f32> {
    let (w, h) = (push.size[0].max(1) as u32, push.size[1].max(1) as u32);
    let depth = HostImage::new(w, h, 1, depth_m.to_vec());
    let color = HostImage::new(w, h, 4, rgba.to_vec());
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let inv_u = resolved_inverse_depth(&depth, &color, push, x as i32, y as i32);
            push.coc_px_of_inverse_depth(inv_u, x, y, table)
        })
        .collect()
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/coc.comp.
    pub struct CocBindings {
        depth_m: image(depth_m),
        coc_px: image(coc_px),
        field_curvature: buffer(FieldCurvature),
        args: buffer(Args),
        edge_pixels: buffer(EdgePixels),
    }
}

/// glsl/dof/coc.comp: one invocation per pixel.
pub struct CocShader;

impl Shader for CocShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = CocBindings<'a>;
    type Push = CocPush;
}

impl Twin for CocShader {
    fn cpu(push: &CocPush, _groups: [u32; 3], b: &mut [HostData]) {
        let table = floats(b[2].words());
        let depth = b[0].image().clone();
        let resolve = push.resolve_edges != 0;
        let mut listed = Vec::new();
        let out = b[1].image_mut();
        for y in 0..push.size[1] {
            for x in 0..push.size[0] {
                out.texel_mut(x as u32, y as u32)[0] =
                    push.coc_px_at(depth.clamped(x, y)[0], x as u32, y as u32, &table);
                if resolve && at_edge(&depth, push, x, y) {
                    listed.push(pack_pixel(x, y));
                }
            }
        }
        if !resolve {
            return;
        }
        let args = b[3].words_mut();
        args[COC_ARGS_DISPATCH as usize + 1] = 1;
        args[COC_ARGS_DISPATCH as usize + 2] = 1;
        let first = args[COC_ARGS_COUNT as usize];
        let groups = (first..first + listed.len() as u32).filter(|slot| slot % EDGE_GROUP_SIZE == 0).count() as u32;
        args[COC_ARGS_COUNT as usize] += listed.len() as u32;
        args[COC_ARGS_DISPATCH as usize] += groups;
        b[4].words_mut()[first as usize..first as usize + listed.len()].copy_from_slice(&listed);
    }

    /// Pixels take slots of the edge list with atomics, in any order: sort the list.
    fn canonical(push: &CocPush, b: &mut [HostData]) {
        if push.resolve_edges == 0 {
            return;
        }
        let count = b[3].words()[COC_ARGS_COUNT as usize] as usize;
        let words = b[4].words_mut();
        let count = count.min(words.len());
        words[..count].sort_unstable();
    }
}

/// One run of the pass: its constants, the field-curvature table, and the channel it is for
/// (longitudinal colour runs it once per channel, each with its offset).
#[derive(Clone, Debug)]
pub struct CocParams {
    pub push: CocPush,
    pub table: Vec<f32>,
    pub channel: Option<Channel>,
}

impl CocParams {
    /// One run for all channels.
    pub fn new(push: CocPush, field_curvature: Option<&crate::optics::distortion::HeightTable>) -> CocParams {
        CocParams { push, table: table_data(field_curvature), channel: None }
    }
}

pub struct Coc {
    kernel: SpecializedKernel<CocShader>,
    edges: SpecializedKernel<CocEdgesShader>,
}

impl Pass for Coc {
    const NAME: &'static str = NAME;
    const INPUTS: &'static [Input] = &[Input::Depth];
    type Params = CocParams;

    /// The anti-aliased-edge resolve reads a pixel's 3x3 neighbours.
    fn reach_px(_p: &CocParams) -> Option<f64> {
        Some(2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<CocParams> {
        let (f, camera) = (&input.facts, input.camera);
        let why = format!(
            "CoC from {:.2} px (nearest, {:.3} m) to {:.2} px (farthest, {:.3e} m) at f/{} focused at {} m",
            f.coc_range_px.0,
            f.depth_range_m.0,
            f.coc_range_px.1,
            f.depth_range_m.1,
            camera.lens.f_number,
            camera.lens.focus_distance_mm / 1000.0
        );
        let why = match f.coc_clamp_note(camera) {
            Some(note) => format!("{why}; {note}"),
            None => why,
        };
        if !f.dof_visible() {
            return Decision::skip(format!(
                "{why}: every CoC is at most {VISIBLE_COC_PX} px, depth of field is invisible"
            ));
        }
        if camera.bokeh == BokehMode::Diffraction {
            // The focus processor maps depth to its tables itself.
            return Decision::skip(format!("{why}; not needed by the focus processor"));
        }
        // The edge resolve is a second dispatch (coc_edges) over the pixels coc lists.
        let why = if camera.resolve_depth_edges {
            format!("{why}; anti-aliased depth edges resolved over the listed edge pixels ({})", coc_edges::NAME)
        } else {
            format!("{why}; depth kept as stored at edges (--keep-edge-depth)")
        };
        let base =
            CocParams::new(CocPush::for_frame(camera, f.pixel_pitch_mm, input.frame), camera.field_curvature.as_ref());
        let runs = input
            .dof_runs()
            .into_iter()
            .map(|(channel, offset_px)| CocParams {
                push: CocPush { coc_offset_px: offset_px, ..base.push },
                channel,
                ..base.clone()
            })
            .collect();
        Decision::run_each(runs, why)
    }

    /// A camera with a lens (not the focus processor, which maps depth itself) will likely
    /// find some pixel defocused.
    fn likely(camera: &Camera, _velocity: bool) -> bool {
        camera.bokeh != BokehMode::Diffraction
    }

    fn prepare_likely(&self, camera: &Camera) -> GpuResult<()> {
        let [resolve, field_curvature] = CocPush::specialization_for(camera);
        self.kernel.prepare(&[resolve, field_curvature])?;
        if resolve != 0 {
            self.edges.prepare(&[field_curvature])?;
        }
        Ok(())
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Coc { kernel: SpecializedKernel::new(gpu)?, edges: SpecializedKernel::new(gpu)? })
    }

    /// The CoC pipeline, and the edge resolve's where the run resolves edges.
    fn prepare(&self, p: &CocParams) -> GpuResult<()> {
        self.kernel.prepare(&p.push.specialization())?;
        if p.push.resolve_edges != 0 {
            self.edges.prepare(&p.push.edge_specialization())?;
        }
        Ok(())
    }

    /// Depth (R32F metres) -> a new CoC image (R32F signed px) for the run's channel: every
    /// pixel's from its own depth (`coc`), then, with the edge resolve, the listed edge pixels'
    /// resolved (`coc_edges`).
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &CocParams) -> GpuResult<()> {
        rec.begin_pass(NAME);
        let depth = images.depth()?.clone();
        let name = match p.channel {
            None => "coc (px)".to_string(),
            Some(c) => format!("coc (px, {c:?})"),
        };
        let coc = rec.create_image(&name, images.width, images.height, vk::Format::R32_SFLOAT)?;
        // field_curvature: uploaded with its own barrier (copy -> compute read).
        let table = rec.upload_buffer("field curvature", &p.table)?;
        let resolve = p.push.resolve_edges != 0;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let args = rec.create_args_buffer("coc edge resolve args (indirect dispatch, count)", COC_ARGS_WORDS)?;
        // Without the resolve the shader's list is specialised out: a word to bind.
        let capacity = if resolve { images.width as u64 * images.height as u64 } else { 1 };
        let edge_pixels = rec.create_buffer("coc edge pixels", capacity.max(1) * 4, storage)?;
        // depth: written by the upload copy, whose own barrier already made it visible to
        //   compute reads in layout GENERAL; nothing to wait for here.
        // coc: written from scratch; discard old contents.
        rec.image_barriers(&[overwrite(&coc)]);
        if resolve {
            // args: the count and the dispatch's x start at zero every run (coc.comp counts up
            //   with atomics): transfer write -> compute read/write. The edge list is this run's
            //   own buffer, written here first.
            rec.fill_buffer(&args, 0);
            rec.buffer_barriers(&[buffer_after_fill(&args)]);
        }
        let bindings = CocBindings {
            depth_m: &depth,
            coc_px: &coc,
            field_curvature: &table,
            args: &args,
            edge_pixels: &edge_pixels,
        };
        let constants = p.push.specialization();
        self.kernel.dispatch(rec, &constants, &bindings, &p.push, groups_for(images.width, images.height))?;
        if resolve {
            rec.begin_pass(coc_edges::NAME);
            // args (this dispatch's size, the count) and the edge list: written by coc.comp with
            //   atomics; read here as indirect arguments and by the shader.
            // coc: written by coc.comp; overwritten here at the listed pixels (write-after-write).
            // depth: the upload's own barrier made it visible to compute reads.
            // color: uploaded, or written by the motion blur when it runs before: wait for
            //   that pass's writes.
            let color = images.color().clone();
            rec.buffer_barriers(&[args_for_indirect(&args), buffer_after_compute_write(&edge_pixels)]);
            rec.image_barriers(&[write_after_write(&coc), after_compute_write(&color)]);
            let edges = CocEdgesBindings {
                depth_m: &depth,
                coc_px: &coc,
                field_curvature: &table,
                color_in: &color,
                args: &args,
                edge_pixels: &edge_pixels,
            };
            let constants = p.push.edge_specialization();
            self.edges.dispatch_indirect(rec, &constants, &edges, &p.push, &args, COC_ARGS_DISPATCH as u64 * 4)?;
        }
        rec.end_pass();
        images.set_coc(p.channel, coc);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::coc_push::coc_cpu;
    use super::*;
    use crate::optics::distortion::HeightTable;
    use crate::optics::ThinLens;

    #[test]
    fn field_curvature_blurs_the_focus_plane_off_axis_like_the_geometric_cone() {
        // A point at the focus distance, at image height h where the sharp surface lies delta
        // behind the film: the cone from the exit pupil (diameter v/(N' P)) converging at
        // v + delta meets the film in a disk of diameter D delta / (v + delta), in front of focus
        // (negative). On the axis (delta = 0) the CoC is the plain eq 5.3 value, 0.
        let lens = ThinLens::new(50.0, 2.0, 2000.0).unwrap();
        let pitch_mm = 0.01;
        let table = HeightTable { image_height_mm: vec![0.0, 10.0], values: vec![0.0, 0.2] };
        let p = CocPush::new(&lens, pitch_mm, 1000.0, 2001, 1, [1000.5, 0.5], Some(&table));
        let data = table_data(Some(&table));
        assert!(p.coc_px_at(2.0, 1000, 0, &data).abs() < 1e-3);
        // 500 px right of the centre: h = 5 mm, delta = 0.1 mm.
        let v = lens.image_distance_mm();
        let d = v / lens.effective_f_number();
        let expected_px = -d * 0.1 / (v + 0.1) / pitch_mm;
        let got = p.coc_px_at(2.0, 1500, 0, &data) as f64;
        assert!((got / expected_px - 1.0).abs() < 1e-4, "{got} vs {expected_px}");
        // Without a table the reciprocal form is used: exactly 0 in focus.
        let plain = CocPush::new(&lens, pitch_mm, 1000.0, 2001, 1, [1000.5, 0.5], None);
        assert_eq!(plain.coc_px_at(2.0, 1500, 0, &[0.0]), 0.0);
    }

    /// A 7x5 frame: sky (1e10 m, colour 0.1) with an in-focus object (2 m) in columns 0..=2.
    fn edge_frame(object: impl Fn(u32, u32) -> [f32; 3]) -> (Vec<f32>, Vec<f32>) {
        let (w, h) = (7u32, 5u32);
        let mut depth = Vec::new();
        let mut rgba = Vec::new();
        for y in 0..h {
            for x in 0..w {
                depth.push(if x <= 2 { 2.0 } else { 1.0e10 });
                let c = if x <= 2 { object(x, y) } else { [0.1; 3] };
                rgba.extend([c[0], c[1], c[2], 1.0]);
            }
        }
        (depth, rgba)
    }

    fn resolve_push(resolve_edges: i32) -> CocPush {
        let lens = ThinLens::new(50.0, 2.0, 2000.0).unwrap();
        CocPush { resolve_edges, ..CocPush::new(&lens, 0.01, 1000.0, 7, 5, [3.5, 2.5], None) }
    }

    #[test]
    fn an_anti_aliased_fringe_blurs_with_the_surface_whose_light_it_holds() {
        // A bright in-focus object (10) in front of the sky; the renderer's filter put 30% of its
        // light into column 3, whose one depth sample hit the sky. Without the resolve that
        // pixel spreads 3 of the object's 10 over the sky's disc; with it, it stays sharp.
        let (depth, mut rgba) = edge_frame(|_, _| [10.0; 3]);
        for y in 0..5 {
            let i = (y * 7 + 3) * 4;
            rgba[i..i + 3].copy_from_slice(&[0.3 * 10.0 + 0.7 * 0.1; 3]);
        }
        let sky_coc = resolve_push(0).coc_px(1.0e10);
        assert!(sky_coc > 40.0, "{sky_coc}");
        let stored = coc_resolved_cpu(&depth, &rgba, &resolve_push(0), &[0.0]);
        let resolved = coc_resolved_cpu(&depth, &rgba, &resolve_push(1), &[0.0]);
        for y in 0..5 {
            assert_eq!(stored[y * 7 + 3], sky_coc);
            assert!(resolved[y * 7 + 3].abs() < 1e-3, "row {y}: {}", resolved[y * 7 + 3]);
            // The sky pixel next to it holds only sky light and keeps the sky's CoC.
            assert_eq!(resolved[y * 7 + 4], sky_coc);
        }
        // A dim fringe (the object is as dark as the sky's 1/10): 30% of a dim object does not
        // outweigh 70% of the sky, so the pixel keeps the sky's depth.
        let (depth, mut rgba) = edge_frame(|_, _| [0.01; 3]);
        for y in 0..5 {
            let i = (y * 7 + 3) * 4;
            rgba[i..i + 3].copy_from_slice(&[0.3 * 0.01 + 0.7 * 0.1; 3]);
        }
        let resolved = coc_resolved_cpu(&depth, &rgba, &resolve_push(1), &[0.0]);
        assert!((0..5).all(|y| resolved[y * 7 + 3] == sky_coc));
    }

    #[test]
    fn a_fringe_resolves_even_when_the_two_cocs_differ_by_less_than_a_pixel() {
        // A bright object at 7.7 m in front of a wall at 8 m: CoCs 0.62 px apart (this lens,
        // 0.01 mm pixels). The fringe column holds 30% of the object's light and the wall's
        // depth; it takes the object's CoC. With a 1 px threshold it kept the wall's, so the
        // object's disc grew by the fringe's share of 0.62 px.
        let (depth, mut rgba) = edge_frame(|_, _| [10.0; 3]);
        let depth: Vec<f32> = depth.iter().map(|&d| if d == 2.0 { 7.7 } else { 8.0 }).collect();
        for y in 0..5 {
            let i = (y * 7 + 3) * 4;
            rgba[i..i + 3].copy_from_slice(&[0.3 * 10.0 + 0.7 * 0.1; 3]);
        }
        let push = resolve_push(1);
        let (object, wall) = (push.coc_px(7.7), push.coc_px(8.0));
        assert!((wall - object) > 0.5 && (wall - object) < 1.0, "{object} {wall}");
        let resolved = coc_resolved_cpu(&depth, &rgba, &push, &[0.0]);
        for y in 0..5 {
            assert!((resolved[y * 7 + 3] - object).abs() < 1e-3, "row {y}: {} vs {object}", resolved[y * 7 + 3]);
            assert_eq!(resolved[y * 7 + 4], wall);
        }
    }

    #[test]
    fn a_textured_surface_at_a_hard_edge_keeps_its_depth() {
        // Stripes on the object (rows alternately 0.8 and 0.15, the sky 0.1): the object's edge
        // pixels in a dark row look more like the sky than like the object's mean, but their
        // colour lies within the object's own range, so they keep the object's depth (CoC 0).
        let (depth, rgba) = edge_frame(|_, y| if y % 2 == 0 { [0.8, 0.35, 0.2] } else { [0.15, 0.08, 0.05] });
        let resolved = coc_resolved_cpu(&depth, &rgba, &resolve_push(1), &[0.0]);
        let stored = coc_resolved_cpu(&depth, &rgba, &resolve_push(0), &[0.0]);
        assert_eq!(resolved, stored);
        assert!((0..5).all(|y| resolved[y * 7 + 2] == 0.0));
    }

    /// The CoC pass's two twins chained as the pass records them: coc.comp's (every pixel's own
    /// CoC, the edge list), then coc_edges.comp's over that list. Returns the CoC and the list.
    fn two_dispatches(depth: &[f32], rgba: &[f32], push: &CocPush) -> (Vec<f32>, Vec<u32>) {
        let (w, h) = (push.size[0] as u32, push.size[1] as u32);
        let image = |channels, texels| HostData::Image(HostImage::new(w, h, channels, texels));
        let mut b = vec![
            image(1, depth.to_vec()),
            image(1, vec![f32::NAN; (w * h) as usize]),
            HostData::Buffer(vec![0.0f32.to_bits()]),
            HostData::Buffer(vec![0; COC_ARGS_WORDS as usize]),
            HostData::Buffer(vec![u32::MAX; (w * h) as usize]),
        ];
        CocShader::cpu(push, [1, 1, 1], &mut b);
        let args = b[3].words().to_vec();
        let mut edges =
            vec![b[0].clone(), b[1].clone(), b[2].clone(), image(4, rgba.to_vec()), b[3].clone(), b[4].clone()];
        CocEdgesShader::cpu(push, [args[COC_ARGS_DISPATCH as usize], 1, 1], &mut edges);
        let count = args[COC_ARGS_COUNT as usize] as usize;
        assert_eq!(args[COC_ARGS_DISPATCH as usize], (count as u32).div_ceil(EDGE_GROUP_SIZE));
        // The dispatch's y and z: 1 with the resolve; without it the buffer is left alone.
        let yz = u32::from(push.resolve_edges != 0);
        assert_eq!(args[1..3], [yz, yz]);
        (edges[1].image().texels.clone(), b[4].words()[..count].to_vec())
    }

    #[test]
    fn the_edge_resolve_runs_on_the_listed_edge_pixels_alone_and_gives_the_whole_pass() {
        // coc.comp lists exactly the pixels whose 3x3 depths span CoCs more than a quarter pixel
        // apart (here the two columns either side of the object's edge: 10 of 35), and the
        // resolve over that list gives the one-dispatch pass's CoC to the bit; without the
        // resolve nothing is listed and every CoC is the depth's own.
        let (depth, mut rgba) = edge_frame(|_, _| [10.0; 3]);
        for y in 0..5 {
            let i = (y * 7 + 3) * 4;
            rgba[i..i + 3].copy_from_slice(&[0.3 * 10.0 + 0.7 * 0.1; 3]);
        }
        let push = resolve_push(1);
        let (coc, listed) = two_dispatches(&depth, &rgba, &push);
        let expected: Vec<u32> = (0..5).flat_map(|y| [pack_pixel(2, y), pack_pixel(3, y)]).collect();
        assert_eq!(listed, expected);
        assert_eq!(coc, coc_resolved_cpu(&depth, &rgba, &push, &[0.0]));
        assert_ne!(coc, coc_cpu(&depth, &push, &[0.0]), "the fringe column resolves");
        let plain = resolve_push(0);
        let (coc, listed) = two_dispatches(&depth, &rgba, &plain);
        assert!(listed.is_empty());
        assert_eq!(coc, coc_cpu(&depth, &plain, &[0.0]));
        // The fringed sphere: a ring of edge pixels, and more than a workgroup's worth with the
        // checker's depth jittered in its right quarter; a per-channel offset.
        let (w, h) = (16u32, 16u32);
        let lens = ThinLens::new(50.0, 2.0, 2000.0).unwrap();
        let base = CocPush::new(&lens, 0.05, 1000.0, w, h, [8.0, 8.0], None);
        let push = CocPush { resolve_edges: 1, coc_offset_px: 0.7, ..base };
        let (depth, rgba, _) = fringed_sphere_over_checker(w, h, (8.3, 8.1));
        let jitter = |i: usize| if i % w as usize >= 12 { 1.0 + 0.05 * (i % 3) as f32 } else { 1.0 };
        let depth: Vec<f32> = depth.iter().enumerate().map(|(i, &d)| d * jitter(i)).collect();
        let (coc, listed) = two_dispatches(&depth, &rgba, &push);
        let depth_image = HostImage::new(w, h, 1, depth.clone());
        let at: Vec<u32> = (0..h as i32)
            .flat_map(|y| (0..w as i32).map(move |x| (x, y)))
            .filter(|&(x, y)| at_edge(&depth_image, &push, x, y))
            .map(|(x, y)| pack_pixel(x, y))
            .collect();
        assert!(listed.len() > EDGE_GROUP_SIZE as usize && listed.len() < (w * h) as usize, "{}", listed.len());
        assert_eq!(listed, at);
        assert_eq!(coc, coc_resolved_cpu(&depth, &rgba, &push, &[0.0]));
    }

    /// Scene A's HL15 in small: a sphere of radius 1.5 px (150, at 1.2 m) centred off the pixel
    /// grid over an in-focus checker of 2 px cells (0.2 and 0.8, 2 m). The colour is filtered
    /// over 2 px (each pixel averages 16x16 samples of the 2x2 px square around its centre),
    /// the depth is one sample at the pixel's centre: a ring of fringe pixels, several next to
    /// each other, holds the sphere's light with the checker's depth. Returns depth, colour and
    /// the sphere's light (one channel) in each pixel.
    fn fringed_sphere_over_checker(w: u32, h: u32, (cx, cy): (f32, f32)) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let (r, value) = (1.5f32, 150.0f32);
        let inside = |x: f32, y: f32| (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r;
        let checker = |x: u32, y: u32| if (x / 2 + y / 2).is_multiple_of(2) { 0.2 } else { 0.8 };
        let (mut depth, mut rgba, mut light) = (Vec::new(), Vec::new(), Vec::new());
        for y in 0..h {
            for x in 0..w {
                let n = 16;
                let hits = (0..n * n)
                    .filter(|&s| {
                        let sx = x as f32 - 0.5 + (s % n) as f32 * 2.0 / n as f32 + 1.0 / n as f32;
                        let sy = y as f32 - 0.5 + (s / n) as f32 * 2.0 / n as f32 + 1.0 / n as f32;
                        inside(sx, sy)
                    })
                    .count();
                let coverage = hits as f32 / (n * n) as f32;
                let v = coverage * value + (1.0 - coverage) * checker(x, y);
                rgba.extend([v, v, v, 1.0]);
                light.push(coverage * value);
                depth.push(if inside(x as f32 + 0.5, y as f32 + 0.5) { 1.2 } else { 2.0 });
            }
        }
        (depth, rgba, light)
    }

    #[test]
    fn a_bright_highlights_faint_fringe_over_a_sharp_texture_goes_with_the_highlight() {
        // Every pixel holding more of the sphere's light than twice the checker's brightest
        // takes the sphere's CoC (-8.8 px at f/2 on this lens and 0.05 mm pixels), however faint
        // against the sphere's 150, and at least 99.5% of the sphere's light blurs with it
        // (measured 99.8-100% at these four positions). The far layer's mean colour took in the
        // fringe's brighter pixels, so fainter ones next to them seemed to hold none of the
        // sphere's light and kept the checker's CoC 0: 92.4-100% of the light moved (scene A's
        // HL15: 8 fringe pixels of 1.7-11 over the star's 0.7, 2.6% of its light, kept sharp).
        // A fringe pixel fainter than that over a bright checker cell is not told from the
        // texture (0.2% of the light at the first position). The checker beyond the fringe
        // keeps its depth.
        let (w, h) = (16u32, 16u32);
        let lens = ThinLens::new(50.0, 2.0, 2000.0).unwrap();
        let push = CocPush { resolve_edges: 1, ..CocPush::new(&lens, 0.05, 1000.0, w, h, [8.0, 8.0], None) };
        let sphere_coc = push.coc_px(1.2);
        assert!((-9.0..-8.0).contains(&sphere_coc), "{sphere_coc}");
        for centre in [(8.3, 8.1), (7.8, 8.6), (8.5, 8.5), (8.0, 8.0)] {
            let (depth, rgba, light) = fringed_sphere_over_checker(w, h, centre);
            let coc = coc_resolved_cpu(&depth, &rgba, &push, &[0.0]);
            let total: f32 = light.iter().sum();
            let moves = |c: f32| (c - sphere_coc).abs() < 1e-3;
            let moved: f32 = light.iter().zip(&coc).filter(|(_, &c)| moves(c)).map(|(l, _)| l).sum();
            let fringe = (0..(w * h) as usize).filter(|&i| depth[i] == 2.0 && light[i] > 0.0).count();
            println!("{centre:?}: {fringe} fringe pixels, {:.4} of the sphere's light moves", moved / total);
            assert!(fringe >= 12, "{centre:?}: {fringe}");
            assert!(moved / total > 0.995, "{centre:?}: {:.4} of the sphere's light blurs with it", moved / total);
            for i in 0..(w * h) as usize {
                // More of the sphere's light than twice the checker's brightest: the sphere's.
                if light[i] > 2.0 * 0.8 {
                    assert!(moves(coc[i]), "{centre:?} pixel {i}: {} ({} of the sphere's light)", coc[i], light[i]);
                }
                if light[i] == 0.0 {
                    // Beyond the fringe: the checker, in focus.
                    assert!(coc[i].abs() < 1e-3, "{centre:?} pixel {i}: {}", coc[i]);
                }
            }
        }
    }
}
