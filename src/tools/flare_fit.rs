//! Walch 2017 ch. 7: fitting the measured-ghost primitive to images of a ghost. The cost is
//! the mean squared error of the images plus the same of their edge images (sec. 7.1.2: a
//! Gaussian, the discrete Laplacian, a wider Gaussian), minimised by coordinate descent
//! (sec. 7.2): in a fixed order, each parameter steps along the sign of its central difference
//! (eq 7.3) by its own step times a learning rate, kept when the cost falls (online update;
//! here a kept step is also tried doubled, up to 4 times, while that helps); after an
//! iteration without progress the learning rate halves. A range of samples is fitted
//! in order, each started from the least-squares polynomial of the samples fitted before it
//! (sec. 7.3), and the parameters then become polynomials of the angle (ch. 8: polynomial.rs,
//! the stage the traced and the captured path share).
//!
//! The primitive is drawn as the GPU draws it (the f32 twin of glsl/tools/bezier_ghosts.comp).

pub mod capture;
pub mod polynomial;

pub use polynomial::{fitted_range, missed_angles, polynomials, relight, smooth_fits, worst_error};

use crate::io::lens_file::FittedGhostSpec;
use crate::optics::bezier_ghost::{poly_eval, polyfit, BezierGhost, Transfer, CIRCLE_CONTROL, PARAMS, PARAM_RANGES};
use crate::{passes::flare::ghost_shape::primitive_light, tools::bezier_ghosts::DrawnGhost};

/// A grey image of a ghost: `values` (light per frame pixel) row by row, its pixel (0, 0) at `origin_px` of the frame,
/// each of its pixels `cell_px` frame pixels wide (a ghost larger than the frame is fitted on
/// a coarser grid).
#[derive(Clone, Debug, PartialEq)]
pub struct GreyImage {
    pub width: u32,
    pub height: u32,
    pub origin_px: [f64; 2],
    pub cell_px: f64,
    pub values: Vec<f64>,
}

impl GreyImage {
    /// The frame position of pixel (x, y)'s centre.
    pub fn centre_of(&self, x: u32, y: u32) -> (f64, f64) {
        (self.origin_px[0] + (x as f64 + 0.5) * self.cell_px, self.origin_px[1] + (y as f64 + 0.5) * self.cell_px)
    }

    /// The primitive drawn on this image's pixels (frame coordinates, no roll).
    pub fn draw(&self, ghost: &BezierGhost) -> Vec<f64> {
        let mut out = vec![0.0; (self.width * self.height) as usize];
        let drawn = DrawnGhost { ghost: *ghost, colour: [1.0; 3], roll_rad: 0.0, pivot_px: [0.0; 2] };
        let Some(words) = drawn.words() else { return out };
        let b = ghost.bounds_px();
        let cell = self.cell_px;
        let x0 = ((b[0] - self.origin_px[0]) / cell).floor().max(0.0) as u32;
        let y0 = ((b[1] - self.origin_px[1]) / cell).floor().max(0.0) as u32;
        let x1 = (((b[2] - self.origin_px[0]) / cell).ceil().max(0.0) as u32).min(self.width);
        let y1 = (((b[3] - self.origin_px[1]) / cell).ceil().max(0.0) as u32).min(self.height);
        for y in y0..y1 {
            for x in x0..x1 {
                let q = [
                    (self.origin_px[0] + (x as f64 + 0.5) * cell) as f32,
                    (self.origin_px[1] + (y as f64 + 0.5) * cell) as f32,
                ];
                out[(y * self.width + x) as usize] = primitive_light(&words, q) as f64;
            }
        }
        out
    }
}

/// The traced ghost `path` in channel `c` for a light of display slope `u` (the reference of
/// src/optics/flare/traced.rs, real rays) as a grey image: every ray's weight, per unit of the
/// light's own image, summed in the cell it lands in and divided by the cell's area in frame
/// pixels (light per frame pixel, whatever the cell: a primitive fitted to it draws the same
/// light on the frame's pixels, and samples fitted on cells of different sizes agree), over
/// the box of the ghost's rays grown on every side by `margin` times its larger side (at least
/// 4 px: room for the primitive's outer fade, which the fit must see), in cells of whole pixels
/// at most `max_cells` across. None where no light of it reaches the sensor.
///
/// `rays_across` is where the tracing starts: a ghost that magnifies the pupil (a defocused
/// ghost larger than the frame) spreads its rays wider apart than its cells, and its image is
/// then a lattice of dots with dark cells between them, which no smooth primitive matches (the
/// fit dims to nothing: the Tessar's 6/1 at 32 rays across, about 3.5 cells between the dots).
/// Such a ghost is traced again with more rays across, until its rays land at most
/// [`MAX_RAY_SPACING_CELLS`] of a cell apart ([`ray_spacing_px`]), at most [`MAX_RAYS_ACROSS`].
#[allow(clippy::too_many_arguments)]
pub fn traced_ghost_image(
    lens: &crate::optics::flare::FlareLens,
    path: crate::optics::flare::ghosts::GhostPath,
    u: [f64; 2],
    c: usize,
    rays_across: usize,
    sensor: crate::tools::accuracy_flare::Sensor,
    margin: f64,
    max_cells: u32,
) -> Option<GreyImage> {
    use crate::optics::flare::traced::{optical_slope, TracedImage};
    let direct = TracedImage::trace(lens, None, optical_slope(u), c, rays_across).energy();
    if direct.is_nan() || direct <= 0.0 {
        return None;
    }
    let mut rays = rays_across.max(2);
    loop {
        let ghost = TracedImage::trace(lens, Some(path), optical_slope(u), c, rays);
        let px = hits_px(&ghost, sensor, direct);
        if px.is_empty() {
            return None;
        }
        let image = bin_hits(&px, margin, max_cells);
        let wavelengths = crate::optics::flare::BANDS_NM[c.min(2)].len();
        let spacing = ray_spacing_px(&px, wavelengths);
        let wanted = MAX_RAY_SPACING_CELLS * image.cell_px;
        if spacing <= wanted || rays >= MAX_RAYS_ACROSS {
            return Some(image);
        }
        rays = ((rays as f64 * spacing / wanted).ceil() as usize).clamp(rays + 1, MAX_RAYS_ACROSS);
    }
}

