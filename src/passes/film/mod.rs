//! Exposure and film-response pass. Shader: glsl/film/film.comp.
//! The exposure gain (sensor value per scene unit, Kyaw 2013 eq 4.1/4.9 with ISO) is applied
//! first; then either the characteristic curve (toe, straight part, shoulder on log exposure)
//! or nothing more, keeping scene-referred linear values for compositing.
//! Where the vignette pass runs, its falloff is applied here first, in the same dispatch
//! (src/passes/lens/vignette.rs says why; `FilmPush::with_vignette`).

use crate::gpu::{Gpu, GpuResult, HostData, Recorder, Shader, SpecializedKernel, Twin};
use crate::model::camera::{Camera, FilmMode};
use crate::optics::film::FilmCurve;
use crate::passes::filter::{self, FilterBindings};
use crate::passes::lens::vignette::{Vignette, VignettePush};
use crate::passes::scene::PlanInput;
use crate::passes::{Decision, FrameImages, Pass};

pub const NAME: &str = "film";
/// The profile's name of the film's dispatch when it also applies the vignette's falloff.
pub const WITH_VIGNETTE_NAME: &str = "vignette+film";

/// The film the output gets: the camera's, or linear when the curve goes only into the preview.
fn output_film(camera: &Camera) -> &FilmMode {
    if camera.film_on_output {
        &camera.film
    } else {
        &FilmMode::Linear
    }
}

/// Whether the pass runs for `camera`: a curve, an exposure gain other than 1 or grain.
pub fn runs(camera: &Camera) -> bool {
    curve_and_table(output_film(camera)).0.is_some() || camera.exposure_gain() != 1.0 || camera.noise_sigma() != 0.0
}

/// A non-finite value as 0 (the shader's finite_or_zero before the vignette's falloff).
fn finite(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// Push constants of glsl/film/film.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FilmPush {
    pub size: [i32; 2],
    pub exposure_gain: f32,
    pub use_curve: i32,
    pub log10_mid_in: f32,
    pub log10_mid_out: f32,
    pub contrast: f32,
    pub toe_softness_decades: f32,
    pub shoulder_softness_decades: f32,
    pub log10_black_out: f32,
    pub log10_white_out: f32,
    /// Sensor noise: standard deviation at sensor value 1 (scaled by sqrt(value)); 0: none.
    pub noise_sigma: f32,
    pub seed: u32,
    /// Entries of the characteristic-curve table (use_curve 2); 0: none.
    pub table_entries: i32,
    /// 1: the vignette's falloff applied first (its constants below), 0: none.
    pub vignette: i32,
    pub vignette_centre_px: [f32; 2],
    pub vignette_pixel_pitch_mm: f32,
    pub vignette_image_distance_mm: f32,
    /// Entries of the vignette's table (0: cos^4).
    pub vignette_entries: i32,
    /// The vignette's table's first word in the film's table buffer.
    pub vignette_base: i32,
    /// A band's first row in the whole frame (banded rendering): the grain's rows are the
    /// whole frame's.
    pub band_top_px: i32,
}

impl FilmPush {
    /// The shader's specialization constants for these constants: `RESPONSE` (`use_curve`),
    /// `NOISE` (whether `noise_sigma` > 0) and `VIGNETTE`, so each run's pipeline holds only
    /// its own path.
    pub fn specialization(&self) -> [u32; 3] {
        [self.use_curve as u32, u32::from(self.noise_sigma > 0.0), u32::from(self.vignette != 0)]
    }

    /// The vignette's constants, as the vignette pass would run them, for its table at word
    /// `base` of this pass's table.
    pub fn with_vignette(self, v: &VignettePush, base: usize) -> FilmPush {
        FilmPush {
            vignette: 1,
            vignette_centre_px: v.centre_px,
            vignette_pixel_pitch_mm: v.pixel_pitch_mm,
            vignette_image_distance_mm: v.image_distance_mm,
            vignette_entries: v.entries,
            vignette_base: base as i32,
            ..self
        }
    }

    /// The vignette's constants back (meaningful when `vignette` is 1).
    fn vignette_push(&self) -> VignettePush {
        VignettePush {
            size: self.size,
            centre_px: self.vignette_centre_px,
            pixel_pitch_mm: self.vignette_pixel_pitch_mm,
            image_distance_mm: self.vignette_image_distance_mm,
            entries: self.vignette_entries,
        }
    }
}

/// The table buffer: log10 sensor values, then log10 outputs ([0] when there is no table).
pub fn table_data(table: Option<&crate::optics::film::FilmTable>) -> Vec<f32> {
    match table {
        None => vec![0.0],
        Some(t) => t.log10_sensor_value.iter().chain(&t.log10_output).map(|&v| v as f32).collect(),
    }
}

/// The shader's integer hash (glsl/film/film.comp).
fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The shader's standard normal value for (pixel, channel, seed).
pub fn gaussian(x: u32, y: u32, c: u32, seed: u32) -> f32 {
    let h1 = hash(x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663) ^ c.wrapping_mul(83_492_791) ^ seed);
    let h2 = hash(h1 ^ 0x9e37_79b9);
    let u1 = ((h1 >> 8) as f32 + 0.5) / 16_777_216.0;
    let u2 = (h2 >> 8) as f32 / 16_777_216.0;
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f32::consts::PI * u2).cos()
}

