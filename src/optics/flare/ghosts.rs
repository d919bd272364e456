//! Ghosts by ray-transfer matrices (Walch 2017 sec. 3.2.1 and 4.2.1; the flare matrices of Lee
//! & Eisemann 2013): light reflected first at a surface i, back towards the front, and again at
//! a surface j < i, towards the sensor. Only even numbers of reflections reach the sensor and
//! each reflection costs most of the light, so the paths with two reflections are the ghosts
//! that matter; a lens of N reflecting surfaces has N (N - 1) / 2 of them (Walch eq. 3.3,
//! R = M (2M - 1) for N = 2M surfaces).
//!
//! A path is a list of [`Event`]s; its matrix maps the ray (height y, slope u) on the entrance
//! plane (the first vertex) to each surface it crosses and to the sensor. The slope u is taken
//! along the direction of travel, so after a reflection the ray runs backwards with positive
//! translations, and a surface met from behind is the same surface with its curvature c
//! negated. Refraction from n1 into n2 is [[1, 0], [(n1 - n2) c / n2, n1 / n2]] (Walch 4.2.1);
//! a reflection off a surface met from the front is [[1, 0], [2c, 1]] (a concave mirror,
//! c < 0, focuses at -1/(2c)), and off one met from behind [[1, 0], [-2c, 1]].
//!
//! For a light in direction u every entrance point p (2D) lands on the sensor at A p + B u and
//! crosses surface m at a_m p + b_m u. So the points that get through the aperture are the
//! aperture polygon seen through 1/a_stop, centred on -b_stop u / a_stop, and the ghost is that
//! region mapped by A: its centre is (B - A b_stop / a_stop) u, its radius |A| r_stop / |a_stop|,
//! its light uniform (the map is linear), each entrance area element spread over A^2 times
//! its area. Every other surface the path crosses limits p to a disk of radius sd_m / |a_m|
//! centred on -b_m u / a_m: the vignetting, which moves against the aperture as the light moves
//! off-axis.

use super::{disk_overlap_area, FlareLens, BANDS_NM, BAND_WEIGHTS};
use crate::optics::prescription::RayMatrix;

/// What the light does at one surface along a path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// Refracted through surface `surface`, travelling towards the sensor (`forward`) or back.
    Transmit { surface: usize, forward: bool },
    /// Reflected at `surface`, met from its front (turning back) or from behind (turning
    /// towards the sensor again).
    Reflect { surface: usize, from_front: bool },
}

impl Event {
    pub fn surface(&self) -> usize {
        match *self {
            Event::Transmit { surface, .. } | Event::Reflect { surface, .. } => surface,
        }
    }
}

/// A ghost: reflected first at surface `first`, then at the earlier surface `second`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct GhostPath {
    pub first: usize,
    pub second: usize,
}

impl GhostPath {
    /// The events from the front surface to the last one, `n` surfaces in all.
    pub fn events(&self, n: usize) -> Vec<Event> {
        let (i, j) = (self.first, self.second);
        let mut events: Vec<Event> = (0..i).map(|k| Event::Transmit { surface: k, forward: true }).collect();
        events.push(Event::Reflect { surface: i, from_front: true });
        events.extend((j + 1..i).rev().map(|k| Event::Transmit { surface: k, forward: false }));
        events.push(Event::Reflect { surface: j, from_front: false });
        events.extend((j + 1..n).map(|k| Event::Transmit { surface: k, forward: true }));
        events
    }
}

/// The image-forming path: every surface crossed once, towards the sensor.
pub fn direct_events(n: usize) -> Vec<Event> {
    (0..n).map(|k| Event::Transmit { surface: k, forward: true }).collect()
}

/// Every two-reflection path of the lens: each pair j < i of reflecting surfaces.
pub fn ghost_paths(lens: &FlareLens) -> Vec<GhostPath> {
    let reflecting: Vec<usize> = (0..lens.prescription.surfaces.len()).filter(|&k| lens.reflects(k)).collect();
    let mut paths = Vec::new();
    for (a, &i) in reflecting.iter().enumerate() {
        for &j in &reflecting[..a] {
            paths.push(GhostPath { first: i, second: j });
        }
    }
    paths
}