/// The most rays across the front lens [`traced_ghost_image`] traces a ghost with.
pub const MAX_RAYS_ACROSS: usize = 256;

/// How far apart (in cells) a traced ghost's neighbouring rays may land: half a cell, about
/// four rays of each wavelength per lit cell.
pub const MAX_RAY_SPACING_CELLS: f64 = 0.5;

/// The hits of a traced ghost on the frame (px) with their light per unit of the light's own
/// image (`direct`), non-finite ones left out.
fn hits_px(
    ghost: &crate::optics::flare::traced::TracedImage,
    sensor: crate::tools::accuracy_flare::Sensor,
    direct: f64,
) -> Vec<([f64; 2], f64)> {
    use crate::optics::flare::traced::display_px;
    ghost
        .hits
        .iter()
        .map(|h| {
            let d = display_px(h.position, sensor.pixel_pitch_mm);
            ([sensor.centre_px[0] + d[0], sensor.centre_px[1] + d[1]], h.weight / direct)
        })
        .filter(|(p, w)| p[0].is_finite() && p[1].is_finite() && w.is_finite())
        .collect()
}

/// The typical distance (px) between neighbouring rays of one wavelength on the frame: the
/// square root of the area they cover per ray, the area that of the ellipse with their second
/// moments (4 pi sigma_x sigma_y: exact for a uniformly lit disc or ellipse; larger than the
/// lit area for a ring, which errs towards tracing more rays).
pub fn ray_spacing_px(hits: &[([f64; 2], f64)], wavelengths: usize) -> f64 {
    let n = hits.len() as f64;
    if n < 2.0 {
        return 0.0;
    }
    let mean = hits.iter().fold([0.0; 2], |m, (p, _)| [m[0] + p[0] / n, m[1] + p[1] / n]);
    let var = hits
        .iter()
        .fold([0.0; 2], |v, (p, _)| [v[0] + (p[0] - mean[0]).powi(2) / n, v[1] + (p[1] - mean[1]).powi(2) / n]);
    let area = 4.0 * std::f64::consts::PI * var[0].sqrt() * var[1].sqrt();
    (area / (n / wavelengths.max(1) as f64)).sqrt()
}

/// The hits binned as [`traced_ghost_image`] describes.
fn bin_hits(px: &[([f64; 2], f64)], margin: f64, max_cells: u32) -> GreyImage {
    let lo = px.iter().fold([f64::INFINITY; 2], |m, (p, _)| [m[0].min(p[0]), m[1].min(p[1])]);
    let hi = px.iter().fold([f64::NEG_INFINITY; 2], |m, (p, _)| [m[0].max(p[0]), m[1].max(p[1])]);
    let margin_px = (margin * (hi[0] - lo[0]).max(hi[1] - lo[1])).max(4.0);
    let origin = [(lo[0] - margin_px).floor(), (lo[1] - margin_px).floor()];
    let extent = ((hi[0] + margin_px).ceil() - origin[0]).max((hi[1] + margin_px).ceil() - origin[1]).max(1.0);
    let cell_px = (extent / max_cells.max(1) as f64).max(1.0).ceil();
    let width = (((hi[0] + margin_px) - origin[0]) / cell_px).ceil().max(1.0) as u32;
    let height = (((hi[1] + margin_px) - origin[1]) / cell_px).ceil().max(1.0) as u32;
    let mut values = vec![0.0; (width * height) as usize];
    for (p, w) in px {
        let (x, y) = (((p[0] - origin[0]) / cell_px) as u32, ((p[1] - origin[1]) / cell_px) as u32);
        if x < width && y < height {
            values[(y * width + x) as usize] += w / (cell_px * cell_px);
        }
    }
    GreyImage { width, height, origin_px: origin, cell_px, values }
}

/// A separable Gaussian of standard deviation `sigma` px (taps to 3 sigma), edges clamped.
fn gaussian(values: &[f64], w: usize, h: usize, sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as i64;
    let taps: Vec<f64> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp()).collect();
    let total: f64 = taps.iter().sum();
    let pass = |src: &[f64], horizontal: bool| {
        let mut out = vec![0.0; w * h];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut s = 0.0;
                for (k, t) in taps.iter().enumerate() {
                    let o = k as i64 - r;
                    let (sx, sy) = if horizontal {
                        ((x + o).clamp(0, w as i64 - 1), y)
                    } else {
                        (x, (y + o).clamp(0, h as i64 - 1))
                    };
                    s += t * src[(sy * w as i64 + sx) as usize];
                }
                out[(y * w as i64 + x) as usize] = s / total;
            }
        }
        out
    };
    pass(&pass(values, true), false)
}

/// Sec. 7.1.2's edge image: Gaussian (sigma 1 px), the discrete Laplacian's magnitude, and a
/// wider Gaussian (sigma 2 px) so that nearby edges overlap.
pub fn edge_image(values: &[f64], w: usize, h: usize) -> Vec<f64> {
    let smooth = gaussian(values, w, h, 1.0);
    let at = |x: i64, y: i64| smooth[(y.clamp(0, h as i64 - 1) as usize) * w + x.clamp(0, w as i64 - 1) as usize];
    let mut lap = vec![0.0; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let l = at(x - 1, y) + at(x + 1, y) + at(x, y - 1) + at(x, y + 1) - 4.0 * at(x, y);
            lap[y as usize * w + x as usize] = l.abs();
        }
    }
    gaussian(&lap, w, h, 2.0)
}

/// Eq 7.2's mean squared error.
pub fn mse(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>() / a.len().max(1) as f64
}

/// Weight of the edge term in the cost (the edge images of a ghost are about as large as the
/// images themselves near the border).
pub const EDGE_WEIGHT: f64 = 1.0;

/// Sec. 7.1.2's cost of `ghost` against a target and the target's edge image.
pub struct Cost<'a> {
    pub target: &'a GreyImage,
    target_edges: Vec<f64>,
    pub evaluations: usize,
}

