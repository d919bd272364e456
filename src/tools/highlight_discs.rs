//! The areas of the defocused discs of isolated highlights, measured in a test image and in a
//! reference (`realcam compare TEST REFERENCE --highlights camera.json --fstop N`).
//!
//! A highlight is a small bright object whose position (px) and planar depth (m) a scene
//! description lists (Blender scene A's `camera.json`: the objects with a role `highlight_*`).
//! Its disc's area is measured as **its energy over its plateau**:
//!
//! 1. A window around the highlight from the renderers' thin lens (the predicted CoC radius
//!    plus the object's own radius): the disc (radius `disc_px`), a plateau well inside it
//!    (`plateau_px`), and an annulus outside it (`disc_px` to `outer_px`) for the background.
//! 2. The background is a plane a + b x + c y fitted to the annulus's luminance by least squares
//!    with outliers beyond 3 robust standard deviations (1.4826 MAD) rejected, three rounds: a
//!    gradient or a neighbouring object's edge in the annulus does not leak into the disc.
//! 3. The plateau is the mean of the background-subtracted luminance within `plateau_px`, values
//!    beyond 3 robust standard deviations of its median left out (a median alone sticks to the
//!    few levels a path tracer's pixels take there, about 5% off on Cycles' discs).
//! 4. The area is the sum of the background-subtracted luminance within `disc_px` over the
//!    plateau.
//!
//! A disc that is an object's image blurred by the aperture (and by a pixel filter) has the
//! energy of the object and, where the blur kernel lies wholly inside the aperture's shape, the
//! plateau energy / aperture area: energy over plateau is the aperture's area on the film, the
//! same for a point or a sphere a few pixels wide and for any pixel filter, as long as the
//! plateau exists. The estimate's 1-sigma noise is propagated from the spread of the annulus
//! (background) and of the plateau (the disc's own noise, a path tracer's samples), counting
//! pixels as independent: a pixel filter wider than a pixel correlates neighbours, so the true
//! noise is somewhat larger.
//!
//! A highlight is not measurable (and reported with the reason, not as a failure) when its disc
//! or most of its annulus leaves the frame, when another listed highlight's disc reaches its
//! disc or annulus, or when the disc is too small for a plateau (in focus).

use crate::optics::lens::ThinLens;
use serde_json::Value as Json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Rec. 709 luminance weights, applied to the RGB of RGBA.
const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// A row's note names a structured background when its bound exceeds this share of the area.
pub const BACKGROUND_NOTE: f64 = 0.01;

/// A disc whose plateau radius is below this has no measurable plateau.
pub const MIN_PLATEAU_PX: f64 = 1.5;

/// The margin outside the predicted disc for the pixel filter and the object's edge, px.
const EDGE_MARGIN_PX: f64 = 3.0;

/// The disc window's radius over the predicted radius: room for a model 15% larger.
const DISC_SLACK: f64 = 1.15;

/// Errors reading a scene description or comparing with it.
#[derive(Debug, Error)]
pub enum HighlightsError {
    #[error("highlights: cannot read \"{}\": {source}", .path.display())]
    Read { path: PathBuf, source: std::io::Error },
    #[error("highlights: \"{}\": invalid JSON: {source}", .path.display())]
    Json { path: PathBuf, source: serde_json::Error },
    /// A field missing or of the wrong kind, by its path in the document (`objects[3].depth_m`).
    #[error("highlights: \"{}\": field \"{field}\" {problem}", .path.display())]
    Field { path: PathBuf, field: String, problem: String },
    #[error("highlights: \"{}\" lists no object with a role starting with \"highlight\"", .path.display())]
    NoHighlights { path: PathBuf },
    #[error("highlights: the images are {image_w}x{image_h} px but \"{}\" field \"camera.resolution\" is {scene_w}x{scene_h}", .path.display())]
    SizeMismatch { path: PathBuf, image_w: u32, image_h: u32, scene_w: u32, scene_h: u32 },
    #[error("highlights: --fstop must be a finite number above 0, got {0}")]
    FNumber(f64),
}

/// One highlight of the scene description.
#[derive(Clone, Debug, PartialEq)]
pub struct Highlight {
    pub name: String,
    /// Planar depth, m.
    pub depth_m: f64,
    /// Centre in pixels, x right and y down from the frame's top-left corner (pixel (i, j)
    /// covers [i, i+1) x [j, j+1)).
    pub x_px: f64,
    pub y_px: f64,
    /// The object's own radius on the film, px (0 for a point).
    pub radius_px: f64,
}

/// The camera and highlights of a scene description.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneHighlights {
    pub path: PathBuf,
    pub focal_length_mm: f64,
    pub pixel_pitch_mm: f64,
    pub focus_distance_m: f64,
    pub width_px: u32,
    pub height_px: u32,
    pub highlights: Vec<Highlight>,
}