/// Where a path crosses a surface: its paraxial height there is `a y + b u` for the entrance
/// height y and slope u.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    pub surface: usize,
    pub a: f64,
    pub b: f64,
}

/// The paraxial form of a path at one wavelength.
#[derive(Clone, Debug, PartialEq)]
pub struct PathMatrix {
    /// Every surface crossing, in order.
    pub crossings: Vec<Crossing>,
    /// Entrance plane to sensor.
    pub sensor: RayMatrix,
}

/// The matrix of one event: the refraction or reflection at its surface.
fn event_matrix(lens: &FlareLens, event: Event, lambda_nm: f64) -> RayMatrix {
    let k = event.surface();
    let c = lens.prescription.surfaces[k].curvature_per_mm();
    let (before, after) = lens.media(k, lambda_nm);
    match event {
        Event::Transmit { forward: true, .. } => RayMatrix::refraction(c, before, after),
        // Met from behind: the surface with its curvature negated, from `after` into `before`.
        Event::Transmit { forward: false, .. } => RayMatrix::refraction(-c, after, before),
        Event::Reflect { from_front: true, .. } => RayMatrix { a: 1.0, b: 0.0, c: 2.0 * c, d: 1.0 },
        Event::Reflect { from_front: false, .. } => RayMatrix { a: 1.0, b: 0.0, c: -2.0 * c, d: 1.0 },
    }
}

/// Distance from event `e`'s surface to the next event's (or to the sensor after the last).
fn step_after(lens: &FlareLens, zs: &[f64], events: &[Event], e: usize) -> f64 {
    let next_z = events.get(e + 1).map_or(lens.image_z_mm, |n| zs[n.surface()]);
    (next_z - zs[events[e].surface()]).abs()
}

/// The matrices of the path `events` at `lambda_nm`.
pub fn path_matrix(lens: &FlareLens, events: &[Event], lambda_nm: f64) -> PathMatrix {
    let zs = lens.prescription.vertex_z_mm();
    let mut m = RayMatrix::IDENTITY;
    let mut crossings = Vec::with_capacity(events.len());
    for (e, &event) in events.iter().enumerate() {
        crossings.push(Crossing { surface: event.surface(), a: m.a, b: m.b });
        m = event_matrix(lens, event, lambda_nm).after(&m);
        m = RayMatrix::translation(step_after(lens, &zs, events, e)).after(&m);
    }
    PathMatrix { crossings, sensor: m }
}

/// The share of the light of the ray entering parallel to the axis at height `y_mm` that
/// follows `events` to the sensor: every surface's reflectance or transmittance at the ray's
/// paraxial angle of incidence there, i = u + y c (c negated for a surface met from behind).
pub fn ray_throughput(lens: &FlareLens, events: &[Event], y_mm: f64, lambda_nm: f64) -> f64 {
    let zs = lens.prescription.vertex_z_mm();
    let (mut y, mut u) = (y_mm, 0.0);
    let mut share = 1.0;
    for (e, &event) in events.iter().enumerate() {
        let k = event.surface();
        let c = lens.prescription.surfaces[k].curvature_per_mm();
        let arriving_forward = match event {
            Event::Transmit { forward, .. } => forward,
            Event::Reflect { from_front, .. } => from_front,
        };
        // Paraxial angles beyond a right angle mean nothing: grazing at most.
        let angle = (u + y * if arriving_forward { c } else { -c }).abs().min(0.5 * std::f64::consts::PI);
        let cos_in = angle.cos();
        share *= match event {
            Event::Transmit { forward, .. } => 1.0 - lens.reflectance(k, forward, cos_in, lambda_nm),
            Event::Reflect { from_front, .. } => lens.reflectance(k, from_front, cos_in, lambda_nm),
        };
        (y, u) = event_matrix(lens, event, lambda_nm).apply(y, u);
        (y, u) = RayMatrix::translation(step_after(lens, &zs, events, e)).apply(y, u);
    }
    share
}

