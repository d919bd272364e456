//! Distortion and lateral colour from the lens's tables (Kyaw 2013 eq 6.8; the first aberration
//! pass of sec 7.3). Shader: glsl/lens/distortion.comp.

use crate::gpu::{Gpu, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::optics::distortion::DistortionTables;
use crate::passes::filter::{self, FilterBindings};
use crate::passes::scene::PlanInput;
use crate::passes::twin::{bilinear_in_band, finite_or_zero, floats};
use crate::passes::{height_table_lookup, Decision, FrameImages, Pass};

pub const NAME: &str = "distortion";

/// Push constants of glsl/lens/distortion.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DistortionPush {
    pub size: [i32; 2],
    pub centre_px: [f32; 2],
    pub pixel_pitch_mm: f32,
    pub entries: i32,
    /// The image is the band of the frame from this row (banded rendering; `centre_px` is in
    /// the whole frame's pixels); 0 for the whole frame.
    pub band_top_px: i32,
}

/// The table buffer: heights, then green, red-extra and blue-extra percent.
pub fn table_data(tables: &DistortionTables) -> Vec<f32> {
    let mut data: Vec<f32> = tables.green_percent.image_height_mm.iter().map(|&h| h as f32).collect();
    for t in [&tables.green_percent, &tables.red_extra_percent, &tables.blue_extra_percent] {
        data.extend(t.values.iter().map(|&v| v as f32));
    }
    data
}

/// CPU twin on an RGBA image (f64 mapping, bilinear with clamp to edge like the shader).
pub fn distortion_cpu(rgba: &[f32], params: &DistortionPush, tables: &DistortionTables) -> Vec<f32> {
    let (w, h) = (params.size[0], params.size[1]);
    let load = |x: i32, y: i32, c: usize| rgba[((y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) * 4) as usize + c];
    let mut out = rgba.to_vec();
    for y in 0..h {
        for x in 0..w {
            let d = [
                x as f64 + 0.5 - params.centre_px[0] as f64,
                (y + params.band_top_px) as f64 + 0.5 - params.centre_px[1] as f64,
            ];
            let real_mm = (d[0] * d[0] + d[1] * d[1]).sqrt() * params.pixel_pitch_mm as f64;
            for c in 0..3 {
                let r = tables.ideal_height_mm(c, real_mm);
                let scale = if real_mm > 0.0 { r / real_mm } else { 1.0 };
                let sx = params.centre_px[0] as f64 + d[0] * scale - 0.5;
                let sy = params.centre_px[1] as f64 + d[1] * scale - 0.5 - params.band_top_px as f64;
                let (ix, iy) = (sx.floor() as i32, sy.floor() as i32);
                let (fx, fy) = ((sx - ix as f64) as f32, (sy - iy as f64) as f32);
                let top = load(ix, iy, c) + (load(ix + 1, iy, c) - load(ix, iy, c)) * fx;
                let bottom = load(ix, iy + 1, c) + (load(ix + 1, iy + 1, c) - load(ix, iy + 1, c)) * fx;
                out[((y * w + x) * 4) as usize + c] = top + (bottom - top) * fy;
            }
        }
    }
    out
}

/// glsl/lens/distortion.comp.
pub struct DistortionShader;

impl Shader for DistortionShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FilterBindings<'a>;
    type Push = DistortionPush;
}

