//! The reference for the matrix ghosts: real rays along a path's events (refractions and the
//! two reflections) through the spherical surfaces, in f64, each ray weighted by Fresnel's
//! reflectance or transmittance (with the coating) at its own angle of incidence and
//! wavelength, and clipped at every surface's semi-diameter and by the aperture polygon at the
//! stop. Many rays of a parallel beam (a light at infinity) make a ghost's image: its energy
//! against the light's own image, its centroid and its size.

use super::ghosts::{direct_events, Event, GhostPath};
use super::{FlareLens, BANDS_NM, BAND_WEIGHTS};

/// Why a ray does not follow a path to the sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TraceFailure {
    /// It does not meet this surface's sphere.
    Missed { surface: usize },
    /// It meets it outside its semi-diameter (or outside the aperture, at the stop).
    Clipped { surface: usize },
    /// It cannot be transmitted there (total internal reflection).
    TotalInternalReflection { surface: usize },
}

/// Where a ray reaches the sensor, and the share of its light that gets there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// On the sensor, mm from the axis (x, y up; the sensor's own, upside-down image).
    pub position: [f64; 2],
    pub weight: f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn along(p: [f64; 3], d: [f64; 3], t: f64) -> [f64; 3] {
    [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]]
}

/// Trace one ray from `origin` along `direction` through `events`; `clip` applies the
/// semi-diameters and the aperture.
pub fn trace_ray(
    lens: &FlareLens,
    events: &[Event],
    origin: [f64; 3],
    direction: [f64; 3],
    lambda_nm: f64,
    clip: bool,
) -> Result<Hit, TraceFailure> {
    trace_ray_crossings(lens, events, origin, direction, lambda_nm, clip, &mut Vec::new())
}

/// [`trace_ray`], recording where the ray meets each event's surface in `crossings`.
pub fn trace_ray_crossings(
    lens: &FlareLens,
    events: &[Event],
    origin: [f64; 3],
    direction: [f64; 3],
    lambda_nm: f64,
    clip: bool,
    crossings: &mut Vec<[f64; 3]>,
) -> Result<Hit, TraceFailure> {
    crossings.clear();
    let surfaces = &lens.prescription.surfaces;
    let zs = lens.prescription.vertex_z_mm();
    let stop = lens.prescription.stop_index();
    let l = dot(direction, direction).sqrt();
    let (mut p, mut d) = (origin, direction.map(|x| x / l));
    let mut weight = 1.0;
    for event in events {
        let k = event.surface();
        let s = &surfaces[k];
        let c = s.curvature_per_mm();
        // Intersection with the surface: the plane of the vertex, or the sphere's cap around
        // the vertex (the root on the vertex's side of the centre).
        let (t, normal) = if c == 0.0 {
            if d[2].abs() < 1e-300 {
                return Err(TraceFailure::Missed { surface: k });
            }
            ((zs[k] - p[2]) / d[2], [0.0, 0.0, 1.0])
        } else {
            let r = 1.0 / c;
            let centre = [0.0, 0.0, zs[k] + r];
            let oc = [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
            let b = dot(oc, d);
            let disc = b * b - (dot(oc, oc) - r * r);
            if disc < 0.0 {
                return Err(TraceFailure::Missed { surface: k });
            }
            let roots = [-b - disc.sqrt(), -b + disc.sqrt()];
            let Some(&t) = roots.iter().find(|&&t| t > 1e-9 && (along(p, d, t)[2] - centre[2]) * r < 0.0) else {
                return Err(TraceFailure::Missed { surface: k });
            };
            let q = along(p, d, t);
            (t, [(q[0] - centre[0]) * c, (q[1] - centre[1]) * c, (q[2] - centre[2]) * c].map(|x| -x))
        };
        p = along(p, d, t);
        crossings.push(p);
        if clip {
            let outside = if k == stop {
                lens.aperture.sdf([p[0], -p[1]], s.semi_diameter_mm) > 0.0
            } else {
                p[0] * p[0] + p[1] * p[1] > s.semi_diameter_mm * s.semi_diameter_mm
            };
            if outside {
                return Err(TraceFailure::Clipped { surface: k });
            }
        }
        // The normal against the incoming ray; the angle of incidence.
        let normal = if dot(normal, d) > 0.0 { normal.map(|x| -x) } else { normal };
        let cos_i = -dot(normal, d);
        let (before, after) = lens.media(k, lambda_nm);
        match *event {
            Event::Reflect { from_front, .. } => {
                weight *= lens.reflectance(k, from_front, cos_i, lambda_nm);
                d = along(d, normal, 2.0 * cos_i);
            }
            Event::Transmit { forward, .. } => {
                let (n1, n2) = if forward { (before, after) } else { (after, before) };
                let eta = n1 / n2;
                let k2 = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
                if k2 < 0.0 {
                    return Err(TraceFailure::TotalInternalReflection { surface: k });
                }
                weight *= 1.0 - lens.reflectance(k, forward, cos_i, lambda_nm);
                let g = eta * cos_i - k2.sqrt();
                d = [eta * d[0] + g * normal[0], eta * d[1] + g * normal[1], eta * d[2] + g * normal[2]];
            }
        }
    }
    if d[2] <= 0.0 {
        return Err(TraceFailure::Missed { surface: surfaces.len() });
    }
    let at = along(p, d, (lens.image_z_mm - p[2]) / d[2]);
    Ok(Hit { position: [at[0], at[1]], weight })
}

/// The hits of a parallel beam of slope `u` (optical x, y up: the ray runs along (u, 1)),
/// `rays_across` rays across the front surface's diameter; each hit's weight is its Fresnel
/// share times the area (mm^2, on the entrance plane) its ray stands for.
pub fn trace_beam(lens: &FlareLens, events: &[Event], u: [f64; 2], lambda_nm: f64, rays_across: usize) -> Vec<Hit> {
    let front = &lens.prescription.surfaces[0];
    let half = 1.05 * front.semi_diameter_mm;
    let n = rays_across.max(2);
    let h = 2.0 * half / n as f64;
    // Rays start 1 mm in front of the front surface's rim, whichever way it curves.
    let sag =
        front.radius_mm.abs() - (front.radius_mm.powi(2) - half.min(front.radius_mm.abs()).powi(2)).max(0.0).sqrt();
    let z0 = -(sag + 1.0);
    let direction = [u[0], u[1], 1.0];
    let mut hits = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (-half + (i as f64 + 0.5) * h, -half + (j as f64 + 0.5) * h);
            if x * x + y * y > half * half {
                continue;
            }
            // Through (x, y) on the plane of the first vertex.
            let origin = [x + u[0] * z0, y + u[1] * z0, z0];
            if let Ok(hit) = trace_ray(lens, events, origin, direction, lambda_nm, true) {
                hits.push(Hit { position: hit.position, weight: hit.weight * h * h });
            }
        }
    }
    hits
}