impl<'a> Cost<'a> {
    pub fn new(target: &'a GreyImage) -> Cost<'a> {
        let (w, h) = (target.width as usize, target.height as usize);
        Cost { target, target_edges: edge_image(&target.values, w, h), evaluations: 0 }
    }

    /// MSE of the images plus EDGE_WEIGHT times the MSE of their edge images; infinite for a
    /// primitive whose light would reach past the image (the cost could not see it there, and
    /// a fit would hide light, or whole sides, outside).
    pub fn of(&mut self, ghost: &BezierGhost) -> f64 {
        self.evaluations += 1;
        let (b, t) = (ghost.bounds_px(), self.target);
        let end = [t.origin_px[0] + t.width as f64 * t.cell_px, t.origin_px[1] + t.height as f64 * t.cell_px];
        if !(b[0] >= t.origin_px[0] && b[1] >= t.origin_px[1] && b[2] <= end[0] && b[3] <= end[1]) {
            return f64::INFINITY;
        }
        let drawn = self.target.draw(ghost);
        let (w, h) = (self.target.width as usize, self.target.height as usize);
        let c = mse(&drawn, &self.target.values) + EDGE_WEIGHT * mse(&edge_image(&drawn, w, h), &self.target_edges);
        if c.is_finite() {
            c
        } else {
            f64::INFINITY
        }
    }
}

/// The per-parameter step sizes of sec. 7.2 for a ghost of this size and brightness, and the
/// range each parameter is kept in (sizes and fades positive, controls in 0..1.2).
fn steps_and_limits(g: &BezierGhost) -> ([f64; PARAMS], [(f64, f64); PARAMS]) {
    let size = g.height_px.abs().max(g.left_px.abs()).max(g.right_px.abs()).max(1.0);
    let light = g.transfer.border.abs().max(g.transfer.inner.abs()).max(1e-30);
    let steps = [
        0.05 * size,
        0.05 * size,
        0.05 * size,
        0.05 * size,
        0.05 * size,
        0.1,
        0.1,
        0.1 * light,
        0.1 * light,
        0.05 * size,
        0.05 * size,
        0.2,
        0.2,
    ];
    let mut limits = PARAM_RANGES;
    limits[10].1 = MAX_OUTER_FADE * size;
    // Eq 6.4: an inner fade longer than the ghost is deep draws what one of the ghost's depth
    // does with another I_i, so past its size F_i is free and neighbouring samples' fits wander
    // along it (polynomial.rs); kept within the size nothing drawable is lost.
    limits[9].1 = size.max(limits[9].0);
    (steps, limits)
}

/// The options of the coordinate descent.
#[derive(Clone, Copy, Debug)]
pub struct FitOptions {
    /// Most iterations (each steps every parameter once).
    pub max_iterations: usize,
    /// Stop when the learning rate has halved below this.
    pub min_learning_rate: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions { max_iterations: 300, min_learning_rate: 1e-3 }
    }
}

/// A fitted primitive.
#[derive(Clone, Copy, Debug)]
pub struct Fit {
    pub ghost: BezierGhost,
    pub cost: f64,
    pub iterations: usize,
    pub evaluations: usize,
}

/// `start` within the parameters' limits, shrunk about its centre (sizes and fades) until
/// the image holds its light (a moments guess of a ring, a seed extrapolated from its
/// neighbours may reach past it), and its cost.
fn held(cost: &mut Cost, start: &BezierGhost, limits: &[(f64, f64); PARAMS]) -> ([f64; PARAMS], f64) {
    let mut p = start.to_params();
    for (v, (lo, hi)) in p.iter_mut().zip(limits) {
        *v = v.clamp(*lo, *hi);
    }
    let mut c = cost.of(&BezierGhost::from_params(&p));
    for _ in 0..40 {
        if c.is_finite() {
            break;
        }
        for k in [2, 3, 4, 9, 10] {
            p[k] = (p[k] * 0.9).max(limits[k].0);
        }
        c = cost.of(&BezierGhost::from_params(&p));
    }
    (p, c)
}

/// Of several starts, the one of least cost (once the image holds it).
pub fn cheapest_start(target: &GreyImage, starts: &[BezierGhost]) -> Option<BezierGhost> {
    let mut cost = Cost::new(target);
    starts
        .iter()
        .map(|s| held(&mut cost, s, &steps_and_limits(s).1))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(p, _)| BezierGhost::from_params(&p))
}

/// Sec. 7.2's coordinate descent from `start`.
pub fn fit(target: &GreyImage, start: &BezierGhost, options: &FitOptions) -> Fit {
    fit_near(target, start, None, options)
}

/// [`fit`] with the cost plus `weight` times the squared distance of the parameters from an
/// `anchor`, each in units of ten of its steps (half the size for sizes and fades, the light
/// for I_b and I_i, 1 for the controls, 2 for the exponents): where the image cannot tell
/// parameters apart (polynomial.rs) the anchor decides, elsewhere the image. The returned
/// cost is the image's alone.
pub fn fit_near(
    target: &GreyImage,
    start: &BezierGhost,
    anchor: Option<(&BezierGhost, f64)>,
    options: &FitOptions,
) -> Fit {
    let mut cost = Cost::new(target);
    let (steps, limits) = steps_and_limits(start);
    let penalty = |q: &[f64; PARAMS]| {
        anchor.map_or(0.0, |(a, weight)| {
            let a = a.to_params();
            weight * (0..PARAMS).map(|k| ((q[k] - a[k]) / (10.0 * steps[k])).powi(2)).sum::<f64>()
        })
    };
    let (mut p, mut best) = held(&mut cost, start, &limits);
    best += penalty(&p);
    let mut rate = 1.0;
    let mut iterations = 0;
    while iterations < options.max_iterations && rate >= options.min_learning_rate {
        iterations += 1;
        let mut improved = false;
        for k in 0..PARAMS {
            let h = steps[k] * rate;
            let trial = |cost: &mut Cost, base: [f64; PARAMS], value: f64| {
                let mut q = base;
                q[k] = value.clamp(limits[k].0, limits[k].1);
                (q, cost.of(&BezierGhost::from_params(&q)) + penalty(&q))
            };
            // Eq 7.3's central difference decides the direction; the step is kept if it helps.
            let (plus, c_plus) = trial(&mut cost, p, p[k] + h);
            let (minus, c_minus) = trial(&mut cost, p, p[k] - h);
            let (q, c, direction) = if c_plus < c_minus { (plus, c_plus, 1.0) } else { (minus, c_minus, -1.0) };
            if c < best {
                (p, best) = (q, c);
                improved = true;
                // Along a valley the same direction keeps helping: double the step while it does
                // (at most 4 times), so that a far start costs fewer iterations.
                let mut stride = 2.0 * h;
                for _ in 0..4 {
                    let (q, c) = trial(&mut cost, p, p[k] + direction * stride);
                    if c >= best {
                        break;
                    }
                    (p, best) = (q, c);
                    stride *= 2.0;
                }
            }
        }
        if !improved {
            rate *= 0.5;
        }
    }
    let ghost = BezierGhost::from_params(&p);
    let best = if anchor.is_some() { cost.of(&ghost) } else { best };
    Fit { ghost, cost: best, iterations, evaluations: cost.evaluations }
}

