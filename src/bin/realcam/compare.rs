//! `realcam compare`: the error of an image against a reference.

use anyhow::{bail, Result};
use realcam::io::read_exr_rgba;
use realcam::tools::metrics::compare_rgba;
use std::path::Path;

pub fn run(test: &Path, reference: &Path) -> Result<()> {
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
    Ok(())
}
