//! Issue 32 item 4: Walch 2017 ch. 9's occurrence estimators over a range of light positions
//! instead of one. Sec. 9.2 gives an estimator its context by comparing it with the same
//! estimator over the whole range: its global extremes over the range, and the range between
//! the estimator's minimum and maximum divided into bins that classify each position. The
//! range is a grid of lights over the frame (each cell's light seen through the cell's centre
//! by a pinhole of the given field of view) or the points of a path (a light moving along a
//! line in view space). Each position is [`super::predict`]ed (eq 8.1-8.3, sec. 9.1, eq 9.3);
//! over the range come the minimum, mean and maximum of every estimator (and where the
//! extremes lie), the bins of one chosen estimator, and the share of positions at which the
//! flare reaches a threshold of that estimator.

use super::{predict_sampled, PredictError, PredictRequest, Prediction};
use crate::io::lens_file::FittedGhostSpec;

/// The most positions one range may hold (a 256 x 256 grid): each is a drawn frame.
pub const MAX_POSITIONS: usize = 65_536;

/// One of sec. 9.1's estimators, or eq 9.3's contrast ratio.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    Min,
    Max,
    Sum,
    Average,
    LogAverage,
    ContrastRatio,
}

impl Estimator {
    pub const ALL: [Estimator; 6] = [
        Estimator::Min,
        Estimator::Max,
        Estimator::Sum,
        Estimator::Average,
        Estimator::LogAverage,
        Estimator::ContrastRatio,
    ];

    /// The name the command takes and prints.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Min => "min",
            Estimator::Max => "max",
            Estimator::Sum => "sum",
            Estimator::Average => "average",
            Estimator::LogAverage => "log-average",
            Estimator::ContrastRatio => "contrast-ratio",
        }
    }

    /// The estimator's value of one prediction.
    pub fn of(self, p: &Prediction) -> f64 {
        let e = &p.estimators;
        match self {
            Estimator::Min => e.min,
            Estimator::Max => e.max,
            Estimator::Sum => e.sum,
            Estimator::Average => e.average,
            Estimator::LogAverage => e.log_average,
            Estimator::ContrastRatio => p.contrast_ratio,
        }
    }

    /// Whether a larger value means more flare: the contrast ratio falls as the flare grows
    /// (eq 9.3), the intensities' statistics rise.
    pub fn rises_with_flare(self) -> bool {
        self != Estimator::ContrastRatio
    }

    /// Whether `value` is a flare at least as strong as `threshold` of this estimator.
    pub fn reaches(self, value: f64, threshold: f64) -> bool {
        if self.rises_with_flare() {
            value >= threshold
        } else {
            value <= threshold
        }
    }

    /// The threshold used when none is given: a contrast lost by 5% (K_real / K_ideal 0.95);
    /// the intensities' statistics have no scale of their own, so none.
    pub fn default_threshold(self) -> Option<f64> {
        (self == Estimator::ContrastRatio).then_some(0.95)
    }
}

impl std::str::FromStr for Estimator {
    type Err = RangeError;
    fn from_str(s: &str) -> Result<Estimator, RangeError> {
        Estimator::ALL.into_iter().find(|e| e.name() == s).ok_or_else(|| RangeError::Estimator(s.to_string()))
    }
}

/// Where the lights of a range are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Range {
    /// `cols` x `rows` cells over the frame; the light of each seen through the cell's centre
    /// by a pinhole camera whose horizontal field of view is `fov_deg`.
    Grid { cols: u32, rows: u32, fov_deg: f64 },
    /// `steps` points from `from` to `to` (both included) in view space.
    Path { from: [f64; 3], to: [f64; 3], steps: u32 },
}

