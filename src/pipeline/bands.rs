//! Banded rendering: a frame whose images do not fit the device (its memory, `--max-gpu-memory`,
//! or its largest image side) is rendered as horizontal bands, each with an apron of rows above
//! and below as wide as the running passes reach, and the bands' own rows stitched.
//!
//! A pass's output pixel reads its input within [`crate::passes::Pass::reach_px`] of it; the
//! passes run one after another, so the last pass's pixel depends on the frame's within the sum
//! of their reaches. A band rendered with that many rows of the frame on each side therefore
//! computes its own rows from the same pixels as the whole frame would. Each band is planned
//! with the whole frame's facts (CoC range and clamp, how far the pixels move:
//! [`crate::pipeline::planner::plan_band`]), its rows start on a multiple of the tile size, and
//! what depends on where a pixel lies in the frame (the grain, the motion samples' jitter and
//! rounding, the rolling shutter, the aberrations' sample positions, the cat's eye) reads the
//! band's first row ([`crate::model::frame::BandPlace`]): a band's rows have the bits of the
//! whole frame's render (`tests/bands.rs`).
//!
//! The flare finds its lights over the whole frame ([`crate::passes::Pass::reach_px`] `None`):
//! it and the passes after it (per pixel) run in a second round of bands over the first round's
//! stitched frame, with the whole frame's light tiles summed first on the CPU
//! ([`tile_records`], the twin of `flare_tiles`) and each band drawing the sprites on its own
//! tile rows.

use crate::gpu::{Gpu, GpuError, GpuResult, Profile};
use crate::model::frame::Frame;
use crate::passes::flare::{tiles::tile_records, Flare};
use crate::passes::{PASS_ORDER, TILE_SIZE};
use crate::pipeline::planner::Plan;
use crate::pipeline::render::{estimated_gpu_bytes_per_px, Rendered, Renderer};
use std::sync::Arc;

/// How a frame is cut into bands.
#[derive(Clone, Debug, PartialEq)]
pub struct Bands {
    /// Each band's own rows, `start..end`, top to bottom, covering the frame.
    pub rows: Vec<(u32, u32)>,
    /// Rows of the frame rendered above and below a band's own (fewer at the frame's edges).
    pub apron_px: u32,
    /// Why, for `--explain`.
    pub why: String,
}

/// Why a frame cannot be banded.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum BandError {
    #[error(
        "a band of {width} px by one tile row with aprons of {apron_px} rows above and below (the passes' reach) needs about {} of GPU memory, more than the {} the frame may use (the device's memory or --max-gpu-memory)",
        megabytes(*.bytes),
        megabytes(*.budget)
    )]
    ApronTooLarge { width: u32, apron_px: u32, bytes: u64, budget: u64 },
}

fn megabytes(bytes: u64) -> String {
    format!("{:.1} MB", bytes as f64 / 1e6)
}

/// The apron a band needs for the passes at `range` of the pass order in `plan`: the sum of
/// the running passes' reaches (each pass reads what the one before it wrote), rounded up to
/// whole tiles. `None` when one of them reads the whole frame (the flare).
pub fn apron_px(plan: &Plan, range: std::ops::Range<usize>) -> Option<u32> {
    let mut sum = 0.0f64;
    for (entry, planned) in PASS_ORDER.iter().zip(&plan.passes).skip(range.start).take(range.len()) {
        // The runs of one pass (one per channel) each read the same input: the largest counts.
        let mut largest = 0.0f64;
        for params in planned.run_params() {
            largest = largest.max(entry.reach_px(params)?);
        }
        sum += largest;
    }
    Some((sum.ceil() as u32).div_ceil(TILE_SIZE) * TILE_SIZE)
}

/// The bands of a `width` x `height` frame for `plan` within `budget_bytes` of GPU memory and
/// images at most `max_side_px` on a side; `None` when the whole frame fits.
pub fn plan_bands(
    width: u32,
    height: u32,
    plan: &Plan,
    apron_px: u32,
    budget_bytes: u64,
    max_side_px: u32,
) -> Result<Option<Bands>, BandError> {
    let per_row = width as u64 * estimated_gpu_bytes_per_px(plan);
    let whole = per_row * height as u64;
    if (budget_bytes == 0 || whole <= budget_bytes) && height <= max_side_px {
        return Ok(None);
    }
    let fit_rows = if budget_bytes == 0 { u64::MAX } else { budget_bytes / per_row.max(1) };
    let fit_rows = fit_rows.min(max_side_px as u64);
    // A band's own rows: whole tiles, at least one, with both aprons beside them.
    let own = fit_rows.saturating_sub(2 * apron_px as u64) / TILE_SIZE as u64 * TILE_SIZE as u64;
    if own == 0 {
        return Err(BandError::ApronTooLarge {
            width,
            apron_px,
            bytes: per_row * (2 * apron_px + TILE_SIZE) as u64,
            budget: budget_bytes,
        });
    }
    let own = own as u32;
    let rows: Vec<(u32, u32)> = (0..height.div_ceil(own)).map(|i| (i * own, ((i + 1) * own).min(height))).collect();
    let why = format!(
        "the frame needs about {:.2} GB of GPU memory and the device has {:.2} GB{}: {} bands of {own} rows, each with up to {apron_px} rows above and below (the passes' reach)",
        whole as f64 / 1e9,
        budget_bytes as f64 / 1e9,
        if height > max_side_px { format!(" (and its images may be at most {max_side_px} px high)") } else { String::new() },
        rows.len(),
    );
    Ok(Some(Bands { rows, apron_px, why }))
}