/// A first guess from the image's moments (Walch sets the first sample's start by hand): the
/// light-weighted centre, the extent from the second moments (a uniform disc of radius r has
/// sigma = r / 2 on each axis), round sides, the brightest pixel on the border and the mean
/// light inside.
pub fn moments_guess(image: &GreyImage) -> Option<BezierGhost> {
    let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
    let mut peak = 0.0f64;
    for y in 0..image.height {
        for x in 0..image.width {
            let v = image.values[(y * image.width + x) as usize].max(0.0);
            let (px, py) = image.centre_of(x, y);
            s += v;
            sx += v * px;
            sy += v * py;
            peak = peak.max(v);
        }
    }
    if s <= 0.0 || !s.is_finite() {
        return None;
    }
    let c = [sx / s, sy / s];
    let (mut vx, mut vy) = (0.0, 0.0);
    for y in 0..image.height {
        for x in 0..image.width {
            let v = image.values[(y * image.width + x) as usize].max(0.0);
            let (px, py) = image.centre_of(x, y);
            vx += v * (px - c[0]) * (px - c[0]);
            vy += v * (py - c[1]) * (py - c[1]);
        }
    }
    let (rx, ry) = (2.0 * (vx / s).sqrt(), 2.0 * (vy / s).sqrt());
    let size = rx.max(ry).max(1.0);
    Some(BezierGhost {
        centre_px: c,
        height_px: ry.max(0.5),
        left_px: rx.max(0.5),
        right_px: rx.max(0.5),
        left_control: CIRCLE_CONTROL,
        right_control: CIRCLE_CONTROL,
        transfer: Transfer {
            border: peak,
            inner: 0.5 * peak,
            inner_falloff_px: 0.2 * size,
            outer_falloff_px: 0.1 * size,
            inner_exponent: 1.0,
            outer_exponent: 1.0,
        },
    })
}

/// A fit whose primitive draws its image's light this far off (|drawn / image - 1|) is
/// started again ([`fit_restarted`]): issue 32's goal for the worst angle of a ghost.
pub const RESTART_ENERGY_ERROR: f64 = 0.05;

/// |drawn / held - 1| of the light of `ghost` drawn on `image`'s cells; 0 for a black image.
pub fn energy_error(image: &GreyImage, ghost: &BezierGhost) -> f64 {
    let held: f64 = image.values.iter().sum();
    let drawn: f64 = image.draw(ghost).iter().sum();
    if held > 0.0 && drawn.is_finite() {
        (drawn / held - 1.0).abs()
    } else {
        0.0
    }
}

/// Starts for a fit that failed, none of them from the neighbours: the image's moments, the
/// same at 0.7 and 1.5 times the size (a ring's moments lie inside it, a peaked ghost's
/// outside its bright core), the box of the cells brighter than 5% of the peak (the light's
/// hull) with the mean light in it, and each of those with its lights scaled so that it draws
/// the image's light (eq 6.4 is linear in I_b and I_i together).
pub fn restart_starts(image: &GreyImage) -> Vec<BezierGhost> {
    let Some(moments) = moments_guess(image) else { return Vec::new() };
    let scaled = |k: f64| BezierGhost {
        height_px: k * moments.height_px,
        left_px: k * moments.left_px,
        right_px: k * moments.right_px,
        ..moments
    };
    let peak = image.values.iter().copied().fold(0.0, f64::max);
    let (mut lo, mut hi, mut sum, mut n) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2], 0.0, 0.0);
    for y in 0..image.height {
        for x in 0..image.width {
            let v = image.values[(y * image.width + x) as usize];
            if v > 0.05 * peak {
                let (px, py) = image.centre_of(x, y);
                (lo, hi) = ([lo[0].min(px), lo[1].min(py)], [hi[0].max(px), hi[1].max(py)]);
                (sum, n) = (sum + v, n + 1.0);
            }
        }
    }
    let half = [0.5 * (hi[0] - lo[0] + image.cell_px), 0.5 * (hi[1] - lo[1] + image.cell_px)];
    let hull = BezierGhost {
        centre_px: [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])],
        height_px: half[1],
        left_px: half[0],
        right_px: half[0],
        transfer: Transfer { border: sum / n, inner: sum / n, ..moments.transfer },
        ..moments
    };
    let plain = [moments, scaled(0.7), scaled(1.5), hull];
    let mut starts = plain.to_vec();
    starts.extend(plain.iter().filter_map(|g| with_image_energy(image, g)));
    starts
}

/// `ghost` with I_b and I_i scaled together so that it draws the light `image` holds (eq 6.4
/// is linear in them); None where it draws none or the image holds none.
pub fn with_image_energy(image: &GreyImage, ghost: &BezierGhost) -> Option<BezierGhost> {
    let held: f64 = image.values.iter().sum();
    let drawn: f64 = image.draw(ghost).iter().sum();
    if !(held > 0.0 && drawn > 0.0 && (held / drawn).is_finite()) {
        return None;
    }
    let k = held / drawn;
    let t = ghost.transfer;
    Some(BezierGhost { transfer: Transfer { border: k * t.border, inner: k * t.inner, ..t }, ..*ghost })
}

