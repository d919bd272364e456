//! `realcam flare`: each ghost model of the lens flare against the traced reference, for a point
//! light at a range of angles off the axis: where each ghost lands (its centroid), how much of
//! the light it carries and how large it is, per ghost and colour channel, beside the time each
//! model takes. The reference traces real rays (src/optics/flare/traced.rs: f64, both
//! reflections, Fresnel with the coatings at every ray's own angle, clipped at every
//! semi-diameter and by the aperture); the matrix ghosts (src/optics/flare/ghosts.rs) are what
//! the flare pass draws, and are also timed on the GPU; Walch's fitted primitives (a lens file's
//! `[[fitted_ghost]]`, ch. 6-8) are drawn as glsl/tools/bezier_ghosts.comp draws them, and timed there.

use crate::gpu::shaders::bezier_ghost::BEZIER_BOUNDS;
use crate::gpu::{Gpu, GpuResult, Kernel, Profile};
use crate::io::lens_file::FittedGhostSpec;
use crate::model::camera::Camera;
use crate::model::flare::FlareLight;
use crate::model::frame::Frame;
use crate::optics::flare::ghosts::{GhostCatalogue, GhostPath, GhostShape};
use crate::optics::flare::traced::{chief_ray, display_px, optical_slope, TracedImage};
use crate::optics::flare::{channel_nm, FlareLens};
use crate::passes::flare::ghost_shape::primitive_light;
use crate::passes::flare::{Flare, FlareModel, FlareParams, MIN_GHOST_RADIUS_PX};
use crate::passes::PlanInput;
use crate::pipeline::planner::plan;
use crate::pipeline::render::Renderer;
use crate::tools::bench::median;
use crate::tools::bench_flare::FLARE_PASSES;
use crate::tools::bezier_ghosts::{self, BezierGhostsShader, DrawnGhost};
use std::time::Instant;

/// What a model says of one ghost in one channel for one light. Positions in image pixels
/// (x right, y down), energy per unit of the light's own image's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GhostEstimate {
    /// Where the ghost's centre is: the real chief ray's landing place (through the stop's
    /// centre) for the reference, the matrix model's centre; None where it cannot be found.
    pub centre_px: Option<[f64; 2]>,
    pub centroid_px: [f64; 2],
    pub energy_ratio: f64,
    pub rms_radius_px: f64,
}

/// A way to compute the ghosts of a lens.
pub trait GhostModel {
    fn name(&self) -> &str;
    /// The ghost of `path` in channel `c` for a light of display slope `u` (the light's image at
    /// the centre + G0 u / pitch); None where no light of it reaches the sensor.
    fn ghost(&self, path: GhostPath, u: [f64; 2], c: usize) -> Option<GhostEstimate>;
    /// Whether the model has the ghost of `path` in channel `c` for a light of display slope
    /// `u` at all (a fitted model may carry only some ghosts, over a range of angles); pairs it
    /// does not cover are not compared.
    fn covers(&self, _path: GhostPath, _u: [f64; 2], _c: usize) -> bool {
        true
    }
    /// Adds the light of the ghost of `path` in channel `c` (per unit of the light's own image,
    /// per frame pixel) to `cells`, as the model draws it.
    fn draw(&self, path: GhostPath, u: [f64; 2], c: usize, cells: &mut FrameCells);
}

/// A frame in square cells of `cell_px` frame pixels, row by row: light per frame pixel, each
/// cell sampled at its centre (a model) or the mean over it (the traced rays binned).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameCells {
    pub cell_px: f64,
    pub width: usize,
    pub height: usize,
    pub values: Vec<f64>,
}

/// The report's image error: at most this many cells across the frame (80 px at 1280 px). The
/// Tessar's ghosts are washes 600-3600 px across (RMS radii at 2 degrees), and the traced rays'
/// binning noise grows as the cells shrink: 64 rays across the lens put about one ray of a
/// ghost in a cell of 40 px.
pub const IMAGE_CELLS_ACROSS: u32 = 16;

impl FrameCells {
    /// A black frame of `size_px` in cells of whole pixels, at most `cells_across` across.
    pub fn new(size_px: [u32; 2], cells_across: u32) -> FrameCells {
        let cell_px = (size_px[0].max(size_px[1]) as f64 / cells_across.max(1) as f64).ceil().max(1.0);
        let width = (size_px[0] as f64 / cell_px).ceil() as usize;
        let height = (size_px[1] as f64 / cell_px).ceil() as usize;
        FrameCells { cell_px, width, height, values: vec![0.0; width * height] }
    }