/// What a JSON value is, for error messages.
fn kind(v: &Json) -> &'static str {
    match v {
        Json::Null => "null",
        Json::Bool(_) => "a boolean",
        Json::Number(_) => "a number",
        Json::String(_) => "a string",
        Json::Array(_) => "an array",
        Json::Object(_) => "an object",
    }
}

impl SceneHighlights {
    /// Read a Blender `camera.json` (scene A's format): `camera.focal_length_mm`,
    /// `camera.pixel_pitch_mm`, `camera.resolution`, `ground_truth.dof.focus_distance_m`, and the
    /// `objects` whose `role` starts with "highlight" (`name`, `depth_m`,
    /// `pixel_xy_topleft_ydown`, optionally `approx_diameter_px`).
    pub fn read(path: &Path) -> Result<Self, HighlightsError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| HighlightsError::Read { path: path.into(), source })?;
        Self::parse(path, &text)
    }

    /// [`read`](Self::read) from text (`path` names it in errors).
    pub fn parse(path: &Path, text: &str) -> Result<Self, HighlightsError> {
        let doc: Json =
            serde_json::from_str(text).map_err(|source| HighlightsError::Json { path: path.into(), source })?;
        let field =
            |field: &str, problem: String| HighlightsError::Field { path: path.into(), field: field.into(), problem };
        // The value at a dotted path of object members.
        let at = |name: &str| -> Result<&Json, HighlightsError> {
            name.split('.').try_fold(&doc, |v, key| v.get(key).ok_or_else(|| field(name, "is missing".into())))
        };
        let number = |name: &str, v: &Json, positive: bool| -> Result<f64, HighlightsError> {
            match v.as_f64() {
                Some(x) if !positive || x > 0.0 => Ok(x),
                Some(x) => Err(field(name, format!("must be above 0, got {x}"))),
                None => Err(field(name, format!("must be a number, got {}", kind(v)))),
            }
        };
        let pair = |name: &str, v: &Json| -> Result<[f64; 2], HighlightsError> {
            match v.as_array().map(Vec::as_slice) {
                Some([a, b]) => Ok([number(name, a, false)?, number(name, b, false)?]),
                _ => Err(field(name, format!("must be an array of two numbers, got {}", kind(v)))),
            }
        };
        let focal_length_mm = number("camera.focal_length_mm", at("camera.focal_length_mm")?, true)?;
        let pixel_pitch_mm = number("camera.pixel_pitch_mm", at("camera.pixel_pitch_mm")?, true)?;
        let focus_distance_m =
            number("ground_truth.dof.focus_distance_m", at("ground_truth.dof.focus_distance_m")?, true)?;
        let [w, h] = pair("camera.resolution", at("camera.resolution")?)?;
        if !(w >= 1.0 && h >= 1.0 && w.fract() == 0.0 && h.fract() == 0.0 && w.max(h) <= 65536.0) {
            return Err(field("camera.resolution", format!("must be two whole numbers of pixels, got [{w}, {h}]")));
        }
        let objects = at("objects")?
            .as_array()
            .ok_or_else(|| field("objects", format!("must be an array, got {}", at("objects").map_or("", kind))))?;
        let mut highlights = Vec::new();
        for (i, object) in objects.iter().enumerate() {
            let member = |key: &str| -> Result<&Json, HighlightsError> {
                object.get(key).ok_or_else(|| field(&format!("objects[{i}].{key}"), "is missing".into()))
            };
            let role = member("role")?;
            let role = role
                .as_str()
                .ok_or_else(|| field(&format!("objects[{i}].role"), format!("must be a string, got {}", kind(role))))?;
            if !role.starts_with("highlight") {
                continue;
            }
            let name = member("name")?;
            let name = name
                .as_str()
                .ok_or_else(|| field(&format!("objects[{i}].name"), format!("must be a string, got {}", kind(name))))?;
            let depth_m = number(&format!("objects[{i}].depth_m"), member("depth_m")?, true)?;
            let xy_name = format!("objects[{i}].pixel_xy_topleft_ydown");
            let [x_px, y_px] = pair(&xy_name, member("pixel_xy_topleft_ydown")?)?;
            let d_name = format!("objects[{i}].approx_diameter_px");
            let radius_px = match object.get("approx_diameter_px") {
                Some(d) => match number(&d_name, d, false)? {
                    d if d >= 0.0 => 0.5 * d,
                    d => return Err(field(&d_name, format!("must be 0 or more, got {d}"))),
                },
                None => 0.0,
            };
            highlights.push(Highlight { name: name.into(), depth_m, x_px, y_px, radius_px });
        }
        if highlights.is_empty() {
            return Err(HighlightsError::NoHighlights { path: path.into() });
        }
        Ok(SceneHighlights {
            path: path.into(),
            focal_length_mm,
            pixel_pitch_mm,
            focus_distance_m,
            width_px: w as u32,
            height_px: h as u32,
            highlights,
        })
    }
}