/// Sec. 7.2's descent from `start`; where its primitive ends drawing the image's light more
/// than [`RESTART_ENERGY_ERROR`] off (a start that missed the light, or caught only part of
/// it, or a descent that dimmed the primitive to nothing), again from each of the image's own
/// four [`restart_starts`], then (while none is within the tolerance) from the first fit and
/// the four with their lights scaled to the image's light. The fit kept is the
/// one of least cost among those within [`RESTART_ENERGY_ERROR`] in energy, or, if none is,
/// of least cost overall (a fit off by more than that has failed, whatever its cost: the cost
/// of a sparse or noisy image can favour drawing nothing).
pub fn fit_restarted(image: &GreyImage, start: &BezierGhost, options: &FitOptions) -> Fit {
    let first = fit(image, start, options);
    let first_error = energy_error(image, &first.ghost);
    if first_error <= RESTART_ENERGY_ERROR {
        return first;
    }
    let mut starts = restart_starts(image);
    let plain = starts.len().min(4);
    starts.insert(plain, with_image_energy(image, &first.ghost).unwrap_or(first.ghost));
    let rank = |f: &Fit, e: f64| (e > RESTART_ENERGY_ERROR, f.cost);
    let mut best = (first, first_error);
    for (i, s) in starts.iter().enumerate() {
        let f = fit(image, s, options);
        let e = energy_error(image, &f.ghost);
        let (r, b) = (rank(&f, e), rank(&best.0, best.1));
        if r.0 < b.0 || (r.0 == b.0 && r.1 < b.1) {
            best = (f, e);
        }
        // The image's own four starts are all tried; the scaled ones only while no fit lies
        // within the tolerance (they are for fits that still miss).
        if i + 1 >= plain && best.1 <= RESTART_ENERGY_ERROR {
            break;
        }
    }
    best.0
}

/// Sec. 7.3: the samples (angle, image) fitted in order, each started from the least-squares
/// polynomial (order at most `order`) of the samples fitted before it, evaluated at its angle
/// (or from the last fit or the image's moments, whichever costs least); the first from
/// `first` (or its moments); a fit far off in energy restarted ([`fit_restarted`]).
pub fn fit_range(
    samples: &[(f64, GreyImage)],
    first: Option<BezierGhost>,
    order: usize,
    options: &FitOptions,
) -> Vec<Fit> {
    let mut fits: Vec<Fit> = Vec::new();
    for (angle, image) in samples {
        let start = if fits.is_empty() {
            first.or_else(|| moments_guess(image))
        } else {
            // Sec. 7.3's seed; where the neighbours' polynomial strays (fits of a ghost larger
            // than the frame trade its centre against its reach), the last fit or the image's
            // moments may start closer: the cheapest of the three.
            let angles: Vec<f64> = samples[..fits.len()].iter().map(|s| s.0).collect();
            let ghosts: Vec<BezierGhost> = fits.iter().map(|f| f.ghost).collect();
            let mut starts = vec![seed(&angles, &ghosts, *angle, order), ghosts[ghosts.len() - 1]];
            starts.extend(moments_guess(image));
            cheapest_start(image, &starts)
        };
        let Some(start) = start else { break };
        fits.push(fit_restarted(image, &start, options));
    }
    fits
}

/// Sec. 7.3's start for the sample at `angle`: each parameter's least-squares polynomial of
/// order at most `order` through the samples fitted so far (one: a constant, two: a line),
/// extrapolated to it.
pub fn seed(angles: &[f64], fitted: &[BezierGhost], angle: f64, order: usize) -> BezierGhost {
    let params: Vec<[f64; PARAMS]> = fitted.iter().map(BezierGhost::to_params).collect();
    let mut p = [0.0; PARAMS];
    for (k, v) in p.iter_mut().enumerate() {
        let ys: Vec<f64> = params.iter().map(|q| q[k]).collect();
        *v = poly_eval(&polyfit(angles, &ys, order), angle);
    }
    BezierGhost::from_params(&p)
}

/// What [`fit_traced_ghosts`] fits: each ghost (all of the lens's when `ghosts` is empty) in
/// each channel, traced at each angle (light towards +x of the centre, as `[[fitted_ghost]]`
/// has it) on a `width` x `height` frame.
#[derive(Clone, Debug)]
pub struct TracedFitOptions {
    pub width: u32,
    pub height: u32,
    pub angles_deg: Vec<f64>,
    pub rays_across: usize,
    /// Cells across a traced image at most (a larger ghost is fitted on coarser cells).
    pub max_cells: u32,
    /// The polynomials' order (ch. 8).
    pub order: usize,
    pub channels: Vec<usize>,
    /// Ghosts as (first, second) reflecting surfaces; empty: every ghost of the catalogue.
    pub ghosts: Vec<(usize, usize)>,
    pub fit: FitOptions,
}

impl TracedFitOptions {
    /// Every ghost in every channel at `angles_deg` on a `width` x `height` frame, with
    /// `realcam flare-fit`'s defaults: 32 rays across, at most 24 cells, parabolas.
    pub fn new(width: u32, height: u32, angles_deg: Vec<f64>) -> TracedFitOptions {
        TracedFitOptions {
            width,
            height,
            angles_deg,
            rays_across: 32,
            max_cells: 24,
            order: 2,
            channels: vec![0, 1, 2],
            ghosts: Vec::new(),
            fit: FitOptions::default(),
        }
    }
}

/// One ghost in one channel fitted over the angles, and how far its polynomials' primitive
/// is from the traced images (the worst sample): RMS difference over the traced peak, the
/// relative energy error, the centroid's distance (frame px).
#[derive(Clone, Debug, PartialEq)]
pub struct FittedRange {
    pub spec: FittedGhostSpec,
    pub samples: usize,
    pub worst_rmse_over_peak: f64,
    pub worst_energy_error: f64,
    pub worst_centroid_px: f64,
    /// The same two of each sample's own fit (before the polynomials): what ch. 7 reaches, and
    /// by its difference what ch. 8's polynomials lose.
    pub worst_fit_rmse_over_peak: f64,
    pub worst_fit_energy_error: f64,
    /// The angles (degrees) whose sample's own fit draws its light within
    /// [`RESTART_ENERGY_ERROR`] but the polynomials do not ([`missed_angles`]): where the
    /// polynomials cannot represent the fits; empty when they can.
    pub missed_angles_deg: Vec<f64>,
}