    /// Adds `light(centre)` to every cell whose centre lies within the box `lo`..`hi` (frame px).
    fn add_over(&mut self, lo: [f64; 2], hi: [f64; 2], light: impl Fn([f64; 2]) -> f64) {
        let cell = self.cell_px;
        let range = |a: f64, b: f64, n: usize| {
            let first = (a / cell - 0.5).ceil().clamp(0.0, n as f64) as usize;
            let end = ((b / cell - 0.5).floor() + 1.0).clamp(0.0, n as f64) as usize;
            first..end.max(first)
        };
        for j in range(lo[1], hi[1], self.height) {
            for i in range(lo[0], hi[0], self.width) {
                let q = [(i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell];
                self.values[j * self.width + i] += light(q);
            }
        }
    }

    /// Adds `energy` (per unit of the light's own image) landing at frame point `p` to its cell.
    fn add_at(&mut self, p: [f64; 2], energy: f64) {
        let (i, j) = ((p[0] / self.cell_px).floor(), (p[1] / self.cell_px).floor());
        if i >= 0.0 && j >= 0.0 && (i as usize) < self.width && (j as usize) < self.height && energy.is_finite() {
            self.values[j as usize * self.width + i as usize] += energy / (self.cell_px * self.cell_px);
        }
    }
}

/// The RMS difference of a model's frames from the reference's over the reference's RMS (the
/// relative L2 error: 0 for the same light, 1 for a black frame); None where the reference is
/// black.
pub fn relative_image_error(model: &[FrameCells], reference: &[FrameCells]) -> Option<f64> {
    let (mut diff, mut norm) = (0.0, 0.0);
    for (m, r) in model.iter().zip(reference) {
        for (a, b) in m.values.iter().zip(&r.values) {
            diff += (a - b) * (a - b);
            norm += b * b;
        }
    }
    (norm > 0.0 && diff.is_finite()).then(|| (diff / norm).sqrt())
}

/// The frame the models draw on: its pixel pitch and optical centre.
#[derive(Clone, Copy, Debug)]
pub struct Sensor {
    pub pixel_pitch_mm: f64,
    pub centre_px: [f64; 2],
}

/// The reference: real rays, `rays_across` across the front lens per wavelength.
pub struct Traced<'a> {
    pub lens: &'a FlareLens,
    /// For each ghost, which crossing of the stop is its aperture.
    pub catalogue: &'a GhostCatalogue,
    pub sensor: Sensor,
    pub rays_across: usize,
}

impl Traced<'_> {
    fn image(&self, path: Option<GhostPath>, u: [f64; 2], c: usize) -> TracedImage {
        TracedImage::trace(self.lens, path, optical_slope(u), c, self.rays_across)
    }

    fn to_image(&self, mm: [f64; 2]) -> [f64; 2] {
        let d = display_px(mm, self.sensor.pixel_pitch_mm);
        [self.sensor.centre_px[0] + d[0], self.sensor.centre_px[1] + d[1]]
    }

    /// The ghost's rays binned as [`GhostModel::draw`] does, and its alternate rays (even, odd)
    /// binned apart with twice their weight: two images of the same light whose difference is
    /// the binning noise.
    fn draw_halves(&self, path: GhostPath, u: [f64; 2], c: usize, cells: &mut [FrameCells; 3]) {
        let direct = self.image(None, u, c).energy();
        if direct.is_nan() || direct <= 0.0 {
            return;
        }
        for (k, h) in self.image(Some(path), u, c).hits.iter().enumerate() {
            let p = self.to_image(h.position);
            cells[0].add_at(p, h.weight / direct);
            cells[1 + k % 2].add_at(p, 2.0 * h.weight / direct);
        }
    }
}

impl GhostModel for Traced<'_> {
    fn name(&self) -> &str {
        "traced reference"
    }

    fn ghost(&self, path: GhostPath, u: [f64; 2], c: usize) -> Option<GhostEstimate> {
        let direct = self.image(None, u, c).energy();
        let ghost = self.image(Some(path), u, c);
        let centroid = ghost.centroid()?;
        let to_image = |mm: [f64; 2]| self.to_image(mm);
        let crossing = self.catalogue.ghosts.iter().find(|g| g.path == path)?.channels[c].aperture_crossing;
        let events = path.events(self.lens.prescription.surfaces.len());
        let chief = chief_ray(self.lens, &events, crossing, optical_slope(u), channel_nm(c));
        Some(GhostEstimate {
            centre_px: chief.map(to_image),
            centroid_px: to_image(centroid),
            energy_ratio: ghost.energy() / direct,
            rms_radius_px: ghost.rms_radius_mm()? / self.sensor.pixel_pitch_mm,
        })
    }

    fn draw(&self, path: GhostPath, u: [f64; 2], c: usize, cells: &mut FrameCells) {
        let direct = self.image(None, u, c).energy();
        if direct.is_nan() || direct <= 0.0 {
            return;
        }
        for h in &self.image(Some(path), u, c).hits {
            cells.add_at(self.to_image(h.position), h.weight / direct);
        }
    }
}

