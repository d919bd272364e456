//! The focus processor of Potmesil & Chakravarty 1981 (sec. 3.2, eq 20) on the CPU, in `f64`.
//!
//! Every input sample is an independent point source. Its image on the film is the defocused
//! diffraction pattern of a circular aperture (eq 13, [`crate::optics::diffraction`]), at the
//! sample's depth and the channel's wavelength; the pattern integrated over the area of each
//! pixel is the sample's contribution to that pixel. The paper precomputes these integrals in
//! lookup tables at a set of depths and interpolates linearly between the two tables nearest to
//! a sample's depth; each output pixel keeps a numerator per primary colour and a denominator,
//! the sum of the weights, divided at the end (eq 20):
//!
//! `Q(pixel) = Σ_i q_i f_i(pixel) / Σ_i f_i(pixel)`, `f_i(pixel) = ∫∫_pixel I(z_i, r - r_i) dA`.
//!
//! # The denominator
//!
//! Each table sums to 1 (a point's energy, all of it inside the table, none lost), so the
//! denominator of a pixel is the total weight the samples around it spread onto it: the local
//! density of samples as seen through the point-spread function. In the paper it makes
//! adaptively supersampled pixels (2x2 antialiasing adds samples) no brighter than the others,
//! and here it also normalises the image borders, where the samples that would have spread
//! onto a pixel from outside the frame are missing. Where every sample has the same depth and
//! the samples lie on the pixel grid the denominator is exactly 1 farther than the table radius
//! from the borders, and the processor is an energy-conserving convolution; a point farther
//! than twice the radius from the borders keeps its energy exactly. Near the borders, and where
//! depths differ, it is a normalised (weighted-mean) convolution, which keeps a uniform region
//! uniform but does not conserve energy exactly.
//!
//! The paper's denominator is common to the three colours because its pattern is: here the
//! patterns differ per channel (the wavelength sets the diffraction halo), so each channel
//! keeps its own sum of weights. A common denominator (the mean of the three) would tint the
//! borders of a uniform frame: 1.1% at the corners, measured for the f/16 test lens, whose
//! Airy radius is about one pixel. In uniform regions every channel's weights sum to 1 and
//! the two choices agree.
//!
//! # What the model leaves out, by definition
//!
//! - **No occlusion.** Every sample spreads its full pattern whatever lies in front of or
//!   behind it: a defocused foreground does not hide the background, and a sharp subject does
//!   not block a blurred background spreading over it. This is the paper's model and the
//!   definition of this reference; the production depth-of-field passes handle layers.
//! - **No `1/z²` factor.** The paper divides its tables by the square of the sample's depth
//!   (numerator and denominator alike). Our inputs are radiance samples, one per pixel (equal
//!   solid angles), for which no distance falloff applies; in a region of uniform depth the
//!   factor cancels, and elsewhere it would only bias mixed pixels towards nearer samples.
//!
//! # Depth levels
//!
//! The levels are equally spaced in the defocus `w = 1/S - 1/u` (S the focus distance, u the
//! object distance), i.e. in `1/u`, not in `u` as in the paper: both the circle of confusion
//! (`|coc| = 2 a v |w|`, [`crate::optics::ThinLens::coc_mm`]) and the optical defocus
//! coordinate (`u_opt = k a² w`) are linear in `w`, so equal steps in `w` are equal steps in
//! blur, and linear interpolation between neighbouring tables has the same error everywhere.
//! Equal steps in depth waste levels far away (where the blur barely changes) and undersample
//! near the camera (where it changes fast). When the focus distance lies inside the range, one
//! level sits exactly on it (the grid is split there into two uniform segments), so in-focus
//! samples use the Airy pattern itself, not a blend of two slightly defocused patterns.
//!
//! # Optical coordinates
//!
//! With the film at distance `v` from the (exit) pupil of radius `a`, a point at depth `u`
//! focuses at `v_u = u f / (u - f)`. We use `u_opt = k a² (1/v_u - 1/v)` and `v_opt = k (a/v) r`
//! (the paraxial `u_opt = k (a/v)² Δz` of eq 17 is its first order in `Δz = v - v_u`). Then the
//! geometric edge `v_opt = |u_opt|` lies at `r = a |Δz| / v_u`, exactly `|coc_mm(u)| / 2`, and
//! since `1/v_u - 1/v = 1/S - 1/u = w` everything stays finite at `u = ∞` (`v_u = f`), at
//! `u = f` (`v_u = ∞`) and for `u < f` (a virtual image: the film sees a diverging cone, the
//! same formula). `a` is the entrance pupil radius `f / 2N` for a symmetric lens; for a pupil
//! magnification `P != 1` we use the radius `v / (2 N' P)` that gives the same CoC as
//! `coc_mm` and the same working f-number `N'`.
//!
//! # Tables
//!
//! `data` holds `levels x 3 x subpixel² x (2R+1)²` `f32` values, in that order (see
//! [`PsfTables::index`]): level (nearest first), channel (R, G, B at
//! [`WAVELENGTHS_RGB_NM`]), sub-pixel offset (`oy * subpixel + ox`: the point sits at
//! `(ox, oy) / subpixel` pixels right and down of the source pixel's centre), then the entries
//! row-major, entry `(dx, dy)` (each in `-R..=R`) at `(dy + R) (2R+1) + (dx + R)`: the weight the
//! point gives the pixel `dx` right and `dy` down of its source pixel.
//!
//! Each entry is the pattern integrated over the pixel: the energy of annuli `1/n` pixel wide
//! around the point (`n = integration_samples`) is integrated accurately along the radius
//! (4-point Gauss-Legendre panels at most two optical units wide: the rings are resolved however
//! small the pixels) and spread over the pixels along the annulus's mid circle at `1/n` pixel
//! steps. This handles a pattern much smaller than a pixel (the Airy disk of a large pixel
//! lands in its pixel) as well as one much larger. The pattern is cut at a circle of radius
//! `R + 1/2 - (subpixel - 1)/subpixel` (the largest one inside the table for every offset) and
//! the table renormalised to sum to 1: the fraction kept is [`PsfTables::energy_kept`].