/// Where a disc is measured: centre and radii in pixels (see the module's steps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscWindow {
    pub x_px: f64,
    pub y_px: f64,
    /// The predicted disc's outer radius: the CoC's radius plus the object's.
    pub radius_px: f64,
    pub plateau_px: f64,
    pub disc_px: f64,
    pub outer_px: f64,
}

impl DiscWindow {
    /// The window of a disc of CoC radius `coc_radius_px` (the circumradius of a polygonal
    /// aperture) around an object of radius `object_radius_px`.
    pub fn new(x_px: f64, y_px: f64, coc_radius_px: f64, object_radius_px: f64) -> Self {
        let radius_px = coc_radius_px + object_radius_px;
        // Inside the inscribed circle of a hexagon (cos 30 of the circumradius) by the object's
        // radius and the pixel filter's reach; at most half the radius.
        let plateau_px = (0.5 * coc_radius_px).min(0.866 * coc_radius_px - object_radius_px - 2.0);
        let disc_px = DISC_SLACK * radius_px + EDGE_MARGIN_PX;
        let outer_px = disc_px + (0.35 * radius_px).max(4.0);
        DiscWindow { x_px, y_px, radius_px, plateau_px, disc_px, outer_px }
    }
}

/// One image's measurement of a disc.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscArea {
    /// Energy over plateau, px².
    pub area_px2: f64,
    /// 1-sigma noise of `area_px2` (independent pixels), px².
    pub sigma_area_px2: f64,
    /// Background-subtracted luminance summed within the disc window.
    pub energy: f64,
    /// Background-subtracted luminance within the plateau radius (the clipped mean).
    pub plateau: f64,
    /// Robust standard deviation of the annulus about the fitted plane (luminance).
    pub background_sigma: f64,
    /// The area error if the background under the disc were off the plane by
    /// `background_sigma` everywhere (a structured background: a checker's edge, text), px²: a
    /// bound, not noise. Noise alone gives sqrt(pixels) times less.
    pub background_bound_px2: f64,
    /// The fitted plane's luminance at the centre and its gradient (per px, x and y).
    pub background: [f64; 3],
    /// Pixels of the plateau, the disc window and the annulus (inside the frame).
    pub pixels: [usize; 3],
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// 1.4826 times the median absolute deviation from `centre`: the standard deviation of normal
/// noise, not moved by a few outliers.
fn robust_sigma(values: &[f64], centre: f64) -> f64 {
    let mut dev: Vec<f64> = values.iter().map(|v| (v - centre).abs()).collect();
    1.4826 * median(&mut dev)
}

/// The mean of the values within 3 robust standard deviations of their median, their standard
/// deviation and how many: robust against outliers like the median, but not stuck to one of the
/// few levels a path tracer's pixels take (a pixel's value is its count of hits on a small light
/// times a constant, so a disc's pixels share a few values some 5% apart, and so would the
/// median).
fn clipped_mean(values: &mut [f64]) -> (f64, f64, usize) {
    let centre = median(values);
    let sigma = robust_sigma(values, centre);
    let kept: Vec<f64> = values.iter().copied().filter(|v| (v - centre).abs() <= 3.0 * sigma).collect();
    if kept.is_empty() {
        return (centre, 0.0, values.len());
    }
    let n = kept.len() as f64;
    let mean = kept.iter().sum::<f64>() / n;
    let sd =
        if kept.len() > 1 { (kept.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() } else { 0.0 };
    (mean, sd, kept.len())
}

/// Least-squares plane v = a + b dx + c dy through `samples` (dx, dy, v); None if singular.
fn fit_plane(samples: &[(f64, f64, f64)]) -> Option<[f64; 3]> {
    let (mut m, mut r) = ([[0.0f64; 3]; 3], [0.0f64; 3]);
    for &(x, y, v) in samples {
        let basis = [1.0, x, y];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += basis[i] * basis[j];
            }
            r[i] += basis[i] * v;
        }
    }
    // Cramer's rule on the 3x3 normal equations.
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    if d.abs() < 1e-12 * m[0][0].powi(3).max(1.0) {
        return None;
    }
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut mk = m;
        for i in 0..3 {
            mk[i][k] = r[i];
        }
        *o = det(&mk) / d;
    }
    Some(out)
}