impl FilmPush {
    pub fn new(width: u32, height: u32, exposure_gain: f64, curve: Option<&FilmCurve>) -> FilmPush {
        let c = curve.copied().unwrap_or_else(FilmCurve::default_filmic);
        FilmPush {
            size: [width as i32, height as i32],
            exposure_gain: exposure_gain as f32,
            use_curve: curve.is_some() as i32,
            log10_mid_in: c.middle_grey_in.log10() as f32,
            log10_mid_out: c.middle_grey_out.log10() as f32,
            contrast: c.contrast as f32,
            toe_softness_decades: c.toe_softness_decades.max(1e-6) as f32,
            shoulder_softness_decades: c.shoulder_softness_decades.max(1e-6) as f32,
            log10_black_out: c.black_out.log10() as f32,
            log10_white_out: c.white_out.log10() as f32,
            noise_sigma: 0.0,
            seed: 0,
            table_entries: 0,
            vignette: 0,
            vignette_centre_px: [0.0; 2],
            vignette_pixel_pitch_mm: 0.0,
            vignette_image_distance_mm: 0.0,
            vignette_entries: 0,
            vignette_base: 0,
            band_top_px: 0,
        }
    }

    /// The same, through a tabled characteristic curve.
    pub fn with_table(self, table: &crate::optics::film::FilmTable) -> FilmPush {
        FilmPush { use_curve: 2, table_entries: table.log10_sensor_value.len() as i32, ..self }
    }

    /// CPU twin of the shader for channel `c` of pixel (x, y), in f32 like the shader.
    pub fn apply_at(&self, value: f32, x: u32, y: u32, c: u32, table: &[f32]) -> f32 {
        let v = if value.is_finite() { value } else { 0.0 };
        let mut h = v * self.exposure_gain;
        if self.noise_sigma > 0.0 {
            h += self.noise_sigma
                * h.max(0.0).sqrt()
                * gaussian(x, y.wrapping_add(self.band_top_px as u32), c, self.seed);
        }
        self.response(h, table)
    }

    /// CPU twin without noise.
    pub fn apply(&self, value: f32, table: &[f32]) -> f32 {
        let v = if value.is_finite() { value } else { 0.0 };
        self.response(v * self.exposure_gain, table)
    }

    fn response(&self, h: f32, table: &[f32]) -> f32 {
        if self.use_curve == 0 {
            return h;
        }
        if self.use_curve == 2 {
            let n = self.table_entries as usize;
            let x = h.clamp(1.0e-30, 1.0e30).log10();
            let y = if x <= table[0] {
                table[n]
            } else {
                (1..n)
                    .find(|&i| x <= table[i])
                    .map(|i| {
                        let t = (x - table[i - 1]) / (table[i] - table[i - 1]);
                        table[n + i - 1] + (table[n + i] - table[n + i - 1]) * t
                    })
                    .unwrap_or(table[2 * n - 1])
            };
            return 10f32.powf(y);
        }
        let smooth_max = |a: f32, b: f32, k: f32| {
            a.max(b) + k * (1.0 + (-(a - b).abs() / k * std::f32::consts::LN_10).exp()).ln() / std::f32::consts::LN_10
        };
        let (lb, lw) = (self.log10_black_out, self.log10_white_out);
        let x = h.clamp(1.0e-30, 1.0e30).log10();
        let mut y = self.log10_mid_out + self.contrast * (x - self.log10_mid_in);
        y = -smooth_max(-y, -lw, self.shoulder_softness_decades);
        y = smooth_max(y, lb, self.toe_softness_decades);
        let ceiling = smooth_max(lw, lb, self.toe_softness_decades);
        y = lb + (y - lb) * ((lw - lb) / (ceiling - lb));
        10f32.powf(y.clamp(lb, lw))
    }
}

/// CPU twin on an RGBA image.
pub fn film_cpu(rgba: &[f32], params: &FilmPush, table: &[f32]) -> Vec<f32> {
    let w = params.size[0].max(1) as u32;
    rgba.chunks_exact(4)
        .enumerate()
        .flat_map(|(i, px)| {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let a = if px[3].is_finite() { px[3] } else { 0.0 };
            // The vignette's falloff on the finite value, as the shader applies it.
            let falloff = match params.vignette {
                0 => 1.0,
                _ => params.vignette_push().falloff(x, y, &table[params.vignette_base as usize..]),
            };
            let vignetted = |v: f32| if params.vignette == 0 { v } else { finite(v) * falloff };
            [
                params.apply_at(vignetted(px[0]), x, y, 0, table),
                params.apply_at(vignetted(px[1]), x, y, 1, table),
                params.apply_at(vignetted(px[2]), x, y, 2, table),
                a,
            ]
        })
        .collect()
}

/// glsl/film/film.comp.
pub struct FilmShader;

impl Shader for FilmShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = FilterBindings<'a>;
    type Push = FilmPush;
}