/// [`ray_throughput`] averaged over the disk of radius `radius_mm` on the entrance plane
/// (Gauss-Legendre in the squared radius, so that every area element counts the same).
fn disk_throughput(lens: &FlareLens, events: &[Event], radius_mm: f64, lambda_nm: f64) -> f64 {
    // 4-point Gauss-Legendre on [0, 1].
    const NODES: [f64; 4] =
        [0.069_431_844_202_973_7, 0.330_009_478_207_571_9, 0.669_990_521_792_428_1, 0.930_568_155_797_026_3];
    const WEIGHTS: [f64; 4] =
        [0.173_927_422_568_726_9, 0.326_072_577_431_273_1, 0.326_072_577_431_273_1, 0.173_927_422_568_726_9];
    NODES.iter().zip(WEIGHTS).map(|(&s, w)| w * ray_throughput(lens, events, radius_mm * s.sqrt(), lambda_nm)).sum()
}

/// A surface the path crosses, as a limit on the entrance plane: a disk whose centre lies
/// `offset_mm` x u from the aperture's centre, of radius `radius_mm`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clip {
    pub surface: usize,
    pub offset_mm: f64,
    pub radius_mm: f64,
}

/// One ghost in one colour channel.
#[derive(Clone, Debug, PartialEq)]
pub struct GhostChannel {
    pub lambda_nm: f64,
    /// Entrance plane to sensor: the sensor height is A p + B u.
    pub sensor: RayMatrix,
    /// The ghost's centre on the sensor per unit slope u: B - A b_stop / a_stop (mm).
    pub centre_mm: f64,
    /// Radius of the entrance-plane region the aperture lets through: r_stop / |a_stop| (mm).
    pub aperture_radius_mm: f64,
    /// The event at which the path crosses the stop as the aperture (the crossing that lets
    /// the least through).
    pub aperture_crossing: usize,
    /// +1: the aperture's image appears as the bokeh behind the focus plane does (upright); -1
    /// turned by 180 degrees. -sign(A a_stop): the sensor image is shown turned.
    pub flip: f64,
    /// The other surfaces' limits (and the stop's other crossings, as circles through its
    /// corners).
    pub clips: Vec<Clip>,
    /// Energy of the unvignetted ghost per energy of the light's own image: R_i R_j times the
    /// transmissions along the path over those of the direct path (each at the paraxial angle
    /// of incidence, averaged over the entrance area of an axial light and over the channel's
    /// band), times the area the aperture lets through over the entrance pupil's.
    pub energy_ratio: f64,
}

/// A ghost: its path and its three channels (red, green, blue).
#[derive(Clone, Debug, PartialEq)]
pub struct MatrixGhost {
    pub path: GhostPath,
    pub channels: [GhostChannel; 3],
}

/// The light's own image, per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectImage {
    /// Image height per unit slope (the chief ray's), mm: G0.
    pub centre_mm: [f64; 3],
    /// Entrance pupil radius (the stop through the front group), mm.
    pub pupil_radius_mm: [f64; 3],
    /// Transmission of the direct path, band-averaged.
    pub transmission: [f64; 3],
}

/// Every ghost of a lens.
#[derive(Clone, Debug, PartialEq)]
pub struct GhostCatalogue {
    pub direct: DirectImage,
    /// The ghosts above the energy cull, in path order.
    pub ghosts: Vec<MatrixGhost>,
    /// Two-reflection paths of the lens (N (N - 1) / 2 for N reflecting surfaces).
    pub paths: usize,
    /// Paths dropped for carrying less than the cull's share of the light (or for an
    /// aperture image of no size).
    pub culled: usize,
    /// Area of the aperture of circumradius 1 ([`super::AperturePolygon::area_factor`]).
    pub aperture_area_factor: f64,
}