/// The matrix ghosts as the flare pass draws them (the aperture polygon clipped by the most
/// vignetting surface, uniform light, at least [`MIN_GHOST_RADIUS_PX`]).
pub struct Matrix<'a> {
    pub lens: &'a FlareLens,
    pub catalogue: &'a GhostCatalogue,
    pub sensor: Sensor,
}

impl GhostModel for Matrix<'_> {
    fn name(&self) -> &str {
        "matrix ghosts"
    }

    fn ghost(&self, path: GhostPath, u: [f64; 2], c: usize) -> Option<GhostEstimate> {
        let shape = self.shape(path, u, c)?;
        // At least 256 samples across the ghost, at most 32 per pixel.
        let m = shape.moments_step(&self.lens.aperture, (2.0 * shape.radius_px / 256.0).max(1.0 / 32.0))?;
        Some(GhostEstimate {
            centre_px: Some(shape.centre_px),
            centroid_px: m.centroid_px,
            energy_ratio: shape.irradiance_per_energy * m.area_px2,
            rms_radius_px: m.rms_radius_px,
        })
    }

    fn draw(&self, path: GhostPath, u: [f64; 2], c: usize, cells: &mut FrameCells) {
        let Some(shape) = self.shape(path, u, c) else { return };
        let r = shape.radius_px;
        let lo = [shape.centre_px[0] - r, shape.centre_px[1] - r];
        let hi = [shape.centre_px[0] + r, shape.centre_px[1] + r];
        let aperture = &self.lens.aperture;
        cells.add_over(lo, hi, |q| if shape.sdf(q, aperture) < 0.0 { shape.irradiance_per_energy } else { 0.0 });
    }
}

impl Matrix<'_> {
    /// The ghost as the flare pass draws it; None where a surface blocks it.
    fn shape(&self, path: GhostPath, u: [f64; 2], c: usize) -> Option<GhostShape> {
        let g = self.catalogue.ghosts.iter().find(|g| g.path == path)?;
        let s = self.sensor;
        let shape = g.channels[c].shape(
            u,
            s.centre_px,
            s.pixel_pitch_mm,
            MIN_GHOST_RADIUS_PX,
            self.catalogue.aperture_area_factor,
        );
        (!shape.blocked).then_some(shape)
    }
}

/// Walch's measured-ghost primitives as a lens file's `[[fitted_ghost]]` carries them (ch. 6-8):
/// each ghost's polynomials at the light's angle off the axis (eq 8.1's angle; only within the
/// fitted range, the polynomials do not extrapolate), turned by the light's roll (eq 8.2) about
/// the frame's centre, drawn as the GPU draws them (the f32 twin of glsl/tools/bezier_ghosts.comp).
/// The specs must be of the report's frame.
pub struct Fitted<'a> {
    pub specs: &'a [FittedGhostSpec],
    pub sensor: Sensor,
}

/// Whether a light of display slope `u` lies within the fitted range of `spec`'s angles.
fn within(spec: &FittedGhostSpec, u: [f64; 2]) -> bool {
    let [lo, hi] = spec.angles_deg;
    (lo - 1e-9..=hi + 1e-9).contains(&u[0].hypot(u[1]).atan().to_degrees())
}

impl Fitted<'_> {
    fn spec(&self, path: GhostPath, c: usize) -> Option<&FittedGhostSpec> {
        let label = format!("{}/{}", path.first, path.second);
        self.specs.iter().find(|s| s.ghost == label && s.channel as usize == c)
    }

    /// The primitive of `spec` for a light of display slope `u`, in `colour`; None outside the
    /// fitted range of angles.
    fn drawn(&self, spec: &FittedGhostSpec, u: [f64; 2], colour: [f64; 3]) -> Option<DrawnGhost> {
        if !within(spec, u) {
            return None;
        }
        let angle_deg = u[0].hypot(u[1]).atan().to_degrees();
        // The fit has the light towards +x; on screen (y down) the light's direction u is +x
        // turned counter-clockwise by atan2(-u_y, u_x).
        let roll_rad = (-u[1]).atan2(u[0]);
        Some(DrawnGhost { ghost: spec.polynomials().at(angle_deg), colour, roll_rad, pivot_px: self.sensor.centre_px })
    }
}