impl Twin for FilmShader {
    fn cpu(push: &FilmPush, _groups: [u32; 3], b: &mut [HostData]) {
        let table: Vec<f32> = b[2].words().iter().map(|&w| f32::from_bits(w)).collect();
        b[1].image_mut().texels = film_cpu(&b[0].image().texels, push, &table);
    }
}

/// A film's parametric curve (the table's stand-in when it has a table) and table; none for
/// the linear film.
fn curve_and_table(film: &FilmMode) -> (Option<FilmCurve>, Option<std::sync::Arc<crate::optics::film::FilmTable>>) {
    match film {
        FilmMode::Curve(c) => (Some(*c), None),
        FilmMode::Table(t) => (Some(FilmCurve::default_filmic()), Some(t.clone())),
        FilmMode::Linear => (None, None),
    }
}

/// The shader's constants (no noise) and table for `film` after an exposure gain.
fn response_push(width: u32, height: u32, gain: f64, film: &FilmMode) -> (FilmPush, Vec<f32>) {
    let (curve, film_table) = curve_and_table(film);
    let mut push = FilmPush::new(width, height, gain, curve.as_ref());
    if let Some(t) = &film_table {
        push = push.with_table(t);
    }
    (push, table_data(film_table.as_deref()))
}

/// `film`'s characteristic curve applied to sensor values (RGBA, `width` px per row), as the
/// film pass applies it after the exposure: the preview of a scene-referred output. The same
/// f32 arithmetic as the shader, so a preview of the linear output equals the output rendered
/// through the curve (up to the GPU's rounding of log and pow).
pub fn film_response_cpu(rgba: &[f32], width: u32, film: &FilmMode) -> Vec<f32> {
    let height = (rgba.len() / 4).checked_div(width as usize).unwrap_or(0) as u32;
    let (push, table) = response_push(width, height, 1.0, film);
    film_cpu(rgba, &push, &table)
}

/// The pass's constants and its characteristic-curve table.
#[derive(Clone, Debug)]
pub struct FilmParams {
    pub push: FilmPush,
    pub table: Vec<f32>,
}

pub struct Film {
    kernel: SpecializedKernel<FilmShader>,
}

impl Pass for Film {
    const NAME: &'static str = NAME;
    type Params = FilmParams;

    fn plan(input: &PlanInput<'_>) -> Decision<FilmParams> {
        let camera = input.camera;
        let gain = camera.exposure_gain();
        let film = output_film(camera);
        let noise_sigma = camera.noise_sigma();
        if !runs(camera) {
            return Decision::skip("linear film with exposure off and no grain: the sensor value is the scene value");
        }
        let exposure = if camera.exposure {
            format!(
                "exposure gain {gain:.4} (ISO {}, {} s, f/{}, N' {:.2})",
                camera.iso,
                camera.shutter_s,
                camera.lens.f_number,
                camera.lens.effective_f_number()
            )
        } else {
            "exposure off".into()
        };
        let curve_name = match &camera.film {
            FilmMode::Table(t) => {
                format!("characteristic curve from a table of {} entries", t.log10_sensor_value.len())
            }
            FilmMode::Curve(_) => "characteristic curve".into(),
            FilmMode::Linear => "linear (scene-referred)".into(),
        };
        let response = match (camera.film_on_output, &camera.film) {
            (true, _) | (_, FilmMode::Linear) => curve_name,
            // Where the curve goes instead (the PNG preview, or nowhere when an OpenColorIO view
            // makes the preview) is the command line's to say: its `film curve:` line.
            (false, _) => format!("linear (scene-referred; the {curve_name} is not applied to the output)"),
        };
        let grain = if noise_sigma > 0.0 {
            format!(", sensor noise sigma {noise_sigma:.4} at ISO {} (seed {})", camera.iso, camera.seed)
        } else {
            String::new()
        };
        let (w, h) = input.size();
        let (mut push, mut table) = response_push(w, h, gain, film);
        push.noise_sigma = noise_sigma as f32;
        push.seed = camera.seed;
        push.band_top_px = input.frame.band_top_px() as i32;
        // The vignette's falloff, where that pass runs, in this dispatch (see src/passes/lens/vignette.rs).
        let mut also = String::new();
        if let Some(v) = Vignette::plan(input).runs.into_iter().find(|v| v.in_film) {
            push = push.with_vignette(&v.push, table.len());
            table.extend(&v.table);
            also = "; the vignette's falloff first, in the same dispatch".into();
        }
        Decision::run(FilmParams { push, table }, format!("{exposure}, {response}{grain}{also}"))
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(Film { kernel: SpecializedKernel::new(gpu)? })
    }

    fn prepare(&self, p: &FilmParams) -> GpuResult<()> {
        self.kernel.prepare(&p.push.specialization())
    }

    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, p: &FilmParams) -> GpuResult<()> {
        let constants = p.push.specialization();
        let label = if p.push.vignette != 0 { WITH_VIGNETTE_NAME } else { NAME };
        filter::record(&(&self.kernel, &constants[..]), rec, images, label, &p.table, &p.push)
    }
}