/// Measure the disc in `window` of an RGBA image `width` x `height` (luminance of RGB;
/// non-finite values count as 0). The caller checks that the window is inside the frame.
pub fn measure_disc(width: u32, height: u32, rgba: &[f32], window: &DiscWindow) -> DiscArea {
    let w = window;
    let lum = |x: i64, y: i64| -> f64 {
        let i = 4 * (y as usize * width as usize + x as usize);
        (0..3).map(|c| if rgba[i + c].is_finite() { rgba[i + c] as f64 * LUMINANCE[c] } else { 0.0 }).sum()
    };
    let x0 = ((w.x_px - w.outer_px).floor() as i64).max(0);
    let x1 = ((w.x_px + w.outer_px).ceil() as i64).min(width as i64 - 1);
    let y0 = ((w.y_px - w.outer_px).floor() as i64).max(0);
    let y1 = ((w.y_px + w.outer_px).ceil() as i64).min(height as i64 - 1);
    // (dx, dy, luminance) of the pixels whose centres lie in each zone.
    let (mut annulus, mut disc) = (Vec::new(), Vec::new());
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (dx, dy) = (x as f64 + 0.5 - w.x_px, y as f64 + 0.5 - w.y_px);
            let r = dx.hypot(dy);
            if r < w.disc_px {
                disc.push((dx, dy, lum(x, y)));
            } else if r < w.outer_px {
                annulus.push((dx, dy, lum(x, y)));
            }
        }
    }
    // The background plane, outliers rejected.
    let mut kept = annulus.clone();
    let mut plane = [0.0; 3];
    let mut sigma = 0.0;
    for _ in 0..3 {
        plane = fit_plane(&kept).unwrap_or_else(|| {
            let mut v: Vec<f64> = kept.iter().map(|s| s.2).collect();
            [median(&mut v), 0.0, 0.0]
        });
        let residual = |s: &(f64, f64, f64)| s.2 - (plane[0] + plane[1] * s.0 + plane[2] * s.1);
        let res: Vec<f64> = annulus.iter().map(residual).collect();
        sigma = robust_sigma(&res, 0.0);
        let limit = 3.0 * sigma.max(1e-12);
        let next: Vec<_> = annulus.iter().copied().filter(|s| residual(s).abs() <= limit).collect();
        if next.len() < 3 || next.len() == kept.len() {
            if next.len() >= 3 {
                kept = next;
            }
            break;
        }
        kept = next;
    }
    let bg = |dx: f64, dy: f64| plane[0] + plane[1] * dx + plane[2] * dy;
    let energy: f64 = disc.iter().map(|&(dx, dy, v)| v - bg(dx, dy)).sum();
    let mut plateau_values: Vec<f64> =
        disc.iter().filter(|&&(dx, dy, _)| dx.hypot(dy) < w.plateau_px).map(|&(dx, dy, v)| v - bg(dx, dy)).collect();
    let (plateau, plateau_sigma, n_plateau) = clipped_mean(&mut plateau_values);
    let area_px2 = energy / plateau;
    // Noise: the disc's pixels carry the plateau's spread, the rest of the window the
    // background's; the plane's offset is known to sigma / sqrt(annulus pixels) and counts once
    // per window pixel; the median of n normal values has sigma 1.2533 s / sqrt(n).
    let (n_disc, n_annulus) = (disc.len(), kept.len().max(1));
    let inside = area_px2.clamp(0.0, n_disc as f64);
    let energy_var = inside * plateau_sigma.powi(2)
        + (n_disc as f64 - inside) * sigma.powi(2)
        + (n_disc as f64 * sigma).powi(2) / n_annulus as f64;
    let plateau_var = plateau_sigma.powi(2) / n_plateau.max(1) as f64;
    let rel = (energy_var / energy.powi(2) + plateau_var / plateau.powi(2)).sqrt();
    DiscArea {
        area_px2,
        sigma_area_px2: (rel * area_px2).abs(),
        energy,
        plateau,
        background_sigma: sigma,
        background_bound_px2: (sigma * n_disc as f64 / plateau).abs(),
        background: plane,
        pixels: [plateau_values.len(), n_disc, annulus.len()],
    }
}

/// Why a highlight was not measured.
#[derive(Clone, Debug, PartialEq)]
pub enum NotMeasurable {
    /// The disc window leaves the frame, or most of the annulus does.
    Clipped,
    /// Another listed highlight's disc reaches this one's disc or annulus.
    Overlaps(String),
    /// The predicted plateau radius (px) is below [`MIN_PLATEAU_PX`].
    NoPlateau(f64),
    /// A plateau at or below zero (no disc above the background) in the named image.
    NoDisc(&'static str),
}

impl std::fmt::Display for NotMeasurable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NotMeasurable::Clipped => write!(f, "clipped by the frame's edge"),
            NotMeasurable::Overlaps(other) => write!(f, "overlaps {other}"),
            NotMeasurable::NoPlateau(r) => write!(f, "no plateau (in focus: plateau radius {r:.1} px)"),
            NotMeasurable::NoDisc(which) => write!(f, "no disc above the background in the {which}"),
        }
    }
}

/// One highlight's row of the report.
#[derive(Clone, Debug, PartialEq)]
pub struct HighlightRow {
    pub name: String,
    pub depth_m: f64,
    /// The renderers' thin-lens CoC radius at the highlight's depth, px.
    pub coc_radius_px: f64,
    pub window: DiscWindow,
    /// The test's and the reference's measurements, or why there are none.
    pub result: Result<(DiscArea, DiscArea), NotMeasurable>,
}