impl GhostModel for Fitted<'_> {
    fn name(&self) -> &str {
        "fitted primitives"
    }

    fn covers(&self, path: GhostPath, u: [f64; 2], c: usize) -> bool {
        self.spec(path, c).is_some_and(|s| within(s, u))
    }

    fn ghost(&self, path: GhostPath, u: [f64; 2], c: usize) -> Option<GhostEstimate> {
        let drawn = self.drawn(self.spec(path, c)?, u, [1.0; 3])?;
        let words = drawn.words()?;
        let b: Vec<f64> = words[BEZIER_BOUNDS as usize..][..4].iter().map(|&v| v as f64).collect();
        // Pixel centres as the GPU draws them; a ghost over 256 px across on at least 256
        // samples across, each standing for its square (the intensities are per frame pixel).
        let step = ((b[2] - b[0]).max(b[3] - b[1]) / 256.0).max(1.0);
        let origin = [b[0].floor(), b[1].floor()];
        let n = [((b[2] - origin[0]) / step).ceil() as usize, ((b[3] - origin[1]) / step).ceil() as usize];
        let samples: Vec<([f64; 2], f64)> = (0..n[1])
            .flat_map(|j| {
                (0..n[0]).map(move |i| [origin[0] + (i as f64 + 0.5) * step, origin[1] + (j as f64 + 0.5) * step])
            })
            .map(|q| (q, primitive_light(&words, [q[0] as f32, q[1] as f32]) as f64))
            .collect();
        let sum: f64 = samples.iter().map(|s| s.1).sum();
        if !(sum > 0.0 && sum.is_finite()) {
            return None;
        }
        let c = samples.iter().fold([0.0; 2], |m, (q, v)| [m[0] + v * q[0] / sum, m[1] + v * q[1] / sum]);
        let m2: f64 = samples.iter().map(|(q, v)| v * ((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2))).sum();
        // M, the primitive's centre, turned with it.
        let r = &drawn;
        let o = [r.ghost.centre_px[0] - r.pivot_px[0], r.ghost.centre_px[1] - r.pivot_px[1]];
        let (cos, sin) = (r.roll_rad.cos(), r.roll_rad.sin());
        Some(GhostEstimate {
            centre_px: Some([r.pivot_px[0] + cos * o[0] + sin * o[1], r.pivot_px[1] - sin * o[0] + cos * o[1]]),
            centroid_px: c,
            energy_ratio: sum * step * step,
            rms_radius_px: (m2 / sum).sqrt(),
        })
    }

    fn draw(&self, path: GhostPath, u: [f64; 2], c: usize, cells: &mut FrameCells) {
        let Some(words) = self.spec(path, c).and_then(|s| self.drawn(s, u, [1.0; 3])).and_then(|d| d.words()) else {
            return;
        };
        let b: Vec<f64> = words[BEZIER_BOUNDS as usize..][..4].iter().map(|&v| v as f64).collect();
        cells.add_over([b[0], b[1]], [b[2], b[3]], |q| primitive_light(&words, [q[0] as f32, q[1] as f32]) as f64);
    }
}

/// GPU ms of glsl/tools/bezier_ghosts.comp drawing every fitted ghost (all channels) of a light of
/// display slope `u` on a black frame (timestamp queries, median of `runs` after a warm-up);
/// None when no ghost is within its fitted range.
fn fitted_gpu_ms(
    gpu: &Gpu,
    kernel: &Kernel<BezierGhostsShader>,
    fitted: &Fitted,
    paths: &[GhostPath],
    u: [f64; 2],
    size: [u32; 2],
    runs: usize,
) -> GpuResult<Option<f64>> {
    let ghosts: Vec<DrawnGhost> = paths
        .iter()
        .flat_map(|&p| (0..3).map(move |c| (p, c)))
        .filter_map(|(p, c)| {
            let mut colour = [0.0; 3];
            colour[c] = 1.0;
            fitted.drawn(fitted.spec(p, c)?, u, colour)
        })
        .collect();
    if ghosts.is_empty() {
        return Ok(None);
    }
    let mut times = Vec::new();
    for run in 0..=runs.max(1) {
        let (_, profile, _) = bezier_ghosts::draw(kernel, "fitted ghosts", gpu, size[0], size[1], &ghosts, false)?;
        if run > 0 {
            times.push(profile.pass_ms(bezier_ghosts::NAME).unwrap_or(0.0));
        }
    }
    Ok(Some(median(times)))
}

/// One model at one light angle, against the reference.
#[derive(Clone, Debug)]
pub struct ModelRow {
    pub model: String,
    /// The reference's own row: no errors, only its time.
    pub reference: bool,
    pub angle_deg: f64,
    /// (ghost, channel) pairs both the model and the reference show.
    pub compared: usize,
    /// Pairs one shows and the other does not (blocked or vignetted away).
    pub disagree: usize,
    /// Distance of the centres (chief rays), over the pairs where both have one.
    pub centre_error_px: Stats,
    pub centroid_error_px: Stats,
    /// |model / reference - 1| of the energy.
    pub energy_error: Stats,
    /// |model - reference| of the RMS radius, relative to the reference's.
    pub size_error: Stats,
    /// The model's frame of these ghosts against the traced rays' frame (per channel, in
    /// [`IMAGE_CELLS_ACROSS`] cells across): RMS difference over the traced frame's RMS ([`relative_image_error`]).
    /// The reference's own row: an estimate of its binning noise, the same measure between
    /// the frames of its alternate rays, halved (a model's error holds this noise in
    /// quadrature). None where nothing is compared.
    pub image_error: Option<f64>,
    /// The ghost with the largest centroid error.
    pub worst: Option<GhostPath>,
    /// Time to compute every ghost of the light on the CPU (ms).
    pub cpu_ms: f64,
    /// GPU ms of the flare passes drawing these ghosts for the light (models the pass draws).
    pub gpu_ms: Option<f64>,
}