impl Twin for DistortionShader {
    /// The shader's own arithmetic: the f32 tables and the same fixed-point inverse of eq 6.8
    /// ([`distortion_cpu`] is the f64 reference with the exact inverse).
    fn cpu(push: &DistortionPush, _groups: [u32; 3], b: &mut [HostData]) {
        let table = floats(b[2].words());
        let n = push.entries as usize;
        let input = b[0].image().clone();
        let percent = |c: usize, r_mm: f32| {
            let g = height_table_lookup(&table, 1, n, r_mm);
            match c {
                0 => g + height_table_lookup(&table, 2, n, r_mm),
                2 => g + height_table_lookup(&table, 3, n, r_mm),
                _ => g,
            }
        };
        let out = b[1].image_mut();
        for y in 0..push.size[1] as u32 {
            for x in 0..push.size[0] as u32 {
                let top = push.band_top_px;
                let d = [x as f32 + 0.5 - push.centre_px[0], (y as i32 + top) as f32 + 0.5 - push.centre_px[1]];
                let real_mm = (d[0] * d[0] + d[1] * d[1]).sqrt() * push.pixel_pitch_mm;
                let mut texel: [f32; 4] = input.clamped(x as i32, y as i32).try_into().unwrap_or([0.0; 4]);
                for (c, value) in texel.iter_mut().enumerate().take(3) {
                    let mut r = real_mm;
                    for _ in 0..12 {
                        let next = real_mm / (1.0 + percent(c, r) / 100.0);
                        let done = (next - r).abs() <= 2.0e-7 * real_mm;
                        r = next;
                        if done {
                            break;
                        }
                    }
                    let scale = if real_mm > 0.0 { r / real_mm } else { 1.0 };
                    *value = bilinear_in_band(
                        &input,
                        push.centre_px[0] + d[0] * scale,
                        push.centre_px[1] + d[1] * scale,
                        top,
                    )[c];
                }
                out.texel_mut(x, y).copy_from_slice(&texel.map(finite_or_zero));
            }
        }
    }
}

/// The pass's constants and its tables (heights, then the green, red-extra and blue-extra
/// distortion in percent).
#[derive(Clone, Debug)]
pub struct DistortionParams {
    pub push: DistortionPush,
    pub table: Vec<f32>,
}

pub struct Distortion {
    kernel: Kernel<DistortionShader>,
}

impl Pass for Distortion {
    const NAME: &'static str = NAME;
    type Params = DistortionParams;

    /// The largest shift the tables give (green's percent plus the larger colour's) at the
    /// frame's farthest corner from the centre, and the bilinear lookup's pixel.
    fn reach_px(p: &DistortionParams) -> Option<f64> {
        let n = p.push.entries.max(0) as usize;
        let column =
            |k: usize| p.table.get(k * n..(k + 1) * n).unwrap_or(&[]).iter().fold(0.0f64, |m, v| m.max(v.abs() as f64));
        let percent = column(1) + column(2).max(column(3));
        let [w, h] = p.push.size.map(|s| s as f64);
        let [cx, cy] = p.push.centre_px.map(|c| c as f64);
        let corner_px = cx.max(w - cx).hypot(cy.max(h - cy));
        Some(percent / 100.0 * corner_px + 2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<DistortionParams> {
        match &input.camera.distortion {
            Some(tables) if !tables.is_zero() => {
                let frame = input.frame;
                let nm = frame.channel_wavelengths_nm();
                let tables = &tables.at_wavelengths(nm);
                let why = format!(
                    "the lens's tables: distortion up to {:.2}%, lateral colour up to {:.3}% (red) and {:.3}% (blue) \
                     at {:.0}/{:.0}/{:.0} nm",
                    tables.green_percent.max_abs(),
                    tables.red_extra_percent.max_abs(),
                    tables.blue_extra_percent.max_abs(),
                    nm[0],
                    nm[1],
                    nm[2]
                );
                let push = DistortionPush {
                    size: [frame.width as i32, frame.height as i32],
                    centre_px: [frame.centre_px[0] as f32, (frame.centre_px[1] + frame.band_top_px() as f64) as f32],
                    pixel_pitch_mm: input.facts.pixel_pitch_mm as f32,
                    entries: tables.green_percent.image_height_mm.len() as i32,
                    band_top_px: frame.band_top_px() as i32,
                };
                Decision::run(DistortionParams { push, table: table_data(tables) }, why)
            }
            Some(_) => Decision::skip("the lens's tables are all zero"),
            None => Decision::skip("the lens file has no distortion or lateral-colour tables"),
        }
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Distortion { kernel: Kernel::new(gpu)? })
    }

    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &DistortionParams) -> GpuResult<()> {
        filter::record(&self.kernel, rec, images, NAME, &p.table, &p.push)
    }
}