/// Why there is no range prediction; the messages name the command's flags.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RangeError {
    #[error("--grid: {0:?} is not COLSxROWS of whole numbers of at least 1 (e.g. 16x9)")]
    Grid(String),
    #[error("--grid {cols}x{rows} is {positions} positions, more than {MAX_POSITIONS}")]
    TooMany { cols: u32, rows: u32, positions: u64 },
    #[error("--grid needs --fov-deg: the horizontal field of view (degrees) of the frame the ghosts were fitted on")]
    NoFov,
    #[error("--fov-deg must be above 0 and below 180, not {0}")]
    Fov(f64),
    #[error("--path: {0:?} is not X,Y,Z:X,Y,Z (the line's two ends in view space, finite numbers)")]
    Path(String),
    #[error("--steps must be from 2 (the path's two ends) to {MAX_POSITIONS}, not {0}")]
    Steps(u32),
    #[error("--estimator: {0:?} is not one of min, max, sum, average, log-average, contrast-ratio")]
    Estimator(String),
    #[error("--threshold must be a finite number, not {0}")]
    Threshold(f64),
    #[error("--bins must be from 1 to 1000, not {0}")]
    Bins(usize),
    #[error("--sample-px must be from 1 to 256, not {0}")]
    SamplePx(u32),
    /// The lens's ghosts cannot be predicted at all (no ghosts, frames that differ, a bad
    /// exposure or scene).
    #[error(transparent)]
    Lens(PredictError),
    #[error("{at}: {source}")]
    Predict { at: String, source: PredictError },
}

/// `COLSxROWS` (e.g. `16x9`).
pub fn parse_grid(text: &str) -> Result<(u32, u32), RangeError> {
    let bad = || RangeError::Grid(text.to_string());
    let (c, r) = text.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    let (cols, rows): (u32, u32) = (c.trim().parse().map_err(|_| bad())?, r.trim().parse().map_err(|_| bad())?);
    if cols == 0 || rows == 0 {
        return Err(bad());
    }
    let positions = cols as u64 * rows as u64;
    if positions > MAX_POSITIONS as u64 {
        return Err(RangeError::TooMany { cols, rows, positions });
    }
    Ok((cols, rows))
}

/// `X,Y,Z:X,Y,Z` (the path's ends).
pub fn parse_path(text: &str) -> Result<([f64; 3], [f64; 3]), RangeError> {
    let bad = || RangeError::Path(text.to_string());
    let point = |s: &str| -> Result<[f64; 3], RangeError> {
        let v: Vec<f64> = s.split(',').map(|n| n.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
        match v[..] {
            [x, y, z] if v.iter().all(|n| n.is_finite()) => Ok([x, y, z]),
            _ => Err(bad()),
        }
    };
    let (a, b) = text.split_once(':').ok_or_else(bad)?;
    Ok((point(a)?, point(b)?))
}

/// The range the command's flags describe: `--grid` (with `--fov-deg`) or `--path` (with
/// `--steps`); None when neither is given.
pub fn range_from_flags(
    grid: Option<&str>,
    fov_deg: Option<f64>,
    path: Option<&str>,
    steps: u32,
) -> Result<Option<Range>, RangeError> {
    if let Some(g) = grid {
        let (cols, rows) = parse_grid(g)?;
        let fov_deg = fov_deg.ok_or(RangeError::NoFov)?;
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(RangeError::Fov(fov_deg));
        }
        return Ok(Some(Range::Grid { cols, rows, fov_deg }));
    }
    match path {
        Some(p) => {
            let (from, to) = parse_path(p)?;
            if !(2..=MAX_POSITIONS as u32).contains(&steps) {
                return Err(RangeError::Steps(steps));
            }
            Ok(Some(Range::Path { from, to, steps }))
        }
        None => Ok(None),
    }
}

/// One light of a range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Grid: (column, row), row 0 at the top; path: (step, 0).
    pub cell: [u32; 2],
    /// Grid: the cell's centre in frame pixels (y down); path: None.
    pub frame_px: Option<[f64; 2]>,
    /// The light in view space (x right, y up, looking down -z).
    pub view: [f64; 3],
}