/// Median and largest of a set of errors.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats {
    pub median: f64,
    pub max: f64,
}

impl Stats {
    fn of(values: &[f64]) -> Stats {
        Stats { median: median(values.to_vec()), max: values.iter().copied().fold(0.0, f64::max) }
    }
}

/// The light's display slope for a light `angle_deg` off the axis, towards the frame's upper
/// right corner.
pub fn light_slope(angle_deg: f64, width: u32, height: u32) -> [f64; 2] {
    let (w, h) = (width as f64, -(height as f64));
    let t = angle_deg.to_radians().tan() / w.hypot(h);
    [w * t, h * t]
}

/// Every ghost of `paths` in every channel by `model`.
fn estimates(model: &dyn GhostModel, paths: &[GhostPath], u: [f64; 2]) -> (Vec<Option<GhostEstimate>>, f64) {
    let start = Instant::now();
    let e = paths
        .iter()
        .flat_map(|&p| (0..3).map(move |c| (p, c)))
        .map(|(p, c)| if model.covers(p, u, c) { model.ghost(p, u, c) } else { None })
        .collect();
    (e, start.elapsed().as_secs_f64() * 1e3)
}

/// GPU ms of the flare passes drawing only the ghosts (no starburst or halo) of one light.
fn ghosts_gpu_ms(
    gpu: &Gpu,
    camera: &Camera,
    width: u32,
    height: u32,
    light: FlareLight,
    runs: usize,
) -> GpuResult<f64> {
    let mut camera = camera.clone();
    camera.flare.enabled = true;
    camera.flare.lights = vec![light];
    let frame =
        Frame::new(width, height, vec![0.0; (width * height * 4) as usize], vec![1.0e4; (width * height) as usize]);
    let input = PlanInput::new(&frame, &camera);
    let model = FlareModel::new(&camera, input.facts.pixel_pitch_mm, frame.centre_px);
    let mut params = FlareParams::new(&input, &model, None);
    params.constants.spike_count = 0;
    params.constants.glow_coef_px = [0.0; 4];
    params.constants.halo_fraction = 0.0;
    params.constants.slots_per_light = params.constants.ghost_count + 1;
    let mut p = plan(&frame, &camera);
    p.force::<Flare>(params);
    let renderer = Renderer::new(gpu, &p)?;
    renderer.render(&frame, &p, false)?;
    let ms = |profile: &Profile| FLARE_PASSES.iter().filter_map(|n| profile.pass_ms(n)).sum::<f64>();
    let times = (0..runs.max(1)).map(|_| renderer.render(&frame, &p, false).map(|o| ms(&o.profile)));
    Ok(median(times.collect::<GpuResult<Vec<_>>>()?))
}

/// The report's options.
#[derive(Clone, Debug)]
pub struct FlareAccuracyOptions {
    pub width: u32,
    pub height: u32,
    pub angles_deg: Vec<f64>,
    pub rays_across: usize,
    pub runs: usize,
    /// Walch's fitted primitives to compare too (a lens file's `[[fitted_ghost]]`, of this
    /// frame); empty: no such row.
    pub fitted: Vec<FittedGhostSpec>,
}

/// One model's row at one angle: its estimates against the reference's (`truth`), over the
/// (ghost, channel) pairs in `paths` x 0..3 order that the model covers.
fn compare(
    model: &dyn GhostModel,
    (angle_deg, u): (f64, [f64; 2]),
    paths: &[GhostPath],
    truth: &[Option<GhostEstimate>],
    (estimate, cpu_ms): (Vec<Option<GhostEstimate>>, f64),
    gpu_ms: Option<f64>,
    image_error: Option<f64>,
) -> ModelRow {
    let (mut centre, mut centroid, mut energy, mut size, mut disagree) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), 0);
    let mut worst = (0.0, None);
    for (k, (t, e)) in truth.iter().zip(&estimate).enumerate() {
        if !model.covers(paths[k / 3], u, k % 3) {
            continue;
        }
        match (t, e) {
            (Some(t), Some(e)) => {
                if let (Some(a), Some(b)) = (t.centre_px, e.centre_px) {
                    centre.push((a[0] - b[0]).hypot(a[1] - b[1]));
                }
                let d = (t.centroid_px[0] - e.centroid_px[0]).hypot(t.centroid_px[1] - e.centroid_px[1]);
                if d >= worst.0 {
                    worst = (d, Some(paths[k / 3]));
                }
                centroid.push(d);
                energy.push((e.energy_ratio / t.energy_ratio - 1.0).abs());
                size.push((e.rms_radius_px - t.rms_radius_px).abs() / t.rms_radius_px.max(1e-9));
            }
            (None, None) => {}
            _ => disagree += 1,
        }
    }
    ModelRow {
        model: model.name().into(),
        reference: false,
        angle_deg,
        compared: centroid.len(),
        disagree,
        centre_error_px: Stats::of(&centre),
        centroid_error_px: Stats::of(&centroid),
        energy_error: Stats::of(&energy),
        size_error: Stats::of(&size),
        image_error,
        worst: worst.1,
        cpu_ms,
        gpu_ms,
    }
}

