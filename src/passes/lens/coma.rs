//! Coma: each off-axis point spreads into a comet along its radius whose size follows the
//! lens's coma table against image height (third-order coma; Kyaw 2013 sec 7.6 left it out).
//! One dispatch of glsl/lens/coma.comp; `coma_cpu` is its CPU twin.

use crate::gpu::{Gpu, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::optics::distortion::HeightTable;
use crate::passes::filter::{self, FilterBindings};
use crate::passes::scene::PlanInput;
use crate::passes::twin::floats;
use crate::passes::{height_table_lookup, Decision, FrameImages, Pass};

pub const NAME: &str = "coma";

/// Push constants of glsl/lens/coma.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ComaPush {
    pub size: [i32; 2],
    pub centre_px: [f32; 2],
    pub pixel_pitch_mm: f32,
    pub entries: i32,
    /// Largest |tangential coma| of the table in px.
    pub max_coma_px: f32,
    /// The image is the band of the frame from this row (banded rendering; `centre_px` is in
    /// the whole frame's pixels); 0 for the whole frame.
    pub band_top_px: i32,
}

impl ComaPush {
    pub fn new(size: [u32; 2], centre_px: [f64; 2], pixel_pitch_mm: f64, coma_mm: &HeightTable) -> ComaPush {
        ComaPush {
            size: [size[0] as i32, size[1] as i32],
            centre_px: [centre_px[0] as f32, centre_px[1] as f32],
            pixel_pitch_mm: pixel_pitch_mm as f32,
            entries: coma_mm.image_height_mm.len() as i32,
            max_coma_px: (coma_mm.max_abs() / pixel_pitch_mm) as f32,
            band_top_px: 0,
        }
    }

    /// Sagittal coma C in px at a height in px (a third of the table's tangential coma).
    fn c_px(&self, table: &[f32], h_px: f32) -> f32 {
        height_table_lookup(table, 1, self.entries as usize, h_px * self.pixel_pitch_mm) / (3.0 * self.pixel_pitch_mm)
    }
}

/// The table buffer: heights (mm), tangential coma (mm).
pub fn table_data(coma_mm: &HeightTable) -> Vec<f32> {
    coma_mm.image_height_mm.iter().chain(&coma_mm.values).map(|&v| v as f32).collect()
}

/// C near a pixel, linear in the height (see glsl/lens/coma.comp).
struct Local {
    c_at_p: f32,
    slope: f32,
    h_at_p: f32,
}

impl Local {
    fn c(&self, h: f32) -> f32 {
        self.c_at_p + self.slope * (h - self.h_at_p)
    }

    /// The pupil-sample displacement of third-order coma for a source at q.
    fn displacement(&self, q: [f32; 2], a: f32, b: f32) -> [f32; 2] {
        let h = (q[0] * q[0] + q[1] * q[1]).sqrt();
        if h < 1e-6 {
            return [0.0, 0.0];
        }
        let (rx, ry) = (q[0] / h, q[1] / h);
        let c = self.c(h);
        [c * (a * rx - b * ry), c * (a * ry + b * rx)]
    }
}