/// The lights of `range` on a `frame_px` frame (row by row for a grid).
pub fn lights(range: &Range, frame_px: [u32; 2]) -> Vec<Light> {
    match *range {
        Range::Grid { cols, rows, fov_deg } => {
            let (w, h) = (frame_px[0] as f64, frame_px[1] as f64);
            // A pinhole's focal length in pixels: the frame's half width at half the view.
            let focal_px = 0.5 * w / (0.5 * fov_deg).to_radians().tan();
            let mut out = Vec::with_capacity((cols * rows) as usize);
            for row in 0..rows {
                for col in 0..cols {
                    let px = [(col as f64 + 0.5) * w / cols as f64, (row as f64 + 0.5) * h / rows as f64];
                    // `+ 0.0` turns -0 into 0, so that a light on the horizon's left has a roll
                    // of 180 degrees, not -180.
                    let view = [(px[0] - 0.5 * w) / focal_px + 0.0, (0.5 * h - px[1]) / focal_px + 0.0, -1.0];
                    out.push(Light { cell: [col, row], frame_px: Some(px), view });
                }
            }
            out
        }
        Range::Path { from, to, steps } => (0..steps)
            .map(|k| {
                let t = k as f64 / (steps - 1) as f64;
                let view = std::array::from_fn(|i| from[i] + t * (to[i] - from[i]));
                Light { cell: [k, 0], frame_px: None, view }
            })
            .collect(),
    }
}

/// Minimum, mean and maximum of one estimator over a range, and the first positions (their
/// indices) of the extremes: sec. 9.2's global extremes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Statistics {
    pub estimator: Estimator,
    pub min: f64,
    pub mean: f64,
    pub max: f64,
    pub at_min: usize,
    pub at_max: usize,
}

/// `values`' statistics (at least one value).
pub fn statistics(estimator: Estimator, values: &[f64]) -> Statistics {
    let (mut at_min, mut at_max) = (0, 0);
    for (i, &v) in values.iter().enumerate() {
        if v < values[at_min] {
            at_min = i;
        }
        if v > values[at_max] {
            at_max = i;
        }
    }
    let mean = values.iter().sum::<f64>() / values.len().max(1) as f64;
    Statistics { estimator, min: values[at_min], mean, max: values[at_max], at_min, at_max }
}

/// Sec. 9.2's bins: the estimator's range from its minimum to its maximum over the positions
/// in `counts.len()` bins of equal width (the last includes the maximum).
#[derive(Clone, Debug, PartialEq)]
pub struct Bins {
    pub lower: f64,
    pub upper: f64,
    pub counts: Vec<usize>,
}

impl Bins {
    pub fn new(lower: f64, upper: f64, bins: usize, values: &[f64]) -> Bins {
        let mut b = Bins { lower, upper, counts: vec![0; bins.max(1)] };
        for &v in values {
            let i = b.bin_of(v);
            b.counts[i] += 1;
        }
        b
    }

    /// The bin of `value` (0 when the range is a single value).
    pub fn bin_of(&self, value: f64) -> usize {
        let n = self.counts.len();
        let width = self.upper - self.lower;
        if !(width > 0.0) {
            return 0;
        }
        (((value - self.lower) / width * n as f64).floor().max(0.0) as usize).min(n - 1)
    }

    /// Bin `i`'s lower and upper edge.
    pub fn edges(&self, i: usize) -> (f64, f64) {
        let w = (self.upper - self.lower) / self.counts.len() as f64;
        (
            self.lower + i as f64 * w,
            if i + 1 == self.counts.len() { self.upper } else { self.lower + (i + 1) as f64 * w },
        )
    }
}

/// What a range prediction is for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RangeRequest {
    pub range: Range,
    /// The camera, exposures and scene; its light is replaced by each of the range's.
    pub base: PredictRequest,
    /// The estimator binned, plotted and held against the threshold.
    pub estimator: Estimator,
    /// None: the estimator's default ([`Estimator::default_threshold`]).
    pub threshold: Option<f64>,
    pub bins: usize,
    /// The flare drawn at every this many pixels across and down (1: every pixel; see
    /// [`super::predict_sampled`]).
    pub sample_px: u32,
}

/// One position's prediction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position {
    pub light: Light,
    pub prediction: Prediction,
    /// The chosen estimator's value, its bin, and whether it reaches the threshold.
    pub value: f64,
    pub bin: usize,
    pub reaches: bool,
}