/// Every model against the traced reference at every angle. `camera` needs a prescription.
pub fn run(
    gpu: &Gpu,
    camera: &Camera,
    options: &FlareAccuracyOptions,
    mut progress: impl FnMut(&str),
) -> GpuResult<Vec<ModelRow>> {
    let (w, h) = (options.width, options.height);
    let sensor = Sensor { pixel_pitch_mm: camera.pixel_pitch_mm(w, h), centre_px: [0.5 * w as f64, 0.5 * h as f64] };
    let model = FlareModel::new(camera, sensor.pixel_pitch_mm, sensor.centre_px);
    let (Some(lens), Some(catalogue)) = (&model.lens, &model.catalogue) else { return Ok(Vec::new()) };
    let paths: Vec<GhostPath> = catalogue.ghosts.iter().map(|g| g.path).collect();
    let reference = Traced { lens, catalogue, sensor, rays_across: options.rays_across };
    let matrix = Matrix { lens, catalogue, sensor };
    let fitted = Fitted { specs: &options.fitted, sensor };
    let kernel = if options.fitted.is_empty() { None } else { Some(Kernel::<BezierGhostsShader>::new(gpu)?) };
    let g0_mm = catalogue.direct.centre_mm[1];
    let mut rows = Vec::new();
    for &angle_deg in &options.angles_deg {
        let u = light_slope(angle_deg, w, h);
        progress(&format!("{angle_deg} degrees: tracing"));
        let (truth, traced_ms) = estimates(&reference, &paths, u);
        let shown = truth.iter().filter(|t| t.is_some()).count();
        // Each (ghost, channel)'s traced frame, and every ghost's alternate rays apart.
        let black = || FrameCells::new([w, h], IMAGE_CELLS_ACROSS);
        let mut halves: [[FrameCells; 3]; 2] = [std::array::from_fn(|_| black()), std::array::from_fn(|_| black())];
        let traced_cells: Vec<FrameCells> = (0..3 * paths.len())
            .map(|k| {
                let mut cells = std::array::from_fn(|_| black());
                reference.draw_halves(paths[k / 3], u, k % 3, &mut cells);
                let [full, even, odd] = cells;
                for (half, own) in halves.iter_mut().zip([even, odd]) {
                    half[k % 3].values.iter_mut().zip(&own.values).for_each(|(a, b)| *a += b);
                }
                full
            })
            .collect();
        let image_error = |model: &dyn GhostModel| {
            let (mut drawn, mut traced): ([FrameCells; 3], [FrameCells; 3]) =
                (std::array::from_fn(|_| black()), std::array::from_fn(|_| black()));
            for (k, cells) in traced_cells.iter().enumerate() {
                let (p, c) = (paths[k / 3], k % 3);
                if model.covers(p, u, c) {
                    model.draw(p, u, c, &mut drawn[c]);
                    traced[c].values.iter_mut().zip(&cells.values).for_each(|(a, b)| *a += b);
                }
            }
            relative_image_error(&drawn, &traced)
        };
        rows.push(ModelRow {
            model: reference.name().into(),
            reference: true,
            angle_deg,
            compared: shown,
            disagree: 0,
            centre_error_px: Stats::default(),
            centroid_error_px: Stats::default(),
            energy_error: Stats::default(),
            size_error: Stats::default(),
            image_error: relative_image_error(&halves[0], &halves[1]).map(|e| 0.5 * e),
            worst: None,
            cpu_ms: traced_ms,
            gpu_ms: None,
        });
        progress(&format!("{angle_deg} degrees: matrix ghosts"));
        let light = FlareLight::white(
            sensor.centre_px[0] + g0_mm * u[0] / sensor.pixel_pitch_mm,
            sensor.centre_px[1] + g0_mm * u[1] / sensor.pixel_pitch_mm,
            1.0e6,
        );
        let gpu_ms = ghosts_gpu_ms(gpu, camera, w, h, light, options.runs)?;
        let (estimate, error) = (estimates(&matrix, &paths, u), image_error(&matrix));
        rows.push(compare(&matrix, (angle_deg, u), &paths, &truth, estimate, Some(gpu_ms), error));
        if let Some(kernel) = &kernel {
            let gpu_ms = fitted_gpu_ms(gpu, kernel, &fitted, &paths, u, [w, h], options.runs)?;
            let (estimate, error) = (estimates(&fitted, &paths, u), image_error(&fitted));
            rows.push(compare(&fitted, (angle_deg, u), &paths, &truth, estimate, gpu_ms, error));
        }
    }
    Ok(rows)
}