/// The real chief ray of a path for a light of slope `u` (optical x, y up): the ray through
/// the centre of the stop at the path's crossing `stop_crossing` (an index into its events,
/// the matrix model's aperture), found by the secant method on its entrance height along u (the
/// meridional plane), from the paraxial ray. Its place on the sensor (mm, y up), or None if it
/// cannot be found.
pub fn chief_ray(
    lens: &FlareLens,
    events: &[Event],
    stop_crossing: usize,
    u: [f64; 2],
    lambda_nm: f64,
) -> Option<[f64; 2]> {
    let u_len = u[0].hypot(u[1]);
    let axis = if u_len > 0.0 { [u[0] / u_len, u[1] / u_len] } else { [0.0, 1.0] };
    let z0 = -1.0;
    let mut crossings = Vec::new();
    // The ray entering at height s along `axis` on the first vertex plane: its stop height.
    let mut at = |s: f64| -> Option<(f64, [f64; 2])> {
        let origin = [s * axis[0] + u[0] * z0, s * axis[1] + u[1] * z0, z0];
        let hit =
            trace_ray_crossings(lens, events, origin, [u[0], u[1], 1.0], lambda_nm, false, &mut crossings).ok()?;
        let c = crossings.get(stop_crossing)?;
        Some((c[0] * axis[0] + c[1] * axis[1], hit.position))
    };
    let scale = lens.stop_radius_mm().max(1e-3);
    // The paraxial chief ray: a s + b |u| = 0 at the crossing.
    let crossing = super::ghosts::path_matrix(lens, events, lambda_nm).crossings.get(stop_crossing).copied()?;
    let start = if crossing.a.abs() > 1e-12 { -crossing.b * u_len / crossing.a } else { 0.0 };
    let (mut s0, mut g0) = (start, at(start)?.0);
    let mut s1 = start + 1e-3 * scale / crossing.a.abs().max(1e-3);
    let (mut g1, mut hit) = at(s1)?;
    for _ in 0..60 {
        if g1.abs() < 1e-12 * scale {
            return Some(hit);
        }
        let dg = g1 - g0;
        if dg == 0.0 {
            break;
        }
        let s2 = s1 - g1 * (s1 - s0) / dg;
        (s0, g0) = (s1, g1);
        s1 = s2;
        (g1, hit) = at(s1)?;
    }
    (g1.abs() < 1e-9 * scale).then_some(hit)
}