impl GhostCatalogue {
    /// Every two-reflection path, keeping those whose unvignetted energy is at least
    /// `min_energy_ratio` of the light's in some channel.
    pub fn new(lens: &FlareLens, min_energy_ratio: f64) -> GhostCatalogue {
        let n = lens.prescription.surfaces.len();
        let stop = lens.prescription.stop_index();
        let r_stop = lens.stop_radius_mm();
        let direct_events = direct_events(n);
        let band_mean = |f: &dyn Fn(f64) -> f64, c: usize| -> f64 {
            BANDS_NM[c].iter().zip(BAND_WEIGHTS).map(|(&l, w)| w * f(l)).sum()
        };
        let mut direct = DirectImage { centre_mm: [0.0; 3], pupil_radius_mm: [0.0; 3], transmission: [0.0; 3] };
        for c in 0..3 {
            let m = path_matrix(lens, &direct_events, super::channel_nm(c));
            let s = m.crossings[stop];
            direct.centre_mm[c] = m.sensor.b - m.sensor.a * s.b / s.a;
            direct.pupil_radius_mm[c] = r_stop / s.a.abs();
            let pupil = direct.pupil_radius_mm[c];
            direct.transmission[c] = band_mean(&|l| disk_throughput(lens, &direct_events, pupil, l), c);
        }
        let paths = ghost_paths(lens);
        let mut ghosts = Vec::new();
        let mut culled = 0;
        for path in &paths {
            let events = path.events(n);
            let channels: Vec<Option<GhostChannel>> = (0..3)
                .map(|c| {
                    let lambda_nm = super::channel_nm(c);
                    let m = path_matrix(lens, &events, lambda_nm);
                    // The aperture: the stop crossing that lets the least through.
                    let (aperture_crossing, aperture) = m
                        .crossings
                        .iter()
                        .enumerate()
                        .filter(|(_, x)| x.surface == stop && x.a.abs() > 1e-12)
                        .max_by(|p, q| p.1.a.abs().total_cmp(&q.1.a.abs()))?;
                    let aperture_radius_mm = r_stop / aperture.a.abs();
                    let clips: Vec<Clip> = m
                        .crossings
                        .iter()
                        .filter(|x| !std::ptr::eq(*x, aperture) && x.a.abs() > 1e-12)
                        .map(|x| Clip {
                            surface: x.surface,
                            offset_mm: aperture.b / aperture.a - x.b / x.a,
                            radius_mm: lens.prescription.surfaces[x.surface].semi_diameter_mm / x.a.abs(),
                        })
                        .collect();
                    // Averaged over what an axial light lights: the aperture's region, within
                    // every surface's limit (all centred on the axis then).
                    let lit_mm = clips.iter().fold(aperture_radius_mm, |r: f64, c: &Clip| r.min(c.radius_mm));
                    let throughput = band_mean(&|l| disk_throughput(lens, &events, lit_mm, l), c);
                    let area = (aperture_radius_mm / direct.pupil_radius_mm[c]).powi(2);
                    Some(GhostChannel {
                        lambda_nm,
                        sensor: m.sensor,
                        centre_mm: m.sensor.b - m.sensor.a * aperture.b / aperture.a,
                        aperture_radius_mm,
                        aperture_crossing,
                        flip: if m.sensor.a * aperture.a > 0.0 { -1.0 } else { 1.0 },
                        clips,
                        energy_ratio: throughput / direct.transmission[c] * area,
                    })
                })
                .collect();
            let Some(channels) = channels.into_iter().collect::<Option<Vec<_>>>() else {
                culled += 1;
                continue;
            };
            if channels.iter().all(|c| c.energy_ratio.is_nan() || c.energy_ratio < min_energy_ratio) {
                culled += 1;
                continue;
            }
            let channels: [GhostChannel; 3] = match channels.try_into() {
                Ok(c) => c,
                Err(_) => continue,
            };
            ghosts.push(MatrixGhost { path: *path, channels });
        }
        GhostCatalogue { direct, ghosts, paths: paths.len(), culled, aperture_area_factor: lens.aperture.area_factor() }
    }
}

/// A ghost as drawn for one light: the aperture polygon, clipped by a disk, filled with
/// uniform light. Lengths in pixels, positions in the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GhostShape {
    pub centre_px: [f64; 2],
    /// Circumradius of the aperture's image (at least the smallest drawn radius).
    pub radius_px: f64,
    /// See [`GhostChannel::flip`].
    pub flip: f64,
    pub clip_centre_px: [f64; 2],
    pub clip_radius_px: f64,
    /// Light per pixel inside the shape, per unit of the light's energy (value x pixels).
    pub irradiance_per_energy: f64,
    /// The surface that clips it (the most of any), if one does.
    pub clip_surface: Option<usize>,
    /// A surface blocks it entirely: it does not reach the sensor.
    pub blocked: bool,
}