pub use crate::optics::diffraction::WAVELENGTHS_RGB_NM;
use crate::optics::diffraction::{gauss_legendre_rule, optical_coordinates, psf_intensity, PSF_TOTAL_ENERGY_V2};
use crate::optics::ThinLens;
use std::f64::consts::PI;

/// Depths whose geometric CoC radius exceeds this many table radii (`max_radius_px`) are
/// clamped to the level at that radius: the pattern, cut to the table, is then a nearly flat
/// disk filling the table whatever the exact depth, so more levels there would be wasted.
pub const CLAMP_COC_TABLE_RADII: f64 = 2.0;

/// The table radius covers the largest geometric CoC radius plus this many Airy radii
/// (`1.22 λ N'`, red channel) plus one pixel, up to `max_radius_px`: the diffraction halo.
/// (The Airy pattern keeps about 96% of its energy inside 4 Airy radii.)
pub const HALO_AIRY_RADII: f64 = 4.0;

/// Radial Gauss-Legendre panels are at most this wide in optical units `v` (the intensity
/// oscillates with a period of at least π in `v`; tables made with 1-unit panels differed by
/// at most 1e-7 from these).
const PANEL_WIDTH_V: f64 = 2.0;

/// Nodes per radial panel.
const PANEL_NODES: usize = 4;

/// At most this many radial panels per annulus (bounds the cost for huge pixels, where the
/// rings are far below a pixel and average out).
const MAX_PANELS_PER_ANNULUS: usize = 256;

/// How the lookup tables are computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsfTableSettings {
    /// Number of tables (depth levels), equally spaced in `1/u` (at least 1).
    pub depth_levels: usize,
    /// Sub-pixel positions of the point per axis (1 = pixel centres only; 2 = also the half
    /// pixel, where the paper's 2x2 antialiasing samples lie).
    pub subpixel: u32,
    /// Largest table half-size `R` in pixels; the pattern beyond is cut and the table
    /// renormalised (reported in [`PsfTables::clipped_levels`] and [`PsfTables::energy_kept`]).
    pub max_radius_px: u32,
    /// Integration resolution per pixel: annuli `1/n` pixel wide, spread at `1/n` pixel steps.
    pub integration_samples: u32,
    /// The wavelength (nm) of each channel's pattern (R, G, B): the working space's
    /// ([`crate::model::frame::Frame::channel_wavelengths_nm`]).
    pub wavelengths_nm: [f64; 3],
}

impl Default for PsfTableSettings {
    fn default() -> Self {
        PsfTableSettings {
            depth_levels: 64,
            subpixel: 2,
            max_radius_px: 32,
            integration_samples: 4,
            wavelengths_nm: WAVELENGTHS_RGB_NM,
        }
    }
}

/// The film geometry the tables are computed for: the defocus `w = 1/S - 1/u` gives the
/// geometric CoC radius `a v |w|` and the optical defocus `k a² w` (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocusGeometry {
    /// `v`: lens (exit pupil) to film.
    pub image_distance_mm: f64,
    /// `a`: the pupil radius seen from the film (`f / 2N` for a symmetric lens).
    pub aperture_radius_mm: f64,
    /// `1/S`.
    pub inv_focus_distance_per_mm: f64,
    pub pixel_pitch_mm: f64,
}

impl FocusGeometry {
    pub fn new(lens: &ThinLens, pixel_pitch_mm: f64) -> FocusGeometry {
        let v = lens.image_distance_mm();
        FocusGeometry {
            image_distance_mm: v,
            // coc_mm = v² / (N' P) w = 2 a v w  =>  a = v / (2 N' P); = f / 2N for P = 1.
            aperture_radius_mm: v / (2.0 * lens.effective_f_number() * lens.pupil_magnification),
            inv_focus_distance_per_mm: 1.0 / lens.focus_distance_mm,
            pixel_pitch_mm,
        }
    }

    /// `w = 1/S - 1/u` in 1/mm for a depth `u` in metres (`u = ∞` allowed; `u <= 0` gives -∞).
    pub fn defocus_per_mm(&self, depth_m: f64) -> f64 {
        self.inv_focus_distance_per_mm - 1.0 / (depth_m * 1000.0)
    }

    /// Signed geometric CoC radius in mm, `a v w`: half of [`ThinLens::coc_mm`].
    pub fn coc_radius_mm(&self, defocus_per_mm: f64) -> f64 {
        self.aperture_radius_mm * self.image_distance_mm * defocus_per_mm
    }

    /// `(u_opt, v_opt per mm of radius)` at wavelength `wavelength_nm`: the optical coordinates
    /// of [`optical_coordinates`] with the exact defocus `v² w` referred to the film distance.
    pub fn optical(&self, defocus_per_mm: f64, wavelength_nm: f64) -> (f64, f64) {
        let v = self.image_distance_mm;
        optical_coordinates(v * v * defocus_per_mm, 1.0, self.aperture_radius_mm, v, wavelength_nm)
    }

