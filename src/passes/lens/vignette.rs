//! Vignetting pass: the lens's relative-illumination table, or cos^4 of the real field angle
//! (Kyaw 2013 eq 4.14 / 4.9).
//! Shader: glsl/lens/vignette.comp (the falloff in glsl/include/vignette.glsl). Where the film pass
//! runs (it comes next in the pass order and also works pixel by pixel), the falloff is applied
//! in the film's dispatch instead of a dispatch of its own: one read and write of the frame
//! fewer (`VignetteParams::in_film`, `--explain` says so, the profile names the film's dispatch
//! `vignette+film`).

use crate::gpu::{Gpu, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::filter::{self, FilterBindings};
use crate::passes::scene::{PlanInput, VISIBLE_FALLOFF};
use crate::passes::{Decision, FrameImages, Pass};

pub const NAME: &str = "vignette";

/// Push constants of glsl/lens/vignette.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VignettePush {
    pub size: [i32; 2],
    pub centre_px: [f32; 2],
    pub pixel_pitch_mm: f32,
    pub image_distance_mm: f32,
    /// Entries of the relative-illumination table (0: cos^4).
    pub entries: i32,
}

/// The table buffer: heights in mm, then relative illumination; `[0]` for none.
pub fn table_data(table: Option<&crate::optics::distortion::HeightTable>) -> Vec<f32> {
    match table {
        None => vec![0.0],
        Some(t) => t.image_height_mm.iter().chain(&t.values).map(|&v| v as f32).collect(),
    }
}

impl VignettePush {
    /// The falloff at pixel (x, y): the table (`table_data` layout) or cos^4(theta) with
    /// tan(theta) = r / v; the shader's formula in f32.
    pub fn falloff(&self, x: u32, y: u32, table: &[f32]) -> f32 {
        let rx = (x as f32 + 0.5 - self.centre_px[0]) * self.pixel_pitch_mm;
        let ry = (y as f32 + 0.5 - self.centre_px[1]) * self.pixel_pitch_mm;
        let n = self.entries as usize;
        if n > 0 {
            return crate::passes::height_table_lookup(table, 1, n, (rx * rx + ry * ry).sqrt());
        }
        let t2 = (rx * rx + ry * ry) / (self.image_distance_mm * self.image_distance_mm);
        1.0 / ((1.0 + t2) * (1.0 + t2))
    }

    /// The strongest falloff in the frame (at the corner farthest from the centre).
    pub fn corner_falloff(&self, table: &[f32]) -> f32 {
        let (w, h) = (self.size[0].max(1) as u32 - 1, self.size[1].max(1) as u32 - 1);
        [(0, 0), (w, 0), (0, h), (w, h)].iter().map(|&(x, y)| self.falloff(x, y, table)).fold(1.0, f32::min)
    }
}

/// CPU twin on an RGBA image.
pub fn vignette_cpu(rgba: &[f32], params: &VignettePush, table: &[f32]) -> Vec<f32> {
    let w = params.size[0] as u32;
    rgba.chunks_exact(4)
        .enumerate()
        .flat_map(|(i, px)| {
            let f = params.falloff(i as u32 % w, i as u32 / w, table);
            [px[0] * f, px[1] * f, px[2] * f, px[3]]
        })
        .collect()
}

/// glsl/lens/vignette.comp.
pub struct VignetteShader;

impl Shader for VignetteShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FilterBindings<'a>;
    type Push = VignettePush;
}

impl Twin for VignetteShader {
    fn cpu(push: &VignettePush, _groups: [u32; 3], b: &mut [HostData]) {
        let table: Vec<f32> = b[2].words().iter().map(|&w| f32::from_bits(w)).collect();
        b[1].image_mut().texels = vignette_cpu(&b[0].image().texels, push, &table);
    }
}

/// The pass's constants and its relative-illumination table.
#[derive(Clone, Debug)]
pub struct VignetteParams {
    pub push: VignettePush,
    pub table: Vec<f32>,
    /// Applied in the film pass's dispatch (which then runs), not in one of its own.
    pub in_film: bool,
}

pub struct Vignette {
    kernel: Kernel<VignetteShader>,
}

impl Pass for Vignette {
    const NAME: &'static str = NAME;
    type Params = VignetteParams;

    fn plan(input: &PlanInput<'_>) -> Decision<VignetteParams> {
        let (camera, frame) = (input.camera, input.frame);
        let push = VignettePush {
            size: [frame.width as i32, frame.height as i32],
            centre_px: [frame.centre_px[0] as f32, frame.centre_px[1] as f32],
            pixel_pitch_mm: input.facts.pixel_pitch_mm as f32,
            image_distance_mm: camera.lens.image_distance_mm() as f32,
            entries: camera.relative_illumination.as_ref().map_or(0, |t| t.image_height_mm.len() as i32),
        };
        let table = table_data(camera.relative_illumination.as_ref());
        let falloff_name = if camera.relative_illumination.is_some() {
            "the lens's relative illumination"
        } else {
            "cos^4 natural vignetting"
        };
        let corner = push.corner_falloff(&table) as f64;
        if !camera.lens_vignettes {
            Decision::skip("the lens has no natural vignetting (the ideal lens, or natural_vignetting = false)")
        } else if !camera.vignetting {
            Decision::skip("turned off (--no-vignetting)")
        } else if 1.0 - corner <= VISIBLE_FALLOFF {
            Decision::skip(format!("{falloff_name} at the corners is {corner:.6}: invisible"))
        } else {
            let in_film = crate::passes::film::runs(camera);
            let why = format!(
                "{falloff_name}: {:.1}% of the centre's light at the farthest corner{}",
                corner * 100.0,
                if in_film {
                    "; applied in the film pass's dispatch (one read and write of the frame fewer)"
                } else {
                    ""
                }
            );
            Decision::run(VignetteParams { push, table, in_film }, why)
        }
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Vignette { kernel: Kernel::new(gpu)? })
    }

    /// A dispatch of its own, or nothing where the film pass applies the falloff.
    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &VignetteParams) -> GpuResult<()> {
        if p.in_film {
            return Ok(());
        }
        filter::record(&self.kernel, rec, images, NAME, &p.table, &p.push)
    }
}