impl HighlightRow {
    /// Test area over reference area, and its 1-sigma noise.
    pub fn ratio(&self) -> Option<(f64, f64)> {
        let (t, r) = self.result.as_ref().ok()?;
        let ratio = t.area_px2 / r.area_px2;
        let rel = ((t.sigma_area_px2 / t.area_px2).powi(2) + (r.sigma_area_px2 / r.area_px2).powi(2)).sqrt();
        Some((ratio, ratio * rel))
    }
}

/// Every highlight's row.
#[derive(Clone, Debug, PartialEq)]
pub struct HighlightReport {
    pub f_number: f64,
    pub rows: Vec<HighlightRow>,
}

/// Measure every highlight of `scene` in `test` and `reference` (RGBA, the scene's resolution)
/// at f-number `f_number`, the renderers' thin lens focused at the scene's focus distance.
pub fn compare_highlights(
    scene: &SceneHighlights,
    f_number: f64,
    width: u32,
    height: u32,
    test: &[f32],
    reference: &[f32],
) -> Result<HighlightReport, HighlightsError> {
    if (width, height) != (scene.width_px, scene.height_px) {
        return Err(HighlightsError::SizeMismatch {
            path: scene.path.clone(),
            image_w: width,
            image_h: height,
            scene_w: scene.width_px,
            scene_h: scene.height_px,
        });
    }
    let lens = ThinLens::new(scene.focal_length_mm, f_number, scene.focus_distance_m * 1000.0)
        .map_err(|_| HighlightsError::FNumber(f_number))?;
    let windows: Vec<(f64, DiscWindow)> = scene
        .highlights
        .iter()
        .map(|h| {
            let coc_radius_px = 0.5 * lens.coc_renderer_mm(h.depth_m * 1000.0).abs() / scene.pixel_pitch_mm;
            (coc_radius_px, DiscWindow::new(h.x_px, h.y_px, coc_radius_px, h.radius_px))
        })
        .collect();
    let (w, h) = (width as f64, height as f64);
    let rows = scene
        .highlights
        .iter()
        .zip(&windows)
        .enumerate()
        .map(|(i, (hl, &(coc_radius_px, win)))| {
            let inside = |r: f64| win.x_px - r >= 0.0 && win.y_px - r >= 0.0 && win.x_px + r <= w && win.y_px + r <= h;
            // The annulus's share inside the frame, on a 0.5 px grid.
            let annulus_share = {
                let (mut all, mut kept) = (0usize, 0usize);
                let n = (2.0 * win.outer_px / 0.5).ceil() as i64;
                for j in -n..=n {
                    for k in -n..=n {
                        let (dx, dy) = (0.5 * j as f64, 0.5 * k as f64);
                        let r = dx.hypot(dy);
                        if r >= win.disc_px && r < win.outer_px {
                            all += 1;
                            let (x, y) = (win.x_px + dx, win.y_px + dy);
                            kept += usize::from(x >= 0.0 && y >= 0.0 && x < w && y < h);
                        }
                    }
                }
                kept as f64 / all.max(1) as f64
            };
            let overlap = windows.iter().zip(&scene.highlights).enumerate().find(|(j, ((_, other), _))| {
                *j != i && (other.x_px - win.x_px).hypot(other.y_px - win.y_px) < win.outer_px + other.disc_px
            });
            let result = if !inside(win.disc_px) || annulus_share < 0.5 {
                Err(NotMeasurable::Clipped)
            } else if let Some((_, (_, other))) = overlap {
                Err(NotMeasurable::Overlaps(other.name.clone()))
            } else if win.plateau_px < MIN_PLATEAU_PX {
                Err(NotMeasurable::NoPlateau(win.plateau_px.max(0.0)))
            } else {
                let t = measure_disc(width, height, test, &win);
                let r = measure_disc(width, height, reference, &win);
                if r.plateau.is_nan() || r.plateau <= 0.0 {
                    Err(NotMeasurable::NoDisc("reference"))
                } else if t.plateau.is_nan() || t.plateau <= 0.0 {
                    Err(NotMeasurable::NoDisc("test image"))
                } else {
                    Ok((t, r))
                }
            };
            HighlightRow { name: hl.name.clone(), depth_m: hl.depth_m, coc_radius_px, window: win, result }
        })
        .collect();
    Ok(HighlightReport { f_number, rows })
}

impl HighlightReport {
    /// (within, measured): the measured highlights whose area ratio is within `tolerance`
    /// (0.02 for 2%) of 1, and all measured.
    pub fn within(&self, tolerance: f64) -> (usize, usize) {
        let ratios: Vec<f64> = self.rows.iter().filter_map(|r| r.ratio()).map(|r| r.0).collect();
        (ratios.iter().filter(|r| (*r - 1.0).abs() <= tolerance).count(), ratios.len())
    }

    /// The median area ratio of the measured highlights.
    pub fn median_ratio(&self) -> f64 {
        let mut ratios: Vec<f64> = self.rows.iter().filter_map(|r| r.ratio()).map(|r| r.0).collect();
        median(&mut ratios)
    }