impl GhostChannel {
    /// The ghost of a light at slope `u` (2D, image space: x right, y down; the light's image
    /// is at `centre + G0 u / pitch`), drawn with a radius of at least `min_radius_px` (a ghost
    /// focused to a point keeps its energy, spread over that).
    pub fn shape(
        &self,
        u: [f64; 2],
        centre_px: [f64; 2],
        pixel_pitch_mm: f64,
        min_radius_px: f64,
        aperture_area_factor: f64,
    ) -> GhostShape {
        let u_len = (u[0] * u[0] + u[1] * u[1]).sqrt();
        // The clip that removes the most of the aperture's circle.
        let mut clip = Clip { surface: usize::MAX, offset_mm: 0.0, radius_mm: f64::INFINITY };
        let mut least = f64::INFINITY;
        for c in &self.clips {
            let overlap = disk_overlap_area(self.aperture_radius_mm, c.radius_mm, c.offset_mm * u_len);
            if overlap < least {
                least = overlap;
                clip = *c;
            }
        }
        let true_radius_px = self.sensor.a.abs() * self.aperture_radius_mm / pixel_pitch_mm;
        let radius_px = true_radius_px.max(min_radius_px);
        // Pixels per entrance-plane mm, with the sensor's orientation (A's sign).
        let scale = radius_px / self.aperture_radius_mm * if self.sensor.a < 0.0 { -1.0 } else { 1.0 };
        let centre = [
            centre_px[0] + self.centre_mm * u[0] / pixel_pitch_mm,
            centre_px[1] + self.centre_mm * u[1] / pixel_pitch_mm,
        ];
        // The unvignetted ghost's energy, energy_ratio x E, enters through the aperture's
        // region of the entrance plane (area_factor r_e^2) and lands uniformly on scale^2 pixels
        // per entrance mm^2.
        let entrance_area_mm2 = aperture_area_factor * self.aperture_radius_mm.powi(2);
        let irradiance_per_energy = self.energy_ratio / (entrance_area_mm2 * scale * scale);
        GhostShape {
            centre_px: centre,
            radius_px,
            flip: self.flip,
            clip_centre_px: [centre[0] + scale * clip.offset_mm * u[0], centre[1] + scale * clip.offset_mm * u[1]],
            clip_radius_px: (scale.abs() * clip.radius_mm).min(1e30),
            irradiance_per_energy,
            clip_surface: (clip.surface != usize::MAX).then_some(clip.surface),
            blocked: least.is_nan() || least <= 0.0,
        }
    }
}

impl GhostShape {
    /// Signed distance (px, negative inside) from image point `p` to the shape's edge: the
    /// aperture's (bounded by its circumscribed circle, where the edge distances underestimate
    /// past the corners) and the clip circle's, whichever is larger.
    pub fn sdf(&self, p: [f64; 2], aperture: &super::AperturePolygon) -> f64 {
        let o = [(p[0] - self.centre_px[0]) * self.flip, (p[1] - self.centre_px[1]) * self.flip];
        let d_aperture = aperture.sdf(o, self.radius_px).max((o[0] * o[0] + o[1] * o[1]).sqrt() - self.radius_px);
        let (dx, dy) = (p[0] - self.clip_centre_px[0], p[1] - self.clip_centre_px[1]);
        d_aperture.max((dx * dx + dy * dy).sqrt() - self.clip_radius_px)
    }
}

/// Area, centroid and root-mean-square radius of a shape (or an image of traced light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    pub area_px2: f64,
    pub centroid_px: [f64; 2],
    pub rms_radius_px: f64,
}

impl GhostShape {
    /// The drawn shape's moments (its inside, sdf < 0), integrated on a grid of `per_px`
    /// samples per pixel over its bounds.
    pub fn moments(&self, aperture: &super::AperturePolygon, per_px: usize) -> Option<Moments> {
        self.moments_step(aperture, 1.0 / per_px.max(1) as f64)
    }