/// Why a banded render failed.
#[derive(Debug, thiserror::Error)]
pub enum BandedError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Band(#[from] BandError),
}

/// A frame rendered, and the bands it was cut into (`None`: whole).
pub struct FrameRender {
    pub rendered: Rendered,
    pub bands: Option<Bands>,
}

/// Renders `frame` by `whole`, its plan: at once when it fits `gpu`, else in bands, each band
/// planned by `plan_band` (the band's plan from the whole frame's facts). The frame's colour
/// is taken (left empty) either way.
pub fn render_frame(
    gpu: &Gpu,
    renderer: &Renderer,
    frame: &mut Frame,
    whole: &Plan,
    plan_band: &dyn Fn(&Frame) -> Plan,
) -> Result<FrameRender, BandedError> {
    let flare = PASS_ORDER.iter().position(|e| e.name == crate::passes::flare::NAME).unwrap_or(PASS_ORDER.len());
    // The first round: every pass before the flare (all of them when it does not run).
    let first_end = if whole.runs(crate::passes::flare::NAME) { flare } else { PASS_ORDER.len() };
    let apron = apron_px(whole, 0..first_end).unwrap_or(0);
    let bands =
        plan_bands(frame.width, frame.height, whole, apron, gpu.memory_budget_bytes(), gpu.max_image_dimension_px())?;
    let Some(bands) = bands else {
        let rendered = renderer.render_taking_colour(frame, whole, false)?;
        return Ok(FrameRender { rendered, bands: None });
    };
    let mut stitched = render_round(renderer, frame, &bands, bands.apron_px, &|band| {
        let mut plan = plan_band(band);
        plan.keep_only(0..first_end);
        plan
    })?;
    if first_end < PASS_ORDER.len() {
        // The second round: the flare over the first round's whole frame, its lights found
        // there first (the tiles' sums on the CPU), then the passes after it; none reaches
        // beyond its own pixel, so the bands need no apron.
        let mut params = whole.params::<Flare>().cloned().ok_or_else(|| GpuError::Internal("no flare run".into()))?;
        let image = &stitched.rgba;
        let w = frame.width as usize;
        params.whole_frame_tiles = Some(Arc::new(tile_records(
            |x, y| &image[(y as usize * w + x as usize) * 4..][..4],
            [frame.width, frame.height],
            &params.constants,
        )));
        let first = frame.with_colour_only(std::mem::take(&mut stitched.rgba));
        let second = render_round(renderer, &first, &bands, 0, &|band| {
            let mut plan = plan_band(band);
            plan.keep_only(flare..PASS_ORDER.len());
            let mut own = params.clone();
            own.constants.band_top_px = band.band_top_px() as i32;
            own.constants.band_height_px = band.height as i32;
            plan.set_runs::<Flare>(vec![own], "the whole frame's lights, drawn in this band");
            plan
        })?;
        stitched.profile.add(&second.profile);
        stitched.rgba = second.rgba;
    }
    frame.color = Vec::new();
    Ok(FrameRender { rendered: stitched, bands: Some(bands) })
}

/// Renders `frame` band by band, each with `apron` rows above and below, by `plan_band`'s plan
/// for each band, and stitches the bands' own rows. The profile sums the bands'.
fn render_round(
    renderer: &Renderer,
    frame: &Frame,
    bands: &Bands,
    apron: u32,
    plan_band: &dyn Fn(&Frame) -> Plan,
) -> GpuResult<Rendered> {
    let (w, h) = (frame.width as usize, frame.height);
    let mut rgba = vec![0.0f32; w * h as usize * 4];
    let mut profile: Option<Profile> = None;
    for &(start, end) in &bands.rows {
        let (top, bottom) = (start.saturating_sub(apron), (end + apron).min(h));
        let band = frame.band_rows(top, bottom);
        let plan = plan_band(&band);
        renderer.prepare(&plan)?;
        let rendered = renderer.render(&band, &plan, false)?;
        let own = (start - top) as usize * w * 4..(end - top) as usize * w * 4;
        rgba[start as usize * w * 4..end as usize * w * 4].copy_from_slice(&rendered.rgba[own]);
        match &mut profile {
            None => profile = Some(rendered.profile),
            Some(p) => p.add(&rendered.profile),
        }
    }
    Ok(Rendered { rgba, coc_px: None, profile: profile.unwrap_or_default() })
}