    /// Radius of the Airy disk's first dark ring, `1.22 λ N'`, in pixels.
    pub fn airy_radius_px(&self, wavelength_nm: f64) -> f64 {
        let (_, v_per_mm) = self.optical(0.0, wavelength_nm);
        3.831705970207512 / v_per_mm / self.pixel_pitch_mm
    }
}

/// Depth (as the defocus `w = 1/S - 1/u`) to fractional level: two uniform segments joined at
/// a knot level, placed on the focus distance (`w = 0`) when it lies inside the range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelMapping {
    pub levels: usize,
    /// `1/S` in 1/m.
    pub inv_focus_per_m: f64,
    /// `w` of level 0 (nearest) and of the last level (farthest), 1/m.
    pub defocus_near_per_m: f64,
    pub defocus_far_per_m: f64,
    /// The knot: level `knot_level` has `w = defocus_knot_per_m`.
    pub knot_level: usize,
    pub defocus_knot_per_m: f64,
    /// Levels per unit of `w` (m) below and above the knot (0 for an empty segment).
    pub near_levels_per_defocus_m: f64,
    pub far_levels_per_defocus_m: f64,
}

impl LevelMapping {
    /// `levels` levels from `w_near` to `w_far` (`w_near <= w_far`, in 1/m).
    pub fn new(levels: usize, inv_focus_per_m: f64, w_near: f64, w_far: f64) -> LevelMapping {
        let levels = levels.max(1);
        let last = levels - 1;
        let mut mapping = LevelMapping {
            levels,
            inv_focus_per_m,
            defocus_near_per_m: w_near,
            defocus_far_per_m: w_far,
            knot_level: 0,
            defocus_knot_per_m: w_near,
            near_levels_per_defocus_m: 0.0,
            far_levels_per_defocus_m: 0.0,
        };
        if last == 0 || w_far <= w_near {
            return mapping;
        }
        if levels >= 3 && w_near < 0.0 && w_far > 0.0 {
            let knot = ((last as f64 * -w_near / (w_far - w_near)).round() as usize).clamp(1, last - 1);
            mapping.knot_level = knot;
            mapping.defocus_knot_per_m = 0.0;
            mapping.near_levels_per_defocus_m = knot as f64 / -w_near;
            mapping.far_levels_per_defocus_m = (last - knot) as f64 / w_far;
        } else {
            mapping.far_levels_per_defocus_m = last as f64 / (w_far - w_near);
        }
        mapping
    }

    /// `w` of level `i` (exact at level 0, the knot and the last level).
    pub fn level_defocus_per_m(&self, i: usize) -> f64 {
        let (k, last) = (self.knot_level, self.levels - 1);
        if i == last {
            self.defocus_far_per_m
        } else if i < k {
            let span = self.defocus_knot_per_m - self.defocus_near_per_m;
            self.defocus_near_per_m + span * i as f64 / k as f64
        } else if i == k {
            self.defocus_knot_per_m
        } else {
            let span = self.defocus_far_per_m - self.defocus_knot_per_m;
            self.defocus_knot_per_m + span * (i - k) as f64 / (last - k) as f64
        }
    }

    /// Depth of level `i` in metres (`∞` for `w = 1/S`).
    pub fn level_depth_m(&self, i: usize) -> f64 {
        let inv_depth = self.inv_focus_per_m - self.level_defocus_per_m(i);
        if inv_depth <= 0.0 {
            f64::INFINITY
        } else {
            1.0 / inv_depth
        }
    }

    /// Fractional level of a depth in metres, in `[0, levels - 1]`. Depths outside the range
    /// clamp to the nearest or farthest level: `u <= 0` (and anything nearer than the nearest
    /// level, e.g. nearer than the focal length) to level 0, NaN and `∞` to the far end.
    pub fn coordinate(&self, depth_m: f64) -> f64 {
        let inv_depth = if depth_m.is_nan() { 0.0 } else { 1.0 / depth_m.max(1e-30) };
        let w = (self.inv_focus_per_m - inv_depth).clamp(self.defocus_near_per_m, self.defocus_far_per_m);
        let x = if w < self.defocus_knot_per_m {
            (w - self.defocus_near_per_m) * self.near_levels_per_defocus_m
        } else {
            self.knot_level as f64 + (w - self.defocus_knot_per_m) * self.far_levels_per_defocus_m
        };
        x.clamp(0.0, (self.levels - 1) as f64)
    }

    /// The two levels to blend and the weight of the second: `(l0, l1, t)`.
    pub fn blend(&self, depth_m: f64) -> (usize, usize, f64) {
        let x = self.coordinate(depth_m);
        let l0 = (x.floor() as usize).min(self.levels - 1);
        (l0, (l0 + 1).min(self.levels - 1), x - l0 as f64)
    }
}

/// The lookup tables of the focus processor (layout in the module docs).
#[derive(Clone, Debug)]
pub struct PsfTables {
    /// Depth of each level in metres, nearest first (the last may be `∞`).
    pub depths_m: Vec<f64>,
    /// Signed geometric CoC radius of each level in pixels (negative in front of the focus).
    pub coc_radius_px: Vec<f64>,
    /// Per level and channel, the fraction of the pattern's energy inside the cut circle
    /// (before renormalisation), for offset 0.
    pub energy_kept: Vec<[f64; 3]>,
    /// Levels whose geometric CoC radius is larger than the cut circle.
    pub clipped_levels: usize,
    /// Whether the requested depth range reached beyond the clamp depths
    /// ([`CLAMP_COC_TABLE_RADII`]) and was shortened.
    pub depth_range_clamped: bool,
    /// Table half-size `R`: a table has `(2R+1)²` entries.
    pub radius_px: u32,
    pub subpixel: u32,
    pub mapping: LevelMapping,
    pub geometry: FocusGeometry,
    /// `[level][channel][offset][(2R+1)²]`, each table summing to 1.
    pub data: Vec<f32>,
}

