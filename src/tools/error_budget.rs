//! Where a depth of field's error against ray-traced ground truth comes from: every pixel is put
//! in one region, and the squared error (energy-matched, clamped, as [`compare_rgba`]'s
//! `rmse_matched`) is summed per region.
//!
//! - **Highlights**: pixels a bright input pixel's circle of confusion reaches (luminance above
//!   the clamp of the comparison): the discs and their rims, where the disc's size and edge decide
//!   the error.
//! - **Occlusion edges**: pixels a blurred foreground edge reaches (a depth step of more than
//!   20% whose nearer side has a CoC radius above a pixel): there the camera sees around the
//!   foreground, which the pinhole image cannot show.
//! - **Smooth**: everything else.
//!
//! [`compare_rgba`]: crate::tools::metrics::compare_rgba

use crate::tools::metrics::MATCHED_CLAMP;

/// The regions of [`classify`], in the order a pixel is assigned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    Highlight,
    OcclusionEdge,
    Smooth,
}

pub const REGIONS: [Region; 3] = [Region::Highlight, Region::OcclusionEdge, Region::Smooth];

impl Region {
    pub fn name(self) -> &'static str {
        match self {
            Region::Highlight => "highlights",
            Region::OcclusionEdge => "occlusion edges",
            Region::Smooth => "smooth",
        }
    }
}

/// The region of every pixel of a `width x height` frame, from its pinhole colour (RGBA), its
/// depth (m) and its signed CoC diameter (px).
pub fn classify(width: u32, height: u32, rgba: &[f32], depth_m: &[f32], coc_px: &[f32]) -> Vec<Region> {
    let (w, h) = (width as i64, height as i64);
    let mut region = vec![Region::Smooth; (width * height) as usize];
    let luminance = |i: usize| 0.2126 * rgba[4 * i] + 0.7152 * rgba[4 * i + 1] + 0.0722 * rgba[4 * i + 2];
    // Mark the disc of radius `r` (+1 px of rim) around pixel (x, y), unless already a region of
    // higher rank.
    let mark = |region: &mut Vec<Region>, x: i64, y: i64, r: f32, what: Region| {
        let reach = (r + 1.0).ceil() as i64;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let (qx, qy) = (x + dx, y + dy);
                if qx < 0 || qy < 0 || qx >= w || qy >= h || ((dx * dx + dy * dy) as f32) > (r + 1.0) * (r + 1.0) {
                    continue;
                }
                let q = (qy * w + qx) as usize;
                if region[q] == Region::Smooth || (what == Region::Highlight && region[q] == Region::OcclusionEdge) {
                    region[q] = what;
                }
            }
        }
    };
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let r = 0.5 * coc_px[i].abs();
            if luminance(i) as f64 > MATCHED_CLAMP {
                mark(&mut region, x, y, r, Region::Highlight);
            }
            // A depth step: this pixel is the nearer side, with a visible blur.
            let step = [(1, 0), (0, 1), (-1, 0), (0, -1)].iter().any(|&(dx, dy)| {
                let (nx, ny) = (x + dx, y + dy);
                nx >= 0 && ny >= 0 && nx < w && ny < h && depth_m[(ny * w + nx) as usize] > 1.2 * depth_m[i]
            });
            if step && r > 1.0 {
                mark(&mut region, x, y, r, Region::OcclusionEdge);
            }
        }
    }
    region
}

/// One region's share of the error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionError {
    pub region: Region,
    /// Fraction of the frame's pixels in the region.
    pub pixel_share: f64,
    /// Fraction of the total squared error in the region.
    pub error_share: f64,
    /// RMSE over the region's pixels alone.
    pub rmse: f64,
}

/// The energy-matched, clamped squared error of `test` against `reference` (RGBA), per region.
pub fn budget(test: &[f32], reference: &[f32], regions: &[Region]) -> Vec<RegionError> {
    let finite = |v: f32| if v.is_finite() { v as f64 } else { 0.0 };
    let energy = |img: &[f32]| img.chunks_exact(4).map(|p| finite(p[0]) + finite(p[1]) + finite(p[2])).sum::<f64>();
    let (et, er) = (energy(test), energy(reference));
    let scale = if et > 0.0 { er / et } else { 1.0 };
    let mut sums = [(0usize, 0.0f64); 3];
    for ((t, r), &region) in test.chunks_exact(4).zip(reference.chunks_exact(4)).zip(regions) {
        let k = REGIONS.iter().position(|&g| g == region).unwrap_or(2);
        let se: f64 = (0..3)
            .map(|c| {
                let a = (finite(t[c]) * scale).clamp(0.0, MATCHED_CLAMP);
                let b = finite(r[c]).clamp(0.0, MATCHED_CLAMP);
                (a - b) * (a - b)
            })
            .sum();
        sums[k].0 += 1;
        sums[k].1 += se;
    }
    let total_se: f64 = sums.iter().map(|s| s.1).sum();
    let pixels = regions.len().max(1) as f64;
    REGIONS
        .iter()
        .zip(sums)
        .map(|(&region, (n, se))| RegionError {
            region,
            pixel_share: n as f64 / pixels,
            error_share: if total_se > 0.0 { se / total_se } else { 0.0 },
            rmse: if n > 0 { (se / (3 * n) as f64).sqrt() } else { 0.0 },
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_highlight_marks_its_disc_and_a_blurred_near_edge_its_reach() {
        // 32x8: a bright pixel at (4, 4) with a CoC of 4 px (radius 2, +1 of rim), and a near
        // object (x >= 24, depth 1) with a CoC of 6 px in front of a far one (depth 10).
        let (w, h) = (32u32, 8u32);
        let mut rgba = vec![0.1f32; (w * h * 4) as usize];
        let i = (4 * w + 4) as usize;
        rgba[4 * i..4 * i + 3].copy_from_slice(&[50.0, 50.0, 50.0]);
        let depth: Vec<f32> = (0..w * h).map(|i| if i % w >= 24 { 1.0 } else { 10.0 }).collect();
        let coc: Vec<f32> = (0..w * h).map(|i| if i % w >= 24 { -6.0 } else { 4.0 }).collect();
        let regions = classify(w, h, &rgba, &depth, &coc);
        let at = |x: u32, y: u32| regions[(y * w + x) as usize];
        assert_eq!(at(4, 4), Region::Highlight);
        assert_eq!(at(7, 4), Region::Highlight); // 3 px away: radius 2 + 1 px of rim
        assert_eq!(at(8, 4), Region::Smooth);
        assert_eq!(at(20, 4), Region::OcclusionEdge); // 4 px from the edge pixel at 24: 3 + 1
        assert_eq!(at(19, 4), Region::Smooth);
        // The shares add up, and an error placed in one region is all its own.
        let mut test = rgba.clone();
        test[4 * (2 * w + 12) as usize] += 1.0;
        let b = budget(&test, &rgba, &regions);
        assert!((b.iter().map(|r| r.pixel_share).sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(b[2].error_share > 0.999 && b[0].error_share < 1e-3, "{b:?}");
    }
}