impl FittedRange {
    /// What to tell the user where the polynomials cannot represent the fits: the ghost, its
    /// channel and the angles; None where they can.
    pub fn warning(&self) -> Option<String> {
        (!self.missed_angles_deg.is_empty()).then(|| {
            format!(
                "ghost {} channel {}: the polynomials draw the light more than {}% off at {:?} degrees, where the angle's own fit draws it within that; fit fewer angles at a time or a higher --order",
                self.spec.ghost,
                self.spec.channel,
                100.0 * RESTART_ENERGY_ERROR,
                self.missed_angles_deg
            )
        })
    }
}

/// The traced images' margin around the ghost's rays, a share of their box's larger side: room
/// for the outer fade (at most [`MAX_OUTER_FADE`] of the primitive's size, an eighth of the
/// ghost's width).
pub const MARGIN: f64 = 0.2;

/// The primitive's outer fade range F_o at most, a share of its largest half-size.
pub const MAX_OUTER_FADE: f64 = 0.25;

/// Energy (per unit of the light's own image) and centroid (frame px) of an image of light per
/// frame pixel on `grid`'s cells.
fn energy_centroid(grid: &GreyImage, v: &[f64]) -> (f64, [f64; 2]) {
    let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for y in 0..grid.height {
        for x in 0..grid.width {
            let (px, py) = grid.centre_of(x, y);
            let e = v[(y * grid.width + x) as usize];
            (s, sx, sy) = (s + e, sx + e * px, sy + e * py);
        }
    }
    (s * grid.cell_px * grid.cell_px, [sx / s, sy / s])
}