impl PsfTables {
    pub fn levels(&self) -> usize {
        self.depths_m.len()
    }

    /// `2R + 1`.
    pub fn side(&self) -> usize {
        2 * self.radius_px as usize + 1
    }

    /// Entries per table, `(2R+1)²`.
    pub fn entries(&self) -> usize {
        self.side() * self.side()
    }

    /// Sub-pixel offsets per table set, `subpixel²`.
    pub fn offsets(&self) -> usize {
        (self.subpixel * self.subpixel) as usize
    }

    /// Index in `data` of the first entry of table (level, channel, offset).
    pub fn index(&self, level: usize, channel: usize, offset: usize) -> usize {
        ((level * 3 + channel) * self.offsets() + offset) * self.entries()
    }

    /// One table.
    pub fn table(&self, level: usize, channel: usize, offset: usize) -> &[f32] {
        let start = self.index(level, channel, offset);
        &self.data[start..start + self.entries()]
    }
}

/// Computes the focus processor's tables for depths `depth_min_m ..= depth_max_m` (the scene's
/// range; `depth_max_m` may be `∞`). Depths outside the range clamp to the end levels; so do
/// depths with a CoC radius beyond [`CLAMP_COC_TABLE_RADII`] table radii, whose range is
/// shortened (`depth_range_clamped`). A minimum of 0 or below (or nearer than the focal length)
/// is therefore fine: the nearest level is then the clamp depth. Levels with a CoC too large
/// for the table are cut and renormalised, reported by `clipped_levels` (and a log warning).
pub fn build_tables(
    lens: &ThinLens,
    pixel_pitch_mm: f64,
    depth_min_m: f64,
    depth_max_m: f64,
    settings: &PsfTableSettings,
) -> PsfTables {
    let geometry = FocusGeometry::new(lens, pixel_pitch_mm);
    let subpixel = settings.subpixel.max(1);
    let n = settings.integration_samples.max(1) as usize;
    let max_radius_px = settings.max_radius_px.max(1);

    // Depth range -> defocus range (1/m), sanitized: NaN means "unknown", taken as the far end.
    let clean = |d: f64, nan: f64| if d.is_nan() { nan } else { d };
    let (mut near, mut far) = (clean(depth_min_m, 0.0), clean(depth_max_m, f64::INFINITY));
    if near > far {
        std::mem::swap(&mut near, &mut far);
    }
    let inv_focus_per_m = geometry.inv_focus_distance_per_mm * 1000.0;
    let defocus_per_m = |d: f64| inv_focus_per_m - 1.0 / d.max(1e-30);
    // |coc|/2 = a v |w| <= CLAMP * R * pitch
    let px_per_defocus_m = geometry.aperture_radius_mm * geometry.image_distance_mm / pixel_pitch_mm * 1e-3;
    let w_clamp = CLAMP_COC_TABLE_RADII * max_radius_px as f64 / px_per_defocus_m;
    let (w_near_raw, w_far_raw) = (defocus_per_m(near), defocus_per_m(far));
    let w_near = w_near_raw.clamp(-w_clamp, w_clamp);
    let w_far = w_far_raw.clamp(-w_clamp, w_clamp).max(w_near);
    let depth_range_clamped = w_near != w_near_raw || w_far != w_far_raw;
    let mapping = LevelMapping::new(settings.depth_levels, inv_focus_per_m, w_near, w_far);
    let levels = mapping.levels;

    let defocus: Vec<f64> = (0..levels).map(|i| mapping.level_defocus_per_m(i)).collect();
    let depths_m: Vec<f64> = (0..levels).map(|i| mapping.level_depth_m(i)).collect();
    let coc_radius_px: Vec<f64> = defocus.iter().map(|w| w * px_per_defocus_m).collect();

    let largest_coc_px = coc_radius_px.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    let longest_nm = settings.wavelengths_nm.iter().fold(0.0f64, |m, &l| m.max(l));
    let halo_px = HALO_AIRY_RADII * geometry.airy_radius_px(longest_nm) + 1.0;
    let radius_px = ((largest_coc_px + halo_px).ceil() as u32).clamp(1, max_radius_px);
    let cut_px = radius_px as f64 + 0.5 - (subpixel - 1) as f64 / subpixel as f64;
    let clipped_levels = coc_radius_px.iter().filter(|r| r.abs() > cut_px).count();

    let side = 2 * radius_px as usize + 1;
    let entries = side * side;
    let offsets = (subpixel * subpixel) as usize;
    let per_task = offsets * entries;

    // One task per (level, channel), spread over the available cores.
    let tasks = levels * 3;
    let mut data = vec![0.0f32; tasks * per_task];
    let mut energy_kept = vec![[0.0f64; 3]; levels];
    let threads = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1).min(tasks).max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<Vec<(usize, Vec<f32>, f64)>> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let task = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if task >= tasks {
                            break done;
                        }
                        let (level, channel) = (task / 3, task % 3);
                        let spec = TableSpec {
                            geometry: &geometry,
                            defocus_per_mm: defocus[level] * 1e-3,
                            wavelength_nm: settings.wavelengths_nm[channel],
                            radius_px,
                            subpixel,
                            cut_px,
                            n,
                        };
                        let (tables, kept) = spec.compute();
                        done.push((task, tables, kept));
                    }
                })
            })
            .collect();
        // A worker's panic (a bug, not bad input) goes on with its own message.
        workers.into_iter().map(|w| w.join().unwrap_or_else(|p| std::panic::resume_unwind(p))).collect()
    });
    for (task, tables, kept) in results.into_iter().flatten() {
        data[task * per_task..(task + 1) * per_task].copy_from_slice(&tables);
        energy_kept[task / 3][task % 3] = kept;
    }
    if clipped_levels > 0 {
        log::warn!(
            "focus processor: {clipped_levels} of {levels} depth levels have a circle of confusion larger than the \
             {radius_px} px table (largest radius {largest_coc_px:.1} px); their patterns are cut and renormalised"
        );
    }
    PsfTables {
        depths_m,
        coc_radius_px,
        energy_kept,
        clipped_levels,
        depth_range_clamped,
        radius_px,
        subpixel,
        mapping,
        geometry,
        data,
    }
}