    /// A Markdown table, a row per highlight, and the count within `tolerance`.
    pub fn table(&self, tolerance: f64) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "| highlight | depth m | CoC radius px | area test px2 | area reference px2 | ratio | ratio's noise (1 sigma) | energy ratio | note |"
        );
        let _ = writeln!(s, "| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
        for row in &self.rows {
            let head = format!("| {} | {:.2} | {:.2} |", row.name, row.depth_m, row.coc_radius_px);
            match (&row.result, row.ratio()) {
                (Ok((t, r)), Some((ratio, sigma))) => {
                    let mut notes = Vec::new();
                    if (ratio - 1.0).abs() > tolerance {
                        notes.push(format!("outside: {:+.1} sigma of noise", (ratio - 1.0) / sigma.max(1e-12)));
                    }
                    let bound = (t.background_bound_px2 / t.area_px2).max(r.background_bound_px2 / r.area_px2);
                    if bound > BACKGROUND_NOTE {
                        notes.push(format!("structured background (bound {:.1}%)", 100.0 * bound));
                    }
                    let _ = writeln!(
                        s,
                        "{head} {:.1} ± {:.1} | {:.1} ± {:.1} | {:.3} | {:.3} | {:.3} | {} |",
                        t.area_px2,
                        t.sigma_area_px2,
                        r.area_px2,
                        r.sigma_area_px2,
                        ratio,
                        sigma,
                        t.energy / r.energy,
                        notes.join("; ")
                    );
                }
                (Err(why), _) => {
                    let _ = writeln!(s, "{head} | | | | | not measurable: {why} |");
                }
                (Ok(_), None) => {}
            }
        }
        let (k, n) = self.within(tolerance);
        let _ = writeln!(
            s,
            "\nf/{}: areas within {}%: {k} of {n} measured (median ratio {:.3}); {} not measurable",
            self.f_number,
            tolerance * 100.0,
            self.median_ratio(),
            self.rows.len() - n
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The share of pixel (x, y) inside a hexagon of circumradius `r` centred at (cx, cy),
    /// corners at 30 + 60 k degrees (pointy top, as scene A's aperture), 16x16 samples (the
    /// area to about 0.1% at r = 8 px).
    fn hexagon_coverage(x: usize, y: usize, cx: f64, cy: f64, r: f64) -> f64 {
        let inradius = r * 30f64.to_radians().cos();
        let normals: Vec<(f64, f64)> = (0..6).map(|k| (60.0 * k as f64).to_radians().sin_cos()).collect();
        let mut n = 0;
        for sy in 0..16 {
            for sx in 0..16 {
                let (dx, dy) = (x as f64 + (sx as f64 + 0.5) / 16.0 - cx, y as f64 + (sy as f64 + 0.5) / 16.0 - cy);
                n += usize::from(normals.iter().all(|(sin, cos)| dx * cos + dy * sin <= inradius));
            }
        }
        n as f64 / 256.0
    }

    /// Normal deviates from a fixed seed (xorshift64 and Box-Muller).
    struct Noise(u64);
    impl Noise {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn normal(&mut self) -> f64 {
            let (u, v) = (self.uniform(), self.uniform());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        }
    }

    /// An RGBA image (grey) of `disc(x, y)` (luminance above the background) blurred by a
    /// normalised disc of radius `blur_px` (an object's size and a pixel filter), over the
    /// background `background(x, y)`, with normal noise of `sigma`.
    fn image(
        w: usize,
        h: usize,
        disc: impl Fn(usize, usize) -> f64,
        blur_px: i64,
        background: impl Fn(f64, f64) -> f64,
        sigma: f64,
        seed: u64,
    ) -> Vec<f32> {
        let sharp: Vec<f64> = (0..w * h).map(|i| disc(i % w, i / w)).collect();
        let kernel: Vec<(i64, i64)> = (-blur_px..=blur_px)
            .flat_map(|dy| (-blur_px..=blur_px).map(move |dx| (dx, dy)))
            .filter(|(dx, dy)| dx * dx + dy * dy <= blur_px * blur_px)
            .collect();
        let mut noise = Noise(seed);
        let mut out = Vec::with_capacity(4 * w * h);
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let blurred: f64 = kernel
                    .iter()
                    .map(|(dx, dy)| {
                        let (qx, qy) = ((x + dx).clamp(0, w as i64 - 1), (y + dy).clamp(0, h as i64 - 1));
                        sharp[(qy * w as i64 + qx) as usize]
                    })
                    .sum::<f64>()
                    / kernel.len() as f64;
                let v = (blurred + background(x as f64, y as f64) + sigma * noise.normal()) as f32;
                out.extend([v, v, v, 1.0]);
            }
        }
        out
    }

    #[test]
    fn a_noisy_hexagon_over_a_gradient_keeps_its_area() {
        // Circumradius 12 px: area 3 sqrt(3) / 2 * 144 = 374.12 px2, plateau 4 above a
        // background of 0.3 rising 0.02 per px right and falling 0.015 per px down (0.9 across
        // the window, a quarter of the plateau), noise 0.1 per pixel (2.5% of the plateau),
        // blurred by a disc of radius 2 px (an object's size and a filter). The estimate's
        // noise is about 0.35%; it must be within 1% (3 sigma) and its sigma below 0.6%.
        let (w, h, cx, cy, r) = (96, 96, 47.3, 48.6, 12.0);
        let truth = 1.5 * 3f64.sqrt() * r * r;
        let background = |x: f64, y: f64| 0.3 + 0.02 * (x - cx) - 0.015 * (y - cy);
        // A neighbouring object in the annulus (disc 19.1 px, annulus to 24 px): a bar of 2 at
        // 20-22 px right of the centre. Fitted with it, the plane would rise by some 0.15 and take
        // 10% off the area; its pixels are rejected as outliers.
        let with_bar = |x: f64, y: f64| background(x, y) + if (67.0..70.0).contains(&x) { 2.0 } else { 0.0 };
        let window = DiscWindow::new(cx, cy, r, 2.0);
        assert!((window.disc_px - 19.1).abs() < 0.01 && (window.outer_px - 24.0).abs() < 0.01, "{window:?}");
        for seed in [1, 2, 3] {
            let rgba = image(w, h, |x, y| 4.0 * hexagon_coverage(x, y, cx, cy, r), 2, with_bar, 0.1, seed);
            let m = measure_disc(w as u32, h as u32, &rgba, &window);
            let error = m.area_px2 / truth - 1.0;
            assert!(error.abs() < 0.01, "seed {seed}: {} px2 against {truth} ({m:?})", m.area_px2);
            assert!(m.sigma_area_px2 / truth < 0.006 && error.abs() < 3.0 * m.sigma_area_px2 / truth, "{m:?}");
            // The fitted plane found the gradient, and the noise about it.
            assert!((m.background[1] - 0.02).abs() < 0.003 && (m.background[2] + 0.015).abs() < 0.003, "{m:?}");
            assert!((m.background_sigma - 0.1).abs() < 0.02, "{m:?}");
        }
        // Without noise, a circle of radius 10 px (area 314.16 px2), its edge sampled 8x8 per
        // pixel: within 0.3%.
        let rgba = image(
            w,
            h,
            |x, y| {
                let n = (0..64)
                    .filter(|s| {
                        let (dx, dy) = (
                            x as f64 + (s % 8) as f64 / 8.0 + 0.0625 - cx,
                            y as f64 + (s / 8) as f64 / 8.0 + 0.0625 - cy,
                        );
                        dx * dx + dy * dy <= 100.0
                    })
                    .count();
                20.0 * n as f64 / 64.0
            },
            1,
            background,
            0.0,
            1,
        );
        let m = measure_disc(w as u32, h as u32, &rgba, &DiscWindow::new(cx, cy, 10.0, 1.0));
        assert!((m.area_px2 / (std::f64::consts::PI * 100.0) - 1.0).abs() < 0.003, "{m:?}");
    }

    #[test]
    fn the_plateau_is_not_stuck_to_a_path_tracers_levels() {
        // A disc whose pixels take the levels 9, 10, 11 (a path tracer's hit counts): 40% at 10,
        // 35% at 11, 25% at 9, mean 10.1. The median would be 10 (1% low, the area 1% high).
        let mut values: Vec<f64> = (0..100)
            .map(|i| {
                if i < 40 {
                    10.0
                } else if i < 75 {
                    11.0
                } else {
                    9.0
                }
            })
            .collect();
        values.push(1000.0); // and an outlier
        let (mean, _, n) = clipped_mean(&mut values);
        assert_eq!(n, 100);
        assert!((mean - 10.1).abs() < 1e-9, "{mean}");
    }

    fn scene(highlights: Vec<Highlight>) -> SceneHighlights {
        SceneHighlights {
            path: "camera.json".into(),
            focal_length_mm: 50.0,
            pixel_pitch_mm: 0.028125,
            focus_distance_m: 2.0,
            width_px: 200,
            height_px: 120,
            highlights,
        }
    }

    fn highlight(name: &str, depth_m: f64, x_px: f64, y_px: f64) -> Highlight {
        Highlight { name: name.into(), depth_m, x_px, y_px, radius_px: 1.5 }
    }

    #[test]
    fn clipped_overlapping_and_in_focus_highlights_are_not_measured_and_say_why() {
        // 50 mm at f/2 focused at 2 m, 0.028125 mm pixels: a point at 7.5 m has a CoC of
        // 1250 (1/2000 - 1/7500) mm = 0.458 mm, radius 8.15 px.
        let s = scene(vec![
            highlight("edge", 7.5, 6.0, 60.0),
            highlight("pair_a", 7.5, 60.0, 30.0),
            highlight("pair_b", 7.5, 80.0, 40.0),
            highlight("alone", 7.5, 150.37, 70.61),
            highlight("sharp", 2.0, 150.0, 15.0),
        ]);
        // The same disc of radius 8.15 in both images at "alone"; the test image's 1% larger.
        let (w, h) = (200, 120);
        let disc = |scale: f64| {
            image(w, h, move |x, y| 30.0 * hexagon_coverage(x, y, 150.37, 70.61, 8.15 * scale), 1, |_, _| 0.5, 0.0, 1)
        };
        let (test, reference) = (disc(1.005), disc(1.0));
        let report = compare_highlights(&s, 2.0, w as u32, h as u32, &test, &reference).unwrap();
        let why: Vec<_> = report.rows.iter().map(|r| r.result.as_ref().err().cloned()).collect();
        assert_eq!(why[0], Some(NotMeasurable::Clipped));
        assert_eq!(why[1], Some(NotMeasurable::Overlaps("pair_b".into())));
        assert_eq!(why[2], Some(NotMeasurable::Overlaps("pair_a".into())));
        assert_eq!(why[3], None);
        assert!(matches!(why[4], Some(NotMeasurable::NoPlateau(_))));
        assert!((report.rows[3].coc_radius_px - 8.1481).abs() < 1e-3, "{}", report.rows[3].coc_radius_px);
        let (ratio, _) = report.rows[3].ratio().unwrap();
        assert!((ratio - 1.005f64.powi(2)).abs() < 0.003, "{ratio}"); // the edge sampled 16x16 per pixel
        assert_eq!(report.within(0.02), (1, 1));
        let table = report.table(0.02);
        assert!(
            table.contains("| edge | 7.50 | 8.15 | | | | | | not measurable: clipped by the frame's edge |"),
            "{table}"
        );
        assert!(table.contains("areas within 2%: 1 of 1 measured"), "{table}");
        // Images of another size than the description's are refused.
        let e = compare_highlights(&s, 2.0, 100, 120, &test, &reference).unwrap_err();
        assert!(e.to_string().contains("camera.resolution"), "{e}");
    }

    const GOOD: &str = r#"{"camera": {"focal_length_mm": 50.0, "pixel_pitch_mm": 0.028125, "resolution": [1280, 720]},
        "ground_truth": {"dof": {"focus_distance_m": 2.0}},
        "objects": [{"name": "Wall", "role": "far_wall", "depth_m": 8.0},
                    {"name": "HL0", "role": "highlight_background", "depth_m": 7.5,
                     "pixel_xy_topleft_ydown": [929.9, 521.1], "approx_diameter_px": 4.0}]}"#;

    #[test]
    fn a_scene_description_gives_the_highlights() {
        let s = SceneHighlights::parse(Path::new("camera.json"), GOOD).unwrap();
        assert_eq!((s.width_px, s.height_px, s.focus_distance_m), (1280, 720, 2.0));
        assert_eq!(
            s.highlights,
            vec![Highlight { name: "HL0".into(), depth_m: 7.5, x_px: 929.9, y_px: 521.1, radius_px: 2.0 }]
        );
    }

    #[test]
    fn a_bad_scene_description_names_the_file_and_the_field() {
        let error = |text: &str| SceneHighlights::parse(Path::new("dir/camera.json"), text).unwrap_err().to_string();
        let cases = [
            (
                GOOD.replace(r#""depth_m": 7.5"#, r#""depth_m": "far""#),
                "objects[1].depth_m\" must be a number, got a string",
            ),
            (GOOD.replace(r#""depth_m": 7.5,"#, ""), "objects[1].depth_m\" is missing"),
            (
                GOOD.replace("[929.9, 521.1]", "[929.9]"),
                "objects[1].pixel_xy_topleft_ydown\" must be an array of two numbers",
            ),
            (
                GOOD.replace(r#""focal_length_mm": 50.0"#, r#""focal_length_mm": -50"#),
                "camera.focal_length_mm\" must be above 0",
            ),
            (
                GOOD.replace(r#""focus_distance_m": 2.0"#, r#""focus_m": 2.0"#),
                "ground_truth.dof.focus_distance_m\" is missing",
            ),
            (GOOD.replace("[1280, 720]", "[1280.5, 720]"), "camera.resolution\" must be two whole numbers"),
            (GOOD.replace("highlight_background", "lamp"), "lists no object with a role starting with \"highlight\""),
            (
                GOOD.replace(r#""approx_diameter_px": 4.0"#, r#""approx_diameter_px": -1"#),
                "approx_diameter_px\" must be 0 or more",
            ),
            (GOOD.replace("\"objects\"", "\"objects\" 1"), "invalid JSON: expected `:` at line 3 column 19"),
        ];
        for (text, expected) in cases {
            let e = error(&text);
            assert!(e.contains("dir/camera.json") && e.contains(expected), "{e}\nexpected: {expected}");
        }
        let e = SceneHighlights::read(Path::new("/nonexistent/camera.json")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/camera.json"), "{e}");
    }
}