/// The report as Markdown.
pub fn markdown(device: &str, command: &str, lens: &str, options: &FlareAccuracyOptions, rows: &[ModelRow]) -> String {
    let cells = FrameCells::new([options.width, options.height], IMAGE_CELLS_ACROSS);
    let mut out = format!("Device: {device}\n\nCommand: `{command}`\n\n");
    out += &format!(
        "{lens}: every ghost (two reflections) in each colour channel for a point light at each angle off the axis \
         (towards the upper right corner), on a {}x{} px frame. The traced reference: {} real rays across the front \
         lens per wavelength, three wavelengths per channel, f64; each model's ghost against it: the distance of the \
         centres (the real chief ray through the stop's centre against the matrices' centre; px), the distance of \
         the centroids (px), |energy / traced - 1| and |RMS radius - traced| / traced, median and largest over the \
         (ghost, channel) pairs both show; 'disagree': pairs only one of them shows. Image: the model's frame of the ghosts it \
         covers against the traced rays' frame of the same ghosts, each channel in cells of {cell} px ({cells} across, \
         the rays binned, the models sampled at each cell's centre): RMS difference over the traced frame's RMS (0: the \
         same light; 1: a black frame); on the reference's row, its binning noise (half that measure between the \
         frames of its alternate rays), which every model's figure holds in quadrature. CPU ms: every ghost of the light \
         on one core; GPU ms: the flare passes drawing the light's ghosts (no starburst or halo; timestamp queries, \
         median of {} runs).\n\n",
        options.width,
        options.height,
        options.rays_across,
        options.runs,
        cell = cells.cell_px,
        cells = cells.width,
    );
    if !options.fitted.is_empty() {
        out += &format!(
            "Fitted primitives: the lens file's {} [[fitted_ghost]] entries (Walch ch. 6-8; `realcam flare-fit`), each \
             ghost's polynomials at the light's angle, turned to its direction (eq 8.2), compared at angles within \
             their fitted range only; their centre is the primitive's M; GPU ms: glsl/tools/bezier_ghosts.comp drawing \
             them all on the frame (median of {} runs).\n\n",
            options.fitted.len(),
            options.runs
        );
    }
    out += "| angle deg | model | compared | disagree | centre px (median / max) | centroid px (median / max) | energy (median / max) | size (median / max) | image | worst centroid | CPU ms | GPU ms |\n";
    out += "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
    for r in rows {
        let (centre, centroid, energy, size, worst) = if r.reference {
            ("(reference)".to_string(), String::new(), String::new(), String::new(), String::new())
        } else if r.compared == 0 {
            ("(none compared)".to_string(), String::new(), String::new(), String::new(), String::new())
        } else {
            (
                format!("{:.2} / {:.2}", r.centre_error_px.median, r.centre_error_px.max),
                format!("{:.2} / {:.2}", r.centroid_error_px.median, r.centroid_error_px.max),
                format!("{:.1}% / {:.0}%", 100.0 * r.energy_error.median, 100.0 * r.energy_error.max),
                format!("{:.0}% / {:.0}%", 100.0 * r.size_error.median, 100.0 * r.size_error.max),
                r.worst.map_or(String::new(), |g| format!("{}/{}", g.first, g.second)),
            )
        };
        out += &format!(
            "| {} | {} | {} | {} | {centre} | {centroid} | {energy} | {size} | {} | {worst} | {:.1} | {} |\n",
            r.angle_deg,
            r.model,
            r.compared,
            r.disagree,
            r.image_error.map_or(String::new(), |e| format!(
                "{:.0}%{}",
                100.0 * e,
                if r.reference { " (noise)" } else { "" }
            )),
            r.cpu_ms,
            r.gpu_ms.map_or(String::new(), |ms| format!("{ms:.2}")),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::bench_flare::flare_camera;

    /// The report's Tessar at f/2.8 with the pixels of a `w` x `h` frame, its centre at `centre_px`.
    fn tessar_on(w: u32, h: u32, centre_px: [f64; 2]) -> (FlareModel, Sensor) {
        let camera = flare_camera(w, h);
        let sensor = Sensor { pixel_pitch_mm: camera.pixel_pitch_mm(w, h), centre_px };
        (FlareModel::new(&camera, sensor.pixel_pitch_mm, sensor.centre_px), sensor)
    }

    #[test]
    fn the_light_sits_at_its_angle_and_the_models_agree_on_the_centres() {
        // A light 2 degrees off the axis lies G0 tan(2 deg) from the centre towards the upper
        // right corner; at 1 degree the report's two models, in the report's own image
        // coordinates, put every ghost's centre within 1 px of each other at 1280 px (the chief rays, as
        // src/optics/flare/traced.rs checks in sensor coordinates), and on axis every ghost's
        // centroid on the centre.
        let (w, h) = (1280, 720);
        let u = light_slope(2.0, w, h);
        assert!((u[0].hypot(u[1]) - 2f64.to_radians().tan()).abs() < 1e-12);
        assert!(u[0] > 0.0 && u[1] < 0.0 && (u[1] / u[0] + 720.0 / 1280.0).abs() < 1e-12);
        // The centres at 1 degree (the error grows as the cube of the angle: 2.6 px at 2).
        let u = light_slope(1.0, w, h);
        let (model, sensor) = tessar_on(w, h, [640.0, 360.0]);
        let (lens, catalogue) = (model.lens.as_ref().unwrap(), model.catalogue.as_ref().unwrap());
        let traced = Traced { lens, catalogue, sensor, rays_across: 16 };
        let matrix = Matrix { lens, catalogue, sensor };
        let mut centres = 0;
        for g in &catalogue.ghosts {
            for c in 0..3 {
                let (Some(t), Some(m)) = (traced.ghost(g.path, u, c), matrix.ghost(g.path, u, c)) else { continue };
                if let (Some(a), Some(b)) = (t.centre_px, m.centre_px) {
                    assert!((a[0] - b[0]).hypot(a[1] - b[1]) < 1.0, "{:?} channel {c}: {a:?} vs {b:?}", g.path);
                    centres += 1;
                }
                let axis = matrix.ghost(g.path, [0.0; 2], c).unwrap();
                let d = (axis.centroid_px[0] - 640.0).hypot(axis.centroid_px[1] - 360.0);
                assert!(d < 1e-3, "{:?}: on axis the centroid is {d} px off the centre", g.path);
            }
        }
        // Ghost 2/0 has no real chief ray (src/optics/flare/traced.rs).
        assert!(centres >= 60, "{centres}");
    }

    #[test]
    fn the_image_error_is_relative_to_the_traced_frame_and_each_frame_holds_its_ghosts_energy() {
        // The measure: 0 for the reference's own frame, 1 for a black frame and for one of twice
        // the light (|2T - T| = |T|), 1/2 for half of it.
        let mut t = FrameCells::new([1280, 720], IMAGE_CELLS_ACROSS);
        assert_eq!((t.cell_px, t.width, t.height), (80.0, 16, 9));
        t.add_at([100.0, 50.0], 3.0);
        t.add_at([900.0, 700.0], 1.0);
        let scaled = |k: f64| FrameCells { values: t.values.iter().map(|v| k * v).collect(), ..t.clone() };
        let error = |k: f64| relative_image_error(std::slice::from_ref(&scaled(k)), std::slice::from_ref(&t)).unwrap();
        assert_eq!((error(1.0), error(0.0), error(2.0), error(0.5)), (0.0, 1.0, 1.0, 0.5));
        assert_eq!(relative_image_error(&[t.clone()], &[scaled(0.0)]), None);
        // Each model's frame of a ghost holds the energy it reports (light per frame pixel
        // times the cells' area): the Tessar's ghosts at 2 degrees, in green, all of them on a
        // frame ten times the 1280x720 one's size (same pixels; the ghosts span 600-3600 px),
        // in cells of 80 px: the traced rays binned exactly, the matrix ghosts sampled at the
        // cells' centres within 3% (their edges).
        let (w, h) = (1280, 720);
        let (model, sensor) = tessar_on(w, h, [6400.0, 3600.0]);
        let (lens, catalogue) = (model.lens.as_ref().unwrap(), model.catalogue.as_ref().unwrap());
        let traced = Traced { lens, catalogue, sensor, rays_across: 16 };
        let matrix = Matrix { lens, catalogue, sensor };
        let u = light_slope(2.0, w, h);
        let mut checked = 0;
        for g in &catalogue.ghosts {
            for (m, tolerance) in [(&traced as &dyn GhostModel, 1e-9), (&matrix, 0.03)] {
                let Some(e) = m.ghost(g.path, u, 1) else { continue };
                let r = 3.0 * e.rms_radius_px;
                let [x, y] = e.centroid_px;
                if x - r < 0.0 || y - r < 0.0 || x + r > 12800.0 || y + r > 7200.0 {
                    continue;
                }
                let mut cells = FrameCells::new([12800, 7200], 160);
                m.draw(g.path, u, 1, &mut cells);
                let drawn = cells.values.iter().sum::<f64>() * 80.0 * 80.0;
                let summary = format!("{} {:?}: drawn {drawn:.4e}, reported {:.4e}", m.name(), g.path, e.energy_ratio);
                assert!((drawn / e.energy_ratio - 1.0).abs() < tolerance, "{summary}");
                checked += 1;
            }
        }
        assert!(checked >= 20, "{checked}");
    }
}