/// One (level, channel): its tables for every sub-pixel offset.
struct TableSpec<'a> {
    geometry: &'a FocusGeometry,
    defocus_per_mm: f64,
    wavelength_nm: f64,
    radius_px: u32,
    subpixel: u32,
    cut_px: f64,
    n: usize,
}

impl TableSpec<'_> {
    /// The tables of every offset (concatenated) and the energy fraction kept inside the cut.
    fn compute(&self) -> (Vec<f32>, f64) {
        let (u_opt, v_per_mm) = self.geometry.optical(self.defocus_per_mm, self.wavelength_nm);
        let v_per_px = v_per_mm * self.geometry.pixel_pitch_mm;
        // Energy of each annulus [j/n, (j+1)/n) px, cut at cut_px, as a fraction of the total.
        let step_px = 1.0 / self.n as f64;
        let annuli = (self.cut_px / step_px).ceil() as usize;
        let (nodes, weights) = gauss_legendre_rule(PANEL_NODES);
        let annulus_energy: Vec<(f64, f64)> = (0..annuli)
            .map(|j| {
                let (r0, r1) = (j as f64 * step_px, ((j + 1) as f64 * step_px).min(self.cut_px));
                let (v0, v1) = (r0 * v_per_px, r1 * v_per_px);
                let panels = (((v1 - v0) / PANEL_WIDTH_V).ceil() as usize).clamp(1, MAX_PANELS_PER_ANNULUS);
                let width = (v1 - v0) / panels as f64;
                let mut integral_v_dv = 0.0;
                for panel in 0..panels {
                    let mid = v0 + (panel as f64 + 0.5) * width;
                    for (x, wgt) in nodes.iter().zip(&weights) {
                        let v = mid + 0.5 * width * x;
                        integral_v_dv += 0.5 * width * wgt * psf_intensity(u_opt, v) * v;
                    }
                }
                (0.5 * (r0 + r1), 2.0 * PI * integral_v_dv / PSF_TOTAL_ENERGY_V2)
            })
            .collect();
        let kept: f64 = annulus_energy.iter().map(|&(_, e)| e).sum();

        let s = self.subpixel as usize;
        let r = self.radius_px as i64;
        let side = 2 * self.radius_px as usize + 1;
        let mut out = vec![0.0f32; s * s * side * side];
        let mut table = vec![0.0f64; side * side];
        for oy in 0..s {
            for ox in 0..s {
                table.iter_mut().for_each(|t| *t = 0.0);
                let (px, py) = (ox as f64 / s as f64, oy as f64 / s as f64);
                for &(radius, energy) in &annulus_energy {
                    // A multiple of 8 angles, offset by half a step: the points of one circle
                    // have the symmetries of the pixel grid (for offset 0) and avoid the axes.
                    let angles = ((2.0 * PI * radius * self.n as f64 / 8.0).ceil() as usize).max(1) * 8;
                    let share = energy / angles as f64;
                    for a in 0..angles {
                        let theta = 2.0 * PI * (a as f64 + 0.5) / angles as f64;
                        let (x, y) = (px + radius * theta.cos(), py + radius * theta.sin());
                        let dx = ((x + 0.5).floor() as i64).clamp(-r, r);
                        let dy = ((y + 0.5).floor() as i64).clamp(-r, r);
                        table[((dy + r) as usize) * side + (dx + r) as usize] += share;
                    }
                }
                let total: f64 = table.iter().sum();
                let scale = if total > 0.0 { 1.0 / total } else { 0.0 };
                let start = (oy * s + ox) * side * side;
                for (dst, &src) in out[start..start + side * side].iter_mut().zip(&table) {
                    *dst = (src * scale) as f32;
                }
                if total <= 0.0 {
                    out[start + (side * side) / 2] = 1.0; // no energy at all: keep the point
                }
            }
        }
        (out, kept)
    }
}

/// The running sums of eq 20 per output pixel: the numerator and the denominator (the sum of
/// the weights) of each colour. Splat samples, then [`FocusAccumulator::resolve`].
#[derive(Clone, Debug)]
pub struct FocusAccumulator {
    pub width: u32,
    pub height: u32,
    pub numerator: Vec<[f64; 3]>,
    pub denominator: Vec<[f64; 3]>,
}

impl FocusAccumulator {
    pub fn new(width: u32, height: u32) -> FocusAccumulator {
        let pixels = width as usize * height as usize;
        FocusAccumulator { width, height, numerator: vec![[0.0; 3]; pixels], denominator: vec![[0.0; 3]; pixels] }
    }