/// The closed loop with no camera (issue 14): the lens's ghosts traced with real rays over a
/// range of angles, each fitted (ch. 7, sec. 7.3's seeding) and made polynomials of the angle
/// (ch. 8), with each polynomial primitive's error against the traced images. A ghost with
/// fewer traced samples than the order needs is left out. `progress` hears each ghost.
pub fn fit_traced_ghosts(
    camera: &crate::model::camera::Camera,
    options: &TracedFitOptions,
    mut progress: impl FnMut(&str),
) -> Vec<FittedRange> {
    use crate::passes::flare::FlareModel;
    use crate::tools::accuracy_flare::Sensor;
    let (w, h) = (options.width, options.height);
    let sensor = Sensor { pixel_pitch_mm: camera.pixel_pitch_mm(w, h), centre_px: [w as f64 / 2.0, h as f64 / 2.0] };
    let model = FlareModel::new(camera, sensor.pixel_pitch_mm, sensor.centre_px);
    let (Some(lens), Some(catalogue)) = (model.lens.as_ref(), model.catalogue.as_ref()) else { return Vec::new() };
    let mut angles = options.angles_deg.clone();
    angles.sort_by(f64::total_cmp);
    let mut out = Vec::new();
    for g in &catalogue.ghosts {
        let path = g.path;
        if !options.ghosts.is_empty() && !options.ghosts.contains(&(path.first, path.second)) {
            continue;
        }
        let label = format!("{}/{}", path.first, path.second);
        for &c in &options.channels {
            progress(&format!("ghost {label} channel {c}"));
            let samples: Vec<(f64, GreyImage)> = angles
                .iter()
                .filter_map(|&a| {
                    let u = [a.to_radians().tan(), 0.0];
                    traced_ghost_image(lens, path, u, c, options.rays_across, sensor, MARGIN, options.max_cells)
                        .map(|im| (a, im))
                })
                .collect();
            if samples.len() <= options.order {
                continue;
            }
            let fits = fit_range(&samples, None, options.order, &options.fit);
            if fits.len() <= options.order {
                continue;
            }
            out.push(fitted_range(&samples, fits, &label, c, [w, h], options.order, &options.fit));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::bezier_ghost::GhostPolynomials;
    use crate::{optics::flare::ghosts::GhostPath, passes::flare::FlareModel, tools::accuracy_flare::Sensor};

    /// The Tessar at f/2.8 on a 320x180 frame (the flare bench's camera), its sensor (the
    /// frame's centre), and its ghost 4/0: the fits' tests trace it.
    pub(super) fn tessar_320x180_ghost_4_0() -> (FlareModel, Sensor, GhostPath) {
        let camera = crate::tools::bench_flare::flare_camera(320, 180);
        let sensor = Sensor { pixel_pitch_mm: camera.pixel_pitch_mm(320, 180), centre_px: [160.0, 90.0] };
        let model = FlareModel::new(&camera, sensor.pixel_pitch_mm, sensor.centre_px);
        let catalogue = model.catalogue.as_ref().expect("the Tessar's ghosts");
        let path = catalogue.ghosts.iter().map(|g| g.path).find(|p| (p.first, p.second) == (4, 0)).expect("ghost 4/0");
        (model, sensor, path)
    }

    fn truth() -> BezierGhost {
        BezierGhost {
            centre_px: [131.4, 88.2],
            height_px: 11.0,
            left_px: 8.0,
            right_px: 13.0,
            left_control: 0.45,
            right_control: 0.7,
            transfer: Transfer {
                border: 4.0,
                inner: 1.5,
                inner_falloff_px: 5.0,
                outer_falloff_px: 3.0,
                inner_exponent: 1.5,
                outer_exponent: 0.8,
            },
        }
    }

    fn image_of(g: &BezierGhost) -> GreyImage {
        let mut image = GreyImage { width: 44, height: 40, origin_px: [112.0, 68.0], cell_px: 1.0, values: Vec::new() };
        image.values = image.draw(g);
        image
    }

    #[test]
    fn fitting_recovers_known_parameters_within_2_percent_from_a_perturbed_start() {
        let g = truth();
        let image = image_of(&g);
        let p = g.to_params();
        // Every parameter off by 6-12% (of its value; positions by 2 px, 15% of the width).
        let signs = [1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 1.0, -1.0, 1.0, 1.0, -1.0, 1.0, -1.0];
        let mut start = p;
        for k in 0..PARAMS {
            start[k] = if k < 2 { p[k] + 2.0 * signs[k] } else { p[k] * (1.0 + signs[k] * (0.06 + 0.005 * k as f64)) };
        }
        let fitted = fit(&image, &BezierGhost::from_params(&start), &FitOptions::default());
        let q = fitted.ghost.to_params();
        for k in 0..PARAMS {
            let scale = if k < 2 { 13.0 } else { p[k].abs() };
            let err = (q[k] - p[k]).abs() / scale;
            assert!(
                err < 0.02,
                "{}: fitted {} against {} ({:.2}%), cost {}, {} iterations",
                crate::optics::bezier_ghost::PARAM_NAMES[k],
                q[k],
                p[k],
                100.0 * err,
                fitted.cost,
                fitted.iterations
            );
        }
    }

    #[test]
    fn a_fit_whose_start_misses_the_light_is_restarted_and_recovers_it() {
        // The start sits in the image's dark corner, 20 px from the ghost, a third its size:
        // sec. 7.2's descent alone dims it to nothing (no step of it sees the light) and ends
        // drawing almost none of the image's light; restarted from the image's own starts it
        // draws the light within 1% and puts the centre within 0.5 px.
        let g = truth();
        let image = image_of(&g);
        let start = BezierGhost {
            centre_px: [118.0, 74.0],
            height_px: 3.0,
            left_px: 3.0,
            right_px: 3.0,
            transfer: Transfer { inner_falloff_px: 1.0, outer_falloff_px: 0.5, ..g.transfer },
            ..g
        };
        let options = FitOptions::default();
        let alone = fit(&image, &start, &options);
        assert!(energy_error(&image, &alone.ghost) > 0.9, "{:?}", alone.ghost);
        let fitted = fit_restarted(&image, &start, &options);
        let (e, moved) = (
            energy_error(&image, &fitted.ghost),
            (fitted.ghost.centre_px[0] - g.centre_px[0]).hypot(fitted.ghost.centre_px[1] - g.centre_px[1]),
        );
        assert!(e < 0.01 && moved < 0.5 && fitted.cost < alone.cost, "energy {e:.4}, centre {moved:.3} px: {fitted:?}");
    }

    #[test]
    fn relight_gives_the_lights_of_images_drawn_with_the_polynomials_shapes() {
        // Three samples of the same shape whose I_b and I_i drift linearly with the angle; the
        // polynomials carry the shape and wrong lights (constant 1 and 1). Eq 6.4 is linear in
        // I_b and I_i, so the least-squares lights of each image are its own (then scaled to
        // its energy, already equal), and the lines through them give every sample back.
        let g = truth();
        let lights = |a: f64| (4.0 + 0.5 * a, 1.5 - 0.25 * a);
        let samples: Vec<(f64, GreyImage)> = [1.0, 2.0, 3.0]
            .iter()
            .map(|&a| {
                let (border, inner) = lights(a);
                (a, image_of(&BezierGhost { transfer: Transfer { border, inner, ..g.transfer }, ..g }))
            })
            .collect();
        let wrong = BezierGhost { transfer: Transfer { border: 1.0, inner: 1.0, ..g.transfer }, ..g };
        let poly = GhostPolynomials::fit(&[1.0, 2.0, 3.0], &[wrong; 3], 2);
        let relit = relight(&samples, &poly, 2);
        for a in [1.0, 2.0, 2.5, 3.0] {
            let (border, inner) = lights(a);
            let t = relit.at(a).transfer;
            assert!((t.border - border).abs() < 1e-4 && (t.inner - inner).abs() < 1e-4, "{a}: {t:?}");
        }
        assert!(worst_error(&samples, &relit) < 1e-4 && worst_error(&samples, &poly) > 0.3);
    }

    #[test]
    fn each_sample_starts_from_its_neighbours_polynomial() {
        // Sec. 7.3: after one sample a constant, after two a line, after three a parabola.
        let g = truth();
        let at = |x: f64| BezierGhost { centre_px: [x, 88.2], ..g };
        let one = seed(&[1.0], &[at(100.0)], 2.0, 2);
        assert!((one.centre_px[0] - 100.0).abs() < 1e-9);
        let two = seed(&[1.0, 2.0], &[at(100.0), at(104.0)], 3.0, 2);
        assert!((two.centre_px[0] - 108.0).abs() < 1e-9);
        // x = 100 + 3 (a - 1) + (a - 1)^2: 100, 104, 110 -> 118 at a = 4.
        let three = seed(&[1.0, 2.0, 3.0], &[at(100.0), at(104.0), at(110.0)], 4.0, 2);
        assert!((three.centre_px[0] - 118.0).abs() < 1e-9);
        assert!((three.height_px - g.height_px).abs() < 1e-9);
    }

    #[test]
    fn a_fitted_primitive_reproduces_a_traced_ghost_of_the_tessar() {
        // The closed loop with no camera: the Tessar at f/2.8 on a 320x180 frame, a light 4
        // degrees off the axis, ghost 4/0 in green traced with real rays (96 across the front
        // lens per wavelength to start with, more where they land over half a cell apart: the
        // reference), binned into 40x40 cells of 28 px (the ghost is about 780 px wide, the
        // image 20% wider on each side), fitted from its moments. The
        // primitive keeps the energy within 1% (measured 0.04%) and the centroid within a cell
        // (13 px); its RMS difference is under 15% of the traced peak (the rays' binning noise
        // is most of it: 0.122 measured).
        use crate::tools::accuracy_flare::light_slope;
        let (w, h) = (320, 180);
        let (model, sensor, path) = tessar_320x180_ghost_4_0();
        let lens = model.lens.as_ref().unwrap();
        let image = traced_ghost_image(lens, path, light_slope(4.0, w, h), 1, 96, sensor, MARGIN, 40).unwrap();
        assert_eq!((image.width, image.height, image.cell_px), (40, 40, 28.0), "{:?}", image.origin_px);
        let f = fit(&image, &moments_guess(&image).unwrap(), &FitOptions::default());
        let drawn = image.draw(&f.ghost);
        let ((e_t, c_t), (e_f, c_f)) = (energy_centroid(&image, &image.values), energy_centroid(&image, &drawn));
        let peak = image.values.iter().copied().fold(0.0, f64::max);
        let rmse = mse(&drawn, &image.values).sqrt() / peak;
        let moved = (c_t[0] - c_f[0]).hypot(c_t[1] - c_f[1]);
        let summary = format!("energy {:+.4}, centroid {moved:.2} px, rmse/peak {rmse:.3}", e_f / e_t - 1.0);
        assert!((e_f / e_t - 1.0).abs() < 0.01 && moved < 27.0 && rmse < 0.15, "{summary}");
    }

    #[test]
    fn the_traced_ghosts_of_a_range_become_a_lens_file_section_that_round_trips() {
        // The tiny case of `realcam flare-fit`: the Tessar's ghost 4/0 in green on a 320x180
        // frame at 2..5 degrees (48 rays across per wavelength, at most 24 cells across: cells of
        // 45 px), fitted and made polynomials of the angle (src/tools/flare_fit/polynomial.rs:
        // the fade kept within the ghost's size, the lights fitted jointly, samples refitted
        // near the polynomials). Each sample's own fit keeps its energy within 1% (measured
        // 0.72%), RMS over the traced peak under 0.15 (0.071: mostly the rays' binning noise);
        // the polynomials lose little more: energy within 2% (0.19%), RMS 0.15 (0.072),
        // centroid within a cell (14 px).
        use crate::io::lens_file::{LensFile, LensFileWriter};
        let camera = crate::tools::bench_flare::flare_camera(320, 180);
        let options = TracedFitOptions {
            rays_across: 48,
            channels: vec![1],
            ghosts: vec![(4, 0)],
            ..TracedFitOptions::new(320, 180, vec![5.0, 2.0, 3.0, 4.0])
        };
        let mut heard = Vec::new();
        let fitted = fit_traced_ghosts(&camera, &options, |m| heard.push(m.to_string()));
        assert_eq!(heard, ["ghost 4/0 channel 1"]);
        assert_eq!(fitted.len(), 1);
        let f = &fitted[0];
        let summary = format!(
            "fits: rmse/peak {:.3}, energy {:.4}; polynomials: rmse/peak {:.3}, energy {:.4}, centroid {:.2} px",
            f.worst_fit_rmse_over_peak,
            f.worst_fit_energy_error,
            f.worst_rmse_over_peak,
            f.worst_energy_error,
            f.worst_centroid_px
        );
        assert_eq!((f.samples, f.spec.angles_deg, f.spec.frame_px, f.spec.channel), (4, [2.0, 5.0], [320, 180], 1));
        assert!(f.worst_fit_rmse_over_peak < 0.15 && f.worst_fit_energy_error < 0.01, "{summary}");
        assert!(
            f.worst_rmse_over_peak < 0.15 && f.worst_energy_error < 0.02 && f.worst_centroid_px < 45.0,
            "{summary}"
        );
        let tessar = include_str!("../../lenses/tessar-walch-lens.toml");
        let mut w = LensFileWriter::edit(tessar).unwrap();
        w.fitted_ghosts(std::slice::from_ref(&f.spec), None);
        let lens = LensFile::parse(&w.finish(), std::path::Path::new("fitted.toml")).unwrap();
        assert_eq!(lens.fitted_ghosts, std::slice::from_ref(&f.spec));
    }

    #[test]
    fn a_ghost_that_magnifies_the_pupil_is_traced_with_more_rays_and_fits_its_light() {
        // Issue 32 item 3: the Tessar's 6/1 at f/2.8 in green spreads 32 rays across the front
        // lens about 3.5 cells apart (a ghost twice the frame's width), a lattice of dots that
        // the descent and its restarts all fit by dimming the primitive to nothing (96-100% of
        // the light missing at the worst angle of `realcam flare-fit`'s full run). Traced with
        // rays half a cell apart it is a lit disc, and every sample's fit draws its light within
        // 5%. Small: a 320x180 frame, 16 cells across, three angles.
        let camera = crate::tools::bench_flare::flare_camera(320, 180);
        let options = TracedFitOptions {
            max_cells: 16,
            channels: vec![1],
            ghosts: vec![(6, 1)],
            ..TracedFitOptions::new(320, 180, vec![0.0, 6.0, 12.0])
        };
        let fitted = fit_traced_ghosts(&camera, &options, |_| {});
        assert_eq!(fitted.len(), 1);
        let f = &fitted[0];
        assert_eq!(f.samples, 3);
        assert!(
            f.worst_fit_energy_error < RESTART_ENERGY_ERROR,
            "worst fit energy error {:.4}",
            f.worst_fit_energy_error
        );
    }

    #[test]
    fn the_ray_spacing_of_a_lattice_of_hits_is_its_pitch() {
        // Rays on a square grid of pitch 7 px inside a disc of radius 200 px, three
        // wavelengths landing on the same points: the spacing is the pitch within 2% (the
        // disc's edge cells), and a lattice three times coarser reads three times as far apart.
        let lattice = |pitch: f64| {
            let mut hits = Vec::new();
            let n = (200.0 / pitch) as i64;
            for i in -n..=n {
                for j in -n..=n {
                    let p = [500.0 + i as f64 * pitch, 300.0 + j as f64 * pitch];
                    if (p[0] - 500.0).hypot(p[1] - 300.0) <= 200.0 {
                        hits.extend([(p, 1.0); 3]);
                    }
                }
            }
            hits
        };
        let fine = ray_spacing_px(&lattice(7.0), 3);
        assert!((fine / 7.0 - 1.0).abs() < 0.02, "{fine}");
        let coarse = ray_spacing_px(&lattice(21.0), 3);
        assert!((coarse / fine / 3.0 - 1.0).abs() < 0.05, "{coarse} vs {fine}");
    }

    #[test]
    fn the_cost_is_zero_at_the_truth_and_the_edge_term_sees_a_shifted_border() {
        let g = truth();
        let image = image_of(&g);
        let mut cost = Cost::new(&image);
        assert_eq!(cost.of(&g), 0.0);
        let moved = BezierGhost { centre_px: [g.centre_px[0] + 1.0, g.centre_px[1]], ..g };
        let drawn = image.draw(&moved);
        let plain = mse(&drawn, &image.values);
        assert!(cost.of(&moved) > plain && plain > 0.0);
    }
}