/// CPU twin of glsl/lens/coma.comp (same sampling, f32).
pub fn coma_cpu(rgba: &[f32], params: &ComaPush, table: &[f32]) -> Vec<f32> {
    let (w, h) = (params.size[0], params.size[1]);
    let load = |x: i32, y: i32| -> [f32; 4] {
        let i = (y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize * 4;
        [rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]]
    };
    let bilinear = |x: f32, y: f32| -> [f32; 4] {
        let (tx, ty) = (x - 0.5, y - 0.5);
        let (ix, iy) = (tx.floor() as i32, ty.floor() as i32);
        let (fx, fy) = (tx - ix as f32, ty - iy as f32);
        let iy = iy - params.band_top_px;
        let (a, b, c, d) = (load(ix, iy), load(ix + 1, iy), load(ix, iy + 1), load(ix + 1, iy + 1));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    };
    let mut out = vec![0.0f32; rgba.len()];
    for py in 0..h {
        for px in 0..w {
            let x =
                [px as f32 + 0.5 - params.centre_px[0], (py + params.band_top_px) as f32 + 0.5 - params.centre_px[1]];
            let o = (py * w + px) as usize * 4;
            let h_p = (x[0] * x[0] + x[1] * x[1]).sqrt();
            let c_max = params
                .c_px(table, h_p)
                .abs()
                .max(params.c_px(table, (h_p - params.max_coma_px).max(0.0)).abs())
                .max(params.c_px(table, h_p + params.max_coma_px).abs());
            if c_max < 0.02 {
                out[o..o + 4].copy_from_slice(&load(px, py));
                continue;
            }
            let lo = (h_p - 0.5).max(0.0);
            let local = Local {
                c_at_p: params.c_px(table, h_p),
                slope: (params.c_px(table, h_p + 0.5) - params.c_px(table, lo)) / (h_p + 0.5 - lo),
                h_at_p: h_p,
            };
            let n_rho = ((3.0 * c_max).ceil() as i32).clamp(2, 48);
            let n_theta = ((2.0 * std::f32::consts::PI * c_max).ceil() as i32).clamp(4, 96);
            let mut sum = [0.0f32; 4];
            for i in 0..n_rho {
                let rho2 = (i as f32 + 0.5) / n_rho as f32;
                for j in 0..n_theta {
                    let t2 = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / n_theta as f32;
                    let (a, b) = (rho2 * (2.0 + t2.cos()), rho2 * t2.sin());
                    let d = local.displacement(x, a, b);
                    let q = [x[0] - d[0], x[1] - d[1]];
                    let d = local.displacement(q, a, b);
                    let q = [x[0] - d[0], x[1] - d[1]];
                    let hq = (q[0] * q[0] + q[1] * q[1]).sqrt().max(1e-3);
                    let c = local.c(hq);
                    let det = (1.0 + local.slope * a) * (1.0 + c / hq * a) + local.slope * (c / hq) * b * b;
                    let v = bilinear(q[0] + params.centre_px[0], q[1] + params.centre_px[1]);
                    for k in 0..4 {
                        sum[k] += v[k] / det.max(1e-3);
                    }
                }
            }
            let n = (n_rho * n_theta) as f32;
            for k in 0..4 {
                let v = sum[k] / n;
                out[o + k] = if v.is_finite() { v } else { 0.0 };
            }
        }
    }
    out
}

/// glsl/lens/coma.comp.
pub struct ComaShader;

impl Shader for ComaShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FilterBindings<'a>;
    type Push = ComaPush;
}

impl Twin for ComaShader {
    fn cpu(push: &ComaPush, _groups: [u32; 3], b: &mut [HostData]) {
        let table = floats(b[2].words());
        b[1].image_mut().texels = coma_cpu(&b[0].image().texels, push, &table);
    }
}

/// The pass's constants and its table (heights, tangential coma in mm).
#[derive(Clone, Debug)]
pub struct ComaParams {
    pub push: ComaPush,
    pub table: Vec<f32>,
}

pub struct Coma {
    kernel: Kernel<ComaShader>,
}

impl Pass for Coma {
    const NAME: &'static str = NAME;
    type Params = ComaParams;

    /// The comet: three times the sagittal coma, the tangential coma's length, and a pixel.
    fn reach_px(p: &ComaParams) -> Option<f64> {
        Some(3.0 * p.push.max_coma_px.abs() as f64 + 2.0)
    }

    fn plan(input: &PlanInput<'_>) -> Decision<ComaParams> {
        let (frame, pitch_mm) = (input.frame, input.facts.pixel_pitch_mm);
        let Some(t) = &input.camera.coma else {
            return Decision::skip("the lens file has no coma table");
        };
        let longest_px = t.max_abs_within(frame.farthest_corner_px() * pitch_mm) / pitch_mm;
        // A comet shorter than a pixel is invisible (its light moves by a third of that).
        if longest_px < 1.0 {
            return Decision::skip(format!(
                "the lens's comets are at most {longest_px:.3} px long in the frame (< 1 px): invisible"
            ));
        }
        let why = format!(
            "the lens's coma table: comets up to {longest_px:.1} px long in the frame at f/{}",
            input.camera.lens.f_number
        );
        let centre_px = [frame.centre_px[0], frame.centre_px[1] + frame.band_top_px() as f64];
        let push = ComaPush {
            band_top_px: frame.band_top_px() as i32,
            ..ComaPush::new([frame.width, frame.height], centre_px, pitch_mm, t)
        };
        Decision::run(ComaParams { push, table: table_data(t) }, why)
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Coma { kernel: Kernel::new(gpu)? })
    }

    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &ComaParams) -> GpuResult<()> {
        filter::record(&self.kernel, rec, images, NAME, &p.table, &p.push)
    }
}