    /// Spread one point sample at image position `(x_px, y_px)` (pixel `(i, j)` spans
    /// `[i, i+1) x [j, j+1)`, its centre at `(i + 0.5, j + 0.5)`) through the table of its depth,
    /// interpolated between the two nearest levels. The position snaps to the nearest point of
    /// the tables' sub-pixel lattice. Non-finite colours count as 0.
    pub fn splat(&mut self, tables: &PsfTables, x_px: f64, y_px: f64, rgb: [f32; 3], depth_m: f32) {
        let s = tables.subpixel as i64;
        let snap = |p: f64| {
            let lattice = ((p - 0.5) * s as f64).round() as i64;
            (lattice.div_euclid(s), lattice.rem_euclid(s) as usize)
        };
        let ((ix, ox), (iy, oy)) = (snap(x_px), snap(y_px));
        let offset = oy * s as usize + ox;
        let rgb = rgb.map(|c| if c.is_finite() { c as f64 } else { 0.0 });
        let (l0, l1, t) = tables.mapping.blend(depth_m as f64);
        let tables0: [&[f32]; 3] = std::array::from_fn(|c| tables.table(l0, c, offset));
        let tables1: [&[f32]; 3] = std::array::from_fn(|c| tables.table(l1, c, offset));
        let r = tables.radius_px as i64;
        let side = tables.side();
        for dy in -r..=r {
            let y = iy + dy;
            if y < 0 || y >= self.height as i64 {
                continue;
            }
            for dx in -r..=r {
                let x = ix + dx;
                if x < 0 || x >= self.width as i64 {
                    continue;
                }
                let e = (dy + r) as usize * side + (dx + r) as usize;
                let w: [f64; 3] = std::array::from_fn(|c| (1.0 - t) * tables0[c][e] as f64 + t * tables1[c][e] as f64);
                let p = y as usize * self.width as usize + x as usize;
                for c in 0..3 {
                    self.numerator[p][c] += w[c] * rgb[c];
                    self.denominator[p][c] += w[c];
                }
            }
        }
    }

    /// Numerators divided by the denominators (0 where no sample reached).
    pub fn resolve(&self) -> Vec<[f64; 3]> {
        self.numerator
            .iter()
            .zip(&self.denominator)
            .map(|(num, den)| std::array::from_fn(|c| if den[c] > 0.0 { num[c] / den[c] } else { 0.0 }))
            .collect()
    }
}

/// The focus processor on an RGBA image with per-pixel depth (metres, planar): every pixel is
/// a point sample at its centre (sub-pixel offset 0). Alpha passes through. The reference for
/// the GPU pass [`crate::passes::dof::diffraction`].
pub fn process_cpu(rgba: &[f32], depth_m: &[f32], width: u32, height: u32, tables: &PsfTables) -> Vec<f32> {
    let pixels = width as usize * height as usize;
    assert_eq!(rgba.len(), pixels * 4, "rgba must hold width x height x 4 values");
    assert_eq!(depth_m.len(), pixels, "depth must hold width x height values");
    let mut acc = FocusAccumulator::new(width, height);
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let rgb = [rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2]];
            acc.splat(tables, x as f64 + 0.5, y as f64 + 0.5, rgb, depth_m[i]);
        }
    }
    acc.resolve()
        .iter()
        .zip(rgba.chunks_exact(4))
        .flat_map(|(c, px)| [c[0] as f32, c[1] as f32, c[2] as f32, px[3]])
        .collect()
}

/// One point sample of the paper's hidden-surface processor: position in pixels (see
/// [`FocusAccumulator::splat`]), colour and depth in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSample {
    pub x_px: f64,
    pub y_px: f64,
    pub rgb: [f32; 3],
    pub depth_m: f32,
}