    /// [`Self::moments`] on a grid of `step_px` (also coarser than a pixel, for large ghosts).
    pub fn moments_step(&self, aperture: &super::AperturePolygon, step_px: f64) -> Option<Moments> {
        let r = self.radius_px;
        let lo = [
            (self.centre_px[0] - r).max(self.clip_centre_px[0] - self.clip_radius_px),
            (self.centre_px[1] - r).max(self.clip_centre_px[1] - self.clip_radius_px),
        ];
        let hi = [
            (self.centre_px[0] + r).min(self.clip_centre_px[0] + self.clip_radius_px),
            (self.centre_px[1] + r).min(self.clip_centre_px[1] + self.clip_radius_px),
        ];
        if !(lo[0] < hi[0] && lo[1] < hi[1]) {
            return None;
        }
        // The grid fits the bounds exactly (steps of at most step_px), so a symmetric shape has
        // its centroid on its centre.
        let (nx, ny) = (((hi[0] - lo[0]) / step_px).ceil().max(1.0), ((hi[1] - lo[1]) / step_px).ceil().max(1.0));
        let (hx, hy) = ((hi[0] - lo[0]) / nx, (hi[1] - lo[1]) / ny);
        let nx = nx as usize;
        let points = (0..nx * ny as usize)
            .map(|i| [lo[0] + ((i % nx) as f64 + 0.5) * hx, lo[1] + ((i / nx) as f64 + 0.5) * hy])
            .filter(|&p| self.sdf(p, aperture) < 0.0);
        Moments::of(points.map(|p| (p, hx * hy)))
    }
}

impl Moments {
    /// Of weighted points (position, weight).
    pub fn of(points: impl Iterator<Item = ([f64; 2], f64)> + Clone) -> Option<Moments> {
        let (w, sx, sy) = points.clone().fold((0.0, 0.0, 0.0), |(w, x, y), (p, v)| (w + v, x + v * p[0], y + v * p[1]));
        if w.is_nan() || w <= 0.0 {
            return None;
        }
        let c = [sx / w, sy / w];
        let m2: f64 = points.map(|(p, v)| v * ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2))).sum();
        Some(Moments { area_px2: w, centroid_px: c, rms_radius_px: (m2 / w).sqrt() })
    }
}

#[cfg(test)]
mod tests {
    use super::super::traced::tests::tessar;
    use super::super::*;
    use super::*;
    use crate::optics::prescription::{Prescription, Surface};

    fn singlet(n: f64) -> Prescription {
        let s = |radius_mm, thickness_mm, n_d: f64, stop| Surface {
            radius_mm,
            thickness_mm,
            n_d,
            v_d: if n_d > 1.0 { 60.0 } else { 0.0 },
            semi_diameter_mm: 10.0,
            stop,
        };
        Prescription {
            name: "stop and singlet".into(),
            surfaces: vec![s(0.0, 5.0, 1.0, true), s(60.0, 6.0, n, false), s(-60.0, 55.0, 1.0, false)],
        }
    }

    #[test]
    fn the_path_count_is_walch_eq_3_3() {
        // Walch eq 3.3: R = M (2M - 1) paths for M air-spaced elements, i.e. 2M reflecting surfaces.
        let s = |radius_mm: f64, n_d: f64, stop| Surface {
            radius_mm,
            thickness_mm: 4.0,
            n_d,
            v_d: 0.0,
            semi_diameter_mm: 5.0,
            stop,
        };
        for m in 1..=4 {
            let mut surfaces = vec![s(0.0, 1.0, true)];
            for _ in 0..m {
                surfaces.push(s(40.0, 1.5, false));
                surfaces.push(s(-40.0, 1.0, false));
            }
            let p = Prescription { name: "singlets".into(), surfaces };
            let lens = FlareLens::new(&p, 4.0, 0.0, None, AperturePolygon::CIRCLE);
            assert_eq!(ghost_paths(&lens).len(), m * (2 * m - 1), "{m} singlets");
        }
        // The Tessar: 8 surfaces, the stop does not reflect, so N = 7: 21 = 7 x 6 / 2 (eq 3.3
        // with M = 3.5: its cemented doublet shares a surface between two elements).
        let lens = tessar(2.8);
        let paths = ghost_paths(&lens);
        assert_eq!(paths.len(), 21);
        assert!(paths.iter().all(|p| p.first != 3 && p.second != 3 && p.second < p.first));
    }

