//! `realcam flare-predict`: Walch ch. 9's occurrence estimators of a lens's fitted ghosts for
//! one camera and light.

use anyhow::{Context, Result};
use clap::Args;
use realcam::io::lens_file::LensFile;
use realcam::optics::ghost_prediction::ExposureSetting;
use realcam::tools::flare_predict::{predict, text, PredictRequest};
use std::path::PathBuf;

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct FlarePredictArgs {
    /// Lens file with a [[fitted_ghost]] section.
    #[arg(long)]
    lens: PathBuf,
    /// The light in view space: X,Y,Z (camera at the origin looking down -Z, X right, Y up).
    #[arg(long = "light", value_delimiter = ',', required = true)]
    light_view: Vec<f64>,
    /// The scene's f-number, ISO, exposure time (s), and the light's luminance (cd/m^2) and
    /// solid angle (sr) (eq 8.3's R).
    #[arg(long = "fstop", default_value_t = 8.0)]
    f_number: f64,
    #[arg(long, default_value_t = 100.0)]
    iso: f64,
    #[arg(long = "exposure-time-s", default_value_t = 0.01)]
    exposure_time_s: f64,
    #[arg(long = "light-luminance", default_value_t = 1.0)]
    luminance_cd_m2: f64,
    #[arg(long = "light-solid-angle-sr", default_value_t = 1.0)]
    solid_angle_sr: f64,
    /// The same for the images the ghosts were fitted to (eq 8.3's F); each defaults to the
    /// scene's (a scale of 1).
    #[arg(long = "measured-fstop")]
    measured_f_number: Option<f64>,
    #[arg(long = "measured-iso")]
    measured_iso: Option<f64>,
    #[arg(long = "measured-exposure-time-s")]
    measured_exposure_time_s: Option<f64>,
    #[arg(long = "measured-light-luminance")]
    measured_luminance_cd_m2: Option<f64>,
    #[arg(long = "measured-light-solid-angle-sr")]
    measured_solid_angle_sr: Option<f64>,
    /// The scene's brightest and darkest intensity (eq 9.1), in the flare's units.
    #[arg(long = "scene-max", default_value_t = 1.0)]
    scene_max: f64,
    #[arg(long = "scene-min", default_value_t = 0.0)]
    scene_min: f64,
}

pub fn run(args: &FlarePredictArgs) -> Result<()> {
    let lens = LensFile::load(&args.lens)?;
    let scene = ExposureSetting {
        f_number: args.f_number,
        iso: args.iso,
        exposure_time_s: args.exposure_time_s,
        luminance_cd_m2: args.luminance_cd_m2,
        solid_angle_sr: args.solid_angle_sr,
    };
    let measured = ExposureSetting {
        f_number: args.measured_f_number.unwrap_or(scene.f_number),
        iso: args.measured_iso.unwrap_or(scene.iso),
        exposure_time_s: args.measured_exposure_time_s.unwrap_or(scene.exposure_time_s),
        luminance_cd_m2: args.measured_luminance_cd_m2.unwrap_or(scene.luminance_cd_m2),
        solid_angle_sr: args.measured_solid_angle_sr.unwrap_or(scene.solid_angle_sr),
    };
    let [x, y, z] = args.light_view[..] else {
        anyhow::bail!("--light takes three numbers X,Y,Z, not {}", args.light_view.len())
    };
    let request =
        PredictRequest { light_view: [x, y, z], scene, measured, scene_max: args.scene_max, scene_min: args.scene_min };
    let p = predict(&lens.fitted_ghosts, &request).with_context(|| format!("--lens {}", args.lens.display()))?;
    print!("{}", text(&p));
    Ok(())
}