/// A ghost (or the light's own image) traced in one colour channel: every hit of its band's
/// wavelengths, weighted by the band's weights.
#[derive(Clone, Debug, PartialEq)]
pub struct TracedImage {
    pub hits: Vec<Hit>,
}

impl TracedImage {
    /// The path `ghost` (None: the direct path) for a light of slope `u`, channel `c`.
    pub fn trace(lens: &FlareLens, ghost: Option<GhostPath>, u: [f64; 2], c: usize, rays_across: usize) -> Self {
        let n = lens.prescription.surfaces.len();
        let events = match ghost {
            Some(g) => g.events(n),
            None => direct_events(n),
        };
        let mut hits = Vec::new();
        for (&lambda_nm, w) in BANDS_NM[c].iter().zip(BAND_WEIGHTS) {
            hits.extend(
                trace_beam(lens, &events, u, lambda_nm, rays_across)
                    .into_iter()
                    .map(|h| Hit { weight: h.weight * w, ..h }),
            );
        }
        TracedImage { hits }
    }

    pub fn energy(&self) -> f64 {
        self.hits.iter().map(|h| h.weight).sum()
    }

    /// Centroid on the sensor (mm; the sensor's own coordinates).
    pub fn centroid(&self) -> Option<[f64; 2]> {
        let e = self.energy();
        if e.is_nan() || e <= 0.0 {
            return None;
        }
        let sum =
            self.hits.iter().fold([0.0; 2], |s, h| [s[0] + h.weight * h.position[0], s[1] + h.weight * h.position[1]]);
        Some([sum[0] / e, sum[1] / e])
    }

    /// Root-mean-square distance of the light from its centroid (mm).
    pub fn rms_radius_mm(&self) -> Option<f64> {
        let c = self.centroid()?;
        let m2: f64 = self
            .hits
            .iter()
            .map(|h| h.weight * ((h.position[0] - c[0]).powi(2) + (h.position[1] - c[1]).powi(2)))
            .sum();
        Some((m2 / self.energy()).sqrt())
    }
}

/// The display vector (x right, y down, pixels) of a sensor position (mm, y up): the sensor's
/// image turned by 180 degrees.
pub fn display_px(sensor_mm: [f64; 2], pixel_pitch_mm: f64) -> [f64; 2] {
    [-sensor_mm[0] / pixel_pitch_mm, sensor_mm[1] / pixel_pitch_mm]
}