    #[test]
    fn a_path_matrix_is_the_real_ray_at_small_angles() {
        // The paraxial matrices against the real-ray tracer of src/optics/flare/traced.rs, for a
        // ray 1e-4 mm off the axis at slope 1e-4: they agree to second order.
        let lens = tessar(2.8);
        for path in ghost_paths(&lens).into_iter().chain([GhostPath { first: 6, second: 0 }]) {
            let events = path.events(8);
            let m = path_matrix(&lens, &events, 550.0);
            let (y, u) = (1e-4, 2e-4);
            let traced = traced::trace_ray(&lens, &events, [0.0, y - u, -1.0], [0.0, u, 1.0], 550.0, false);
            let Ok(hit) = traced else { panic!("{path:?}: {traced:?}") };
            let (ys, _) = m.sensor.apply(y, u);
            assert!(
                (hit.position[1] - ys).abs() < 1e-6 * (ys.abs() + 1e-4),
                "{path:?}: traced {} matrix {ys}",
                hit.position[1]
            );
        }
    }

    #[test]
    fn a_reflection_off_a_concave_mirror_focuses_at_half_its_radius() {
        // A flat stop and a single glass block whose back surface (R = -40, met from the front)
        // reflects: the light comes back focused R/2 = 20 mm in front of it, then refracts out.
        let lens = FlareLens::new(&singlet(1.5), 4.0, 0.0, None, AperturePolygon::CIRCLE);
        let events = [
            Event::Transmit { surface: 0, forward: true },
            Event::Transmit { surface: 1, forward: true },
            Event::Reflect { surface: 2, from_front: true },
        ];
        let m = path_matrix(&lens, &events[..], 550.0);
        // After the reflection, a parallel ray (u = 0) converges with slope -2 c y where y is
        // its height at surface 2 (glass of index 1.5 refracted it first).
        let c2 = -1.0 / 60.0;
        let at2 = m.crossings[2];
        let (_, u_before) = path_matrix(&lens, &events[..2], 550.0).sensor.apply(1.0, 0.0);
        let y2 = at2.a;
        // The matrix ends with the translation to the image plane; its slope is what counts.
        assert!(
            (m.sensor.c - (u_before + 2.0 * c2 * y2)).abs() < 1e-12,
            "{} vs {}",
            m.sensor.c,
            u_before + 2.0 * c2 * y2
        );
    }

    #[test]
    fn the_catalogue_of_the_tessar() {
        let lens = tessar(2.8);
        let cat = GhostCatalogue::new(&lens, 0.0);
        assert_eq!(cat.paths, 21);
        assert_eq!(cat.ghosts.len(), 21);
        // The light's own image: G0 is the focal length (infinity focus; at 550 nm the sensor,
        // at the d line's focus, is 0.07 mm out of focus, which moves the chief ray's image by
        // its slope times that), the entrance pupil the stop seen through the front group.
        let par = lens.prescription.paraxial(550.0);
        assert!(
            (cat.direct.centre_mm[1] / par.efl_mm - 1.0).abs() < 1e-3,
            "{} {}",
            cat.direct.centre_mm[1],
            par.efl_mm
        );
        assert!((cat.direct.pupil_radius_mm[1] / par.entrance_pupil_semi_diameter_mm - 1.0).abs() < 1e-9);
        for g in &cat.ghosts {
            for c in &g.channels {
                assert!(c.energy_ratio.is_finite() && c.energy_ratio > 0.0 && c.energy_ratio < 1.0, "{g:?}");
                assert!(c.aperture_radius_mm > 0.0 && c.centre_mm.is_finite());
            }
        }
        // Coated air|glass surfaces designed for 550 nm reflect least in the green band: a
        // ghost between two of them is magenta.
        let coated_pair = cat.ghosts.iter().find(|g| g.path == GhostPath { first: 5, second: 4 }).unwrap();
        let [r, g, b] = [0, 1, 2].map(|c| coated_pair.channels[c].energy_ratio);
        assert!(r > 3.0 * g && b > 3.0 * g, "{r} {g} {b}");
    }
}
