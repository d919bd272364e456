//! `realcam compare`: the error of an image against a reference.

use anyhow::{bail, Result};
use realcam::io::read_exr_rgba;
use realcam::tools::highlight_discs::{compare_highlights, SceneHighlights};
use realcam::tools::metrics::compare_rgba;
use std::path::Path;

/// The areas within this relative difference count as matching (issue 15: 2%).
const AREA_TOLERANCE: f64 = 0.02;

/// `highlights`: a scene description and the f-number, for the highlights' disc areas.
pub fn run(test: &Path, reference: &Path, highlights: Option<(&Path, f64)>) -> Result<()> {
    let a = read_exr_rgba(test)?;
    let b = read_exr_rgba(reference)?;
    if (a.width, a.height) != (b.width, b.height) {
        bail!(
            "size mismatch: {} is {}x{} px but {} is {}x{} px",
            test.display(),
            a.width,
            a.height,
            reference.display(),
            b.width,
            b.height
        );
    }
    let e = compare_rgba(&a.data, &b.data);
    println!(
        "rmse {:.6}  rmse_matched {:.6}  rmse_display {:.6}  mean_abs {:.6}  psnr {:.2} dB  energy {:+.3}%",
        e.rmse,
        e.rmse_matched,
        e.rmse_display,
        e.mean_abs,
        e.psnr_db,
        e.relative_energy_error * 100.0
    );
    if let Some((description, f_number)) = highlights {
        let scene = SceneHighlights::read(description)?;
        let report = compare_highlights(&scene, f_number, a.width, a.height, &a.data, &b.data)?;
        println!("\nhighlight discs ({} against {}):\n", test.display(), reference.display());
        print!("{}", report.table(AREA_TOLERANCE));
    }
    Ok(())
}