/// The optical slope of a light whose display slope (the `u` of
/// [`super::ghosts::GhostChannel::shape`]) is `u_display`: the inverse of [`display_px`]'s turn.
pub fn optical_slope(u_display: [f64; 2]) -> [f64; 2] {
    [-u_display[0], u_display[1]]
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::ghosts::GhostCatalogue;
    use super::super::{channel_nm, AperturePolygon};
    use super::*;
    use crate::optics::prescription::Prescription;

    /// The Tessar of lenses/, focused at infinity, coated for 550 nm, circular aperture.
    pub fn tessar(f_number: f64) -> FlareLens {
        let text = include_str!("../../../lenses/tessar-walch.toml");
        let p = Prescription::parse_toml(text, "lenses/tessar-walch.toml").unwrap();
        FlareLens::new(&p, f_number, 0.0, Some(550.0), AperturePolygon::CIRCLE)
    }

    #[test]
    fn the_direct_beam_focuses_and_loses_only_the_coatings_reflections() {
        let lens = tessar(2.8);
        let image = TracedImage::trace(&lens, None, [0.0, 0.0], 1, 64);
        // On axis the light goes to the axis (within the spherical aberration's spread). The
        // real rays that pass the stop fill 94.5% of the paraxial entrance pupil (the front
        // group's spherical aberration of the pupil bends the rim rays onto the stop's edge),
        // and they lose only the coatings' reflections: at most 1% in the green band.
        let par = lens.prescription.paraxial(550.0);
        let pupil_area = std::f64::consts::PI * par.entrance_pupil_semi_diameter_mm.powi(2);
        let ratio = image.energy() / pupil_area;
        assert!(ratio > 0.93 && ratio < 0.955, "{ratio}");
        let h = 2.0 * 1.05 * lens.prescription.surfaces[0].semi_diameter_mm / 64.0;
        let mean_share = image.energy() / (image.hits.len() as f64 / 3.0 * h * h);
        assert!(mean_share > 0.99 && mean_share < 1.0, "{mean_share}");
        assert!(image.centroid().unwrap()[1].abs() < 1e-9);
        assert!(image.rms_radius_mm().unwrap() < 0.1);
    }

    #[test]
    fn ghost_centres_lie_where_the_matrices_put_them() {
        // The Tessar at f/2.8 on 36 mm imaged at 1280 px: for a light up to 1.3 degrees (80 px) off the
        // axis, the real chief ray of every ghost (through the centre of the stop, at the
        // crossing the matrix model takes as the aperture) lands within 1 px of the matrix
        // model's centre (0.68 px at most, the third-order distortion of the ghost paths, growing
        // as the cube of the angle),
        // and on the line through the image centre and the light. Ghost 2/0 has no real chief
        // ray (the stop sees the front through it almost at infinity: the paraxial centre lies
        // 17 mm off the axis in the entrance, where the real ray is totally reflected), so it
        // is the one ghost whose centre no real ray shows.
        let lens = tessar(2.8);
        let cat = GhostCatalogue::new(&lens, 0.0);
        let (pitch, centre) = (36.0 / 1280.0, [640.0, 360.0]);
        let g0 = cat.direct.centre_mm[1];
        let mut worst: f64 = 0.0;
        for light in [[700.0, 385.0], [590.0, 310.0], [640.0, 280.0]] {
            let u = [(light[0] - centre[0]) * pitch / g0, (light[1] - centre[1]) * pitch / g0];
            let along = [light[0] - centre[0], light[1] - centre[1]];
            let len = along[0].hypot(along[1]);
            for g in &cat.ghosts {
                let events = g.path.events(lens.prescription.surfaces.len());
                for (c, ch) in g.channels.iter().enumerate() {
                    let shape = ch.shape(u, centre, pitch, 1.0, lens.aperture.area_factor());
                    let chief = chief_ray(&lens, &events, ch.aperture_crossing, optical_slope(u), channel_nm(c));
                    let Some(chief) = chief else {
                        assert_eq!(g.path, GhostPath { first: 2, second: 0 }, "channel {c}, light {light:?}");
                        continue;
                    };
                    let d = display_px(chief, pitch);
                    let traced = [centre[0] + d[0], centre[1] + d[1]];
                    let miss = (traced[0] - shape.centre_px[0]).hypot(traced[1] - shape.centre_px[1]);
                    worst = worst.max(miss);
                    assert!(
                        miss < 1.0,
                        "{:?} channel {c}, light {light:?}: traced {traced:?}, matrix {:?}",
                        g.path,
                        shape.centre_px
                    );
                    let off_line = (d[0] * along[1] - d[1] * along[0]).abs() / len;
                    assert!(off_line < 1e-6, "{:?}: {off_line} px off the line", g.path);
                }
            }
        }
        println!("largest distance from the matrix centre: {worst:.3} px");
    }

    #[test]
    fn traced_ghosts_agree_with_the_matrices_on_axis() {
        // On the axis every ghost of the Tessar, traced, is centred on the axis; its energy
        // against the light's own image is the matrix model's (the aperture's region within the
        // smallest limit, which all lie on the axis then) within the model's approximations:
        // paraxial angles of incidence for the coatings and no aberrations. Over the 21 ghosts
        // of each channel the median ratio is near 1 and none is off by more than 10x.
        let lens = tessar(2.8);
        let cat = GhostCatalogue::new(&lens, 0.0);
        for c in 0..3 {
            let direct = TracedImage::trace(&lens, None, [0.0, 0.0], c, 64).energy();
            let mut ratios: Vec<f64> = cat
                .ghosts
                .iter()
                .map(|g| {
                    let traced = TracedImage::trace(&lens, Some(g.path), [0.0, 0.0], c, 64);
                    assert!(traced.centroid().unwrap()[1].abs() < 1e-6, "{:?}", g.path);
                    let ch = &g.channels[c];
                    let lit = ch.clips.iter().fold(ch.aperture_radius_mm, |r, clip| r.min(clip.radius_mm));
                    let matrix = ch.energy_ratio * (lit / ch.aperture_radius_mm).powi(2);
                    traced.energy() / direct / matrix
                })
                .collect();
            ratios.sort_by(f64::total_cmp);
            let median = ratios[ratios.len() / 2];
            assert!(median > 0.8 && median < 1.1, "channel {c}: median traced / matrix {median} ({ratios:?})");
            assert!(ratios[0] > 0.1 && ratios[ratios.len() - 1] < 2.5, "channel {c}: {ratios:?}");
        }
    }
}