/// The range's predictions and sec. 9.2's context of them.
#[derive(Clone, Debug, PartialEq)]
pub struct RangePrediction {
    pub request: RangeRequest,
    pub positions: Vec<Position>,
    /// Every estimator's statistics, in [`Estimator::ALL`]'s order.
    pub statistics: Vec<Statistics>,
    pub bins: Bins,
    pub threshold: Option<f64>,
    /// How many positions reach the threshold (0 without one).
    pub reaching: usize,
}

impl RangePrediction {
    /// The share of the positions reaching the threshold (0..1).
    pub fn share(&self) -> f64 {
        self.reaching as f64 / self.positions.len().max(1) as f64
    }

    /// The chosen estimator's statistics.
    pub fn chosen(&self) -> &Statistics {
        let i = Estimator::ALL.iter().position(|&e| e == self.request.estimator).unwrap_or(0);
        &self.statistics[i]
    }
}

fn shown(v: [f64; 3]) -> String {
    format!("({}, {}, {})", v[0], v[1], v[2])
}

/// Each of `lights` predicted, on as many threads as the machine has (in order).
fn predict_all(
    ghosts: &[FittedGhostSpec],
    request: &RangeRequest,
    lights: &[Light],
) -> Result<Vec<Prediction>, RangeError> {
    let one = |i: usize, light: &Light| {
        let one = PredictRequest { light_view: light.view, ..request.base };
        predict_sampled(ghosts, &one, request.sample_px).map_err(|source| {
            let at = match request.range {
                Range::Grid { .. } => {
                    format!("--grid: cell {},{} at {}", light.cell[0], light.cell[1], shown(light.view))
                }
                Range::Path { steps, .. } => format!("--path: step {} of {steps} at {}", i + 1, shown(light.view)),
            };
            RangeError::Predict { at, source }
        })
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(lights.len()).max(1);
    let chunk = lights.len().div_ceil(threads).max(1);
    let parts: Vec<Result<Vec<Prediction>, RangeError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = lights
            .chunks(chunk)
            .enumerate()
            .map(|(k, part)| {
                let one = &one;
                scope.spawn(move || part.iter().enumerate().map(|(j, l)| one(k * chunk + j, l)).collect())
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
    });
    let mut out = Vec::with_capacity(lights.len());
    for part in parts {
        out.extend(part?);
    }
    Ok(out)
}

/// Ch. 9 over `request.range`.
pub fn predict_range(ghosts: &[FittedGhostSpec], request: &RangeRequest) -> Result<RangePrediction, RangeError> {
    if !(1..=1000).contains(&request.bins) {
        return Err(RangeError::Bins(request.bins));
    }
    let threshold = request.threshold.or(request.estimator.default_threshold());
    if let Some(t) = threshold.filter(|t| !t.is_finite()) {
        return Err(RangeError::Threshold(t));
    }
    if !(1..=256).contains(&request.sample_px) {
        return Err(RangeError::SamplePx(request.sample_px));
    }
    // The frame (and the ghosts' own errors) from a prediction on the axis.
    let on_axis = PredictRequest { light_view: [0.0, 0.0, -1.0], ..request.base };
    let first = predict_sampled(ghosts, &on_axis, request.sample_px).map_err(RangeError::Lens)?;
    let all = lights(&request.range, first.frame_px);
    let predictions = predict_all(ghosts, request, &all)?;
    let statistics: Vec<Statistics> = Estimator::ALL
        .iter()
        .map(|&e| statistics(e, &predictions.iter().map(|p| e.of(p)).collect::<Vec<_>>()))
        .collect();
    let values: Vec<f64> = predictions.iter().map(|p| request.estimator.of(p)).collect();
    let chosen = statistics.iter().find(|s| s.estimator == request.estimator).copied().unwrap_or(statistics[0]);
    let bins = Bins::new(chosen.min, chosen.max, request.bins, &values);
    let positions: Vec<Position> = all
        .iter()
        .zip(&predictions)
        .zip(&values)
        .map(|((&light, &prediction), &value)| Position {
            light,
            prediction,
            value,
            bin: bins.bin_of(value),
            reaches: threshold.is_some_and(|t| request.estimator.reaches(value, t)),
        })
        .collect();
    let reaching = positions.iter().filter(|p| p.reaches).count();
    Ok(RangePrediction { request: *request, positions, statistics, bins, threshold, reaching })
}