/// The focus processor on arbitrary point samples (e.g. the paper's adaptive 2x2
/// supersampling, whose positions lie on the half-pixel lattice: use `subpixel = 2`). Returns
/// RGB per pixel; the denominators make the result independent of the local sample
/// density.
pub fn process_samples_cpu(samples: &[PointSample], width: u32, height: u32, tables: &PsfTables) -> Vec<[f64; 3]> {
    let mut acc = FocusAccumulator::new(width, height);
    for s in samples {
        acc.splat(tables, s.x_px, s.y_px, s.rgb, s.depth_m);
    }
    acc.resolve()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::diffraction::encircled_energy;

    /// f/16 so that diffraction is visible at the 11.2 µm pitch (Airy radius about 1 px) while
    /// the far CoC (radius 12 px at infinity) is still mostly geometric (u_opt about 44).
    fn lens() -> ThinLens {
        ThinLens::new(50.0, 16.0, 630.0).unwrap()
    }
    const PITCH_MM: f64 = 0.0112;

    fn small_settings() -> PsfTableSettings {
        PsfTableSettings { depth_levels: 9, subpixel: 2, max_radius_px: 16, ..Default::default() }
    }

    #[test]
    fn the_geometric_edge_of_the_psf_is_half_the_thin_lens_coc() {
        for lens in [lens(), ThinLens::new(35.0, 2.0, 1200.0).unwrap().with_pupil_magnification(0.6).unwrap()] {
            let g = FocusGeometry::new(&lens, PITCH_MM);
            for depth_m in [0.02, 0.034, 0.3, 0.63, 1.2, 7.0, 1e10, f64::INFINITY] {
                let w = g.defocus_per_mm(depth_m);
                let coc_mm = lens.coc_mm(depth_m * 1000.0);
                let radius_mm = g.coc_radius_mm(w);
                assert!((radius_mm - 0.5 * coc_mm).abs() <= 1e-12 * coc_mm.abs().max(1e-3), "{depth_m} m");
                for wavelength_nm in WAVELENGTHS_RGB_NM {
                    let (u, v_per_mm) = g.optical(w, wavelength_nm);
                    let v_edge = v_per_mm * radius_mm.abs();
                    assert!((v_edge - u.abs()).abs() <= 1e-9 * u.abs().max(1.0), "{depth_m} m, {wavelength_nm} nm");
                }
            }
        }
        // Symmetric lens: a = f / 2N; in focus, the Airy ring at 1.22 λ N'.
        let g = FocusGeometry::new(&lens(), PITCH_MM);
        assert!((g.aperture_radius_mm - 50.0 / 32.0).abs() < 1e-12);
        let n_eff = lens().effective_f_number();
        assert!((g.airy_radius_px(550.0) * PITCH_MM - 1.2196698 * 550e-6 * n_eff).abs() < 1e-9);
    }

    #[test]
    fn levels_are_uniform_in_inverse_depth_with_one_on_the_focus_distance() {
        let m = LevelMapping::new(9, 1.0 / 0.63, 1.0 / 0.63 - 1.0 / 0.4, 1.0 / 0.63);
        let k = m.knot_level;
        assert!(k > 0 && k < 8);
        assert_eq!(m.level_defocus_per_m(k), 0.0);
        assert!((m.level_depth_m(k) - 0.63).abs() < 1e-12);
        assert!((m.level_depth_m(0) - 0.4).abs() < 1e-12);
        assert_eq!(m.level_depth_m(8), f64::INFINITY);
        for i in 0..9 {
            let x = m.coordinate(m.level_depth_m(i));
            assert!((x - i as f64).abs() < 1e-9, "level {i}: {x}");
        }
        // Clamping: nearer than the nearest level, zero, negative -> 0; NaN, ∞ -> last.
        for d in [0.3, 0.01, 0.0, -1.0, f64::NEG_INFINITY] {
            assert_eq!(m.coordinate(d), 0.0, "{d}");
        }
        for d in [f64::NAN, f64::INFINITY, 1e30] {
            assert_eq!(m.coordinate(d), 8.0, "{d}");
        }
        // Monotone in depth.
        let mut previous = -1.0;
        for i in 0..200 {
            let x = m.coordinate(0.35 + 0.05 * i as f64);
            assert!(x >= previous);
            previous = x;
        }
        // Degenerate ranges.
        let single = LevelMapping::new(1, 1.0, -0.5, 0.5);
        assert_eq!(single.coordinate(2.0), 0.0);
        let flat = LevelMapping::new(5, 1.0, 0.2, 0.2);
        assert_eq!(flat.coordinate(0.1), 0.0);
        assert_eq!(flat.coordinate(10.0), 0.0);
    }

    #[test]
    fn every_table_sums_to_one_and_is_finite() {
        let t = build_tables(&lens(), PITCH_MM, 0.0, f64::INFINITY, &small_settings());
        assert_eq!(t.data.len(), t.levels() * 3 * t.offsets() * t.entries());
        assert!(t.data.iter().all(|v| v.is_finite() && *v >= 0.0));
        for l in 0..t.levels() {
            for c in 0..3 {
                for o in 0..t.offsets() {
                    let sum: f64 = t.table(l, c, o).iter().map(|&v| v as f64).sum();
                    assert!((sum - 1.0).abs() < 1e-5, "level {l} channel {c} offset {o}: {sum}");
                }
            }
        }
        // Depth 0 was clamped where the CoC is 2 table radii; those levels are clipped.
        assert!(t.depth_range_clamped);
        assert!(t.clipped_levels > 0);
        assert!(t.depths_m[0] > 0.0 && t.depths_m[0].is_finite());
        assert!(t.energy_kept[0].iter().all(|&e| e > 0.0 && e < 0.5));
    }

    #[test]
    fn offset_zero_tables_have_the_symmetry_of_the_pixel_grid() {
        let t = build_tables(&lens(), PITCH_MM, 0.4, 1e10, &small_settings());
        let (r, side) = (t.radius_px as usize, t.side());
        for l in 0..t.levels() {
            let table = t.table(l, 1, 0);
            for y in 0..side {
                for x in 0..side {
                    let v = table[y * side + x];
                    for (xx, yy) in [(2 * r - x, y), (x, 2 * r - y), (y, x)] {
                        let other = table[yy * side + xx];
                        assert!((v - other).abs() <= 1e-6 * v.abs().max(1e-3), "level {l} ({x}, {y})");
                    }
                }
            }
        }
    }

    #[test]
    fn in_focus_table_is_the_airy_pattern_integrated_over_pixels() {
        let t = build_tables(&lens(), PITCH_MM, 0.4, 1e10, &small_settings());
        let k = t.mapping.knot_level;
        assert!((t.depths_m[k] - 0.63).abs() < 1e-12);
        let side = t.side();
        let r = t.radius_px as usize;
        let g = FocusGeometry::new(&lens(), PITCH_MM);
        for (c, &wavelength_nm) in WAVELENGTHS_RGB_NM.iter().enumerate() {
            let table = t.table(k, c, 0);
            let (_, v_per_mm) = g.optical(0.0, wavelength_nm);
            let v_per_px = v_per_mm * PITCH_MM;
            // The 3x3 block holds at least the disk of radius 1.5 px, at most that of 1.5 √2.
            let block: f64 = (r - 1..=r + 1)
                .flat_map(|y| (r - 1..=r + 1).map(move |x| (x, y)))
                .map(|(x, y)| table[y * side + x] as f64)
                .sum();
            let kept = t.energy_kept[k][c];
            let lower = encircled_energy(0.0, 1.5 * v_per_px) / kept;
            let upper = encircled_energy(0.0, 1.5 * 2f64.sqrt() * v_per_px) / kept;
            assert!(block >= lower - 0.01 && block <= upper + 0.01, "channel {c}: {lower} <= {block} <= {upper}");
        }
    }

    #[test]
    fn a_sub_pixel_psf_lands_in_its_pixel() {
        // Huge pixels (0.2 mm) at f/2: the in-focus Airy disk is 1/100 of a pixel.
        let lens = ThinLens::new(50.0, 2.0, 2000.0).unwrap();
        let settings = PsfTableSettings { depth_levels: 3, subpixel: 2, max_radius_px: 4, ..Default::default() };
        let t = build_tables(&lens, 0.2, 1.9, 2.1, &settings);
        let k = t.mapping.knot_level;
        let centre = t.entries() / 2;
        for c in 0..3 {
            assert!(t.table(k, c, 0)[centre] > 0.99, "channel {c}: {}", t.table(k, c, 0)[centre]);
            // Offset (1/2, 1/2): the point on a pixel corner, split in four.
            let corner = t.table(k, c, 3);
            let side = t.side();
            let four = [centre, centre + 1, centre + side, centre + side + 1];
            for e in four {
                assert!((corner[e] - 0.25).abs() < 0.01, "channel {c}: {}", corner[e]);
            }
        }
    }

    #[test]
    fn uniform_image_at_one_depth_stays_uniform_including_the_borders() {
        let t = build_tables(&lens(), PITCH_MM, 0.4, 1e10, &small_settings());
        let (w, h) = (40u32, 36u32);
        let rgba: Vec<f32> = (0..w * h).flat_map(|_| [0.25f32, 0.5, 1.0, 0.75]).collect();
        for depth in [1e10f32, 0.63, 0.4, 0.5] {
            let out = process_cpu(&rgba, &vec![depth; (w * h) as usize], w, h, &t);
            for (a, b) in out.iter().zip(&rgba) {
                assert!((a - b).abs() < 1e-6 * b, "depth {depth}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn a_point_conserves_energy_and_supersampling_keeps_the_image() {
        let t = build_tables(&lens(), PITCH_MM, 0.4, 1e10, &small_settings());
        // Farther than 2R from the borders: neither the point nor the pixels it reaches miss
        // any sample, so every denominator it meets is 1.
        let (w, h) = (72u32, 72u32);
        let mut rgba = vec![0.0f32; (w * h * 4) as usize];
        let i = (36 * w + 36) as usize;
        rgba[4 * i..4 * i + 3].copy_from_slice(&[1.0, 2.0, 3.0]);
        for depth in [1e10f32, 0.63, 0.45] {
            let out = process_cpu(&rgba, &vec![depth; (w * h) as usize], w, h, &t);
            for c in 0..3 {
                let sum: f64 = out.chunks_exact(4).map(|p| p[c] as f64).sum();
                assert!((sum - (c + 1) as f64).abs() < 1e-5, "depth {depth} channel {c}: {sum}");
            }
        }
        // The same smooth image sampled once per pixel and 2x2 per pixel: the denominator
        // cancels the sample density.
        let colour = |x: f64, y: f64| [(x * 0.05) as f32, (y * 0.05) as f32, 0.5];
        let (w, h) = (40u32, 36u32);
        let mut single = Vec::new();
        let mut quad = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
                single.push(PointSample { x_px: cx, y_px: cy, rgb: colour(cx, cy), depth_m: 1e10 });
                for (ox, oy) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                    let (sx, sy) = (cx + ox, cy + oy);
                    quad.push(PointSample { x_px: sx, y_px: sy, rgb: colour(sx, sy), depth_m: 1e10 });
                }
            }
        }
        let settings = PsfTableSettings { subpixel: 4, ..small_settings() };
        let t4 = build_tables(&lens(), PITCH_MM, 0.4, 1e10, &settings);
        let a = process_samples_cpu(&single, w, h, &t4);
        let b = process_samples_cpu(&quad, w, h, &t4);
        let mut worst = 0.0f64;
        for (i, (p, q)) in a.iter().zip(&b).enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            // Within the table radius of the borders the weighted mean of the gradient is
            // pulled inwards, by different amounts for the two sample sets.
            if (16..w - 16).contains(&x) && (16..h - 16).contains(&y) {
                for c in 0..3 {
                    worst = worst.max((p[c] - q[c]).abs());
                }
            }
        }
        println!("1 vs 2x2 samples per pixel: worst difference {worst:.2e}");
        assert!(worst < 1e-4, "{worst}");
    }

    #[test]
    fn clipped_levels_are_reported_and_renormalised() {
        let settings = PsfTableSettings {
            depth_levels: 5,
            subpixel: 1,
            max_radius_px: 6,
            integration_samples: 2,
            ..Default::default()
        };
        let t = build_tables(&lens(), PITCH_MM, 0.4, 1e10, &settings);
        assert_eq!(t.radius_px, 6);
        assert!(t.clipped_levels >= 2, "{}", t.clipped_levels);
        let last = t.levels() - 1;
        assert!(t.coc_radius_px[last] > 11.9);
        assert!(t.energy_kept[last][1] < 0.4);
        let sum: f64 = t.table(last, 1, 0).iter().map(|&v| v as f64).sum();
        assert!((sum - 1.0).abs() < 1e-5);
    }
}
