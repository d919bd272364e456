//! `realcam flare-predict`: Walch ch. 9's occurrence estimators of a lens's fitted ghosts for
//! one camera and light, or over a grid or a path of lights (sec. 9.2's statistics and bins,
//! as a table, a CSV file and an SVG plot).

use anyhow::{Context, Result};
use clap::Args;
use realcam::io::lens_file::LensFile;
use realcam::io::output::Outputs;
use realcam::optics::ghost_prediction::ExposureSetting;
use realcam::tools::flare_predict::range::{predict_range, range_from_flags, Estimator, RangeError, RangeRequest};
use realcam::tools::flare_predict::{predict, report, text, PredictRequest};
use std::path::PathBuf;

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct FlarePredictArgs {
    /// Lens file with a [[fitted_ghost]] section.
    #[arg(long)]
    lens: PathBuf,
    /// The light in view space: X,Y,Z (camera at the origin looking down -Z, X right, Y up).
    /// One of --light, --grid and --path.
    #[arg(long = "light", value_delimiter = ',')]
    light_view: Vec<f64>,
    /// A grid of COLSxROWS lights over the frame, each seen through its cell's centre
    /// (needs --fov-deg).
    #[arg(long)]
    grid: Option<String>,
    /// The horizontal field of view (degrees) of the frame the ghosts were fitted on (--grid).
    #[arg(long = "fov-deg")]
    fov_deg: Option<f64>,
    /// A light moving on a line in view space: X,Y,Z:X,Y,Z (its two ends), at --steps points.
    #[arg(long, allow_hyphen_values = true)]
    path: Option<String>,
    /// Points on the --path, both ends included.
    #[arg(long, default_value_t = 11)]
    steps: u32,
    /// The estimator a range's bins, plot and threshold are of: min, max, sum, average,
    /// log-average or contrast-ratio.
    #[arg(long, default_value = "contrast-ratio")]
    estimator: String,
    /// The flare counted as occurring where the estimator reaches this (contrast-ratio at or
    /// below it, the others at or above); contrast-ratio's default is 0.95.
    #[arg(long)]
    threshold: Option<f64>,
    /// Bins of the estimator's range over the positions (sec. 9.2).
    #[arg(long, default_value_t = 5)]
    bins: usize,
    /// A range's flare drawn at every this many pixels across and down (1: every pixel; 4 or
    /// 8 make a grid over a large frame 16 or 64 times quicker, the estimators approximate).
    #[arg(long = "sample-px", default_value_t = 1)]
    sample_px: u32,
    /// A range's positions as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// A range's plot as SVG: a heat map over the frame (--grid) or a line along the path.
    #[arg(long)]
    svg: Option<PathBuf>,
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
    let given: Vec<&str> =
        [("--light", !args.light_view.is_empty()), ("--grid", args.grid.is_some()), ("--path", args.path.is_some())]
            .iter()
            .filter(|f| f.1)
            .map(|f| f.0)
            .collect();
    if given.len() != 1 {
        anyhow::bail!(
            "give one of --light X,Y,Z, --grid COLSxROWS or --path X,Y,Z:X,Y,Z{}",
            if given.is_empty() { String::new() } else { format!(", not {}", given.join(" and ")) }
        );
    }
    let range = range_from_flags(args.grid.as_deref(), args.fov_deg, args.path.as_deref(), args.steps)?;
    let lens = LensFile::load(&args.lens)?;
    if let Some(range) = range {
        let estimator: Estimator = args.estimator.parse()?;
        let base = PredictRequest {
            light_view: [0.0, 0.0, -1.0],
            scene,
            measured,
            scene_max: args.scene_max,
            scene_min: args.scene_min,
        };
        let request = RangeRequest {
            range,
            base,
            estimator,
            threshold: args.threshold,
            bins: args.bins,
            sample_px: args.sample_px,
        };
        return run_range(args, &lens, &request);
    }
    if args.csv.is_some() || args.svg.is_some() {
        anyhow::bail!("--csv and --svg are written for a range of lights (--grid or --path), not for one --light");
    }
    let [x, y, z] = args.light_view[..] else {
        anyhow::bail!("--light takes three numbers X,Y,Z, not {}", args.light_view.len())
    };
    let request =
        PredictRequest { light_view: [x, y, z], scene, measured, scene_max: args.scene_max, scene_min: args.scene_min };
    let p = predict(&lens.fitted_ghosts, &request).with_context(|| format!("--lens {}", args.lens.display()))?;
    print!("{}", text(&p));
    Ok(())
}

/// A range's prediction: the table on stdout, the CSV and SVG files through temporaries beside
/// them (all checked, and kept apart from the lens file, before any work).
fn run_range(args: &FlarePredictArgs, lens: &LensFile, request: &RangeRequest) -> Result<()> {
    let files: Vec<(&'static str, &std::path::Path)> = [("--csv", args.csv.as_deref()), ("--svg", args.svg.as_deref())]
        .into_iter()
        .filter_map(|(f, p)| Some((f, p?)))
        .collect();
    let mut outputs = (!files.is_empty()).then(|| Outputs::new(&files, &[("--lens", &args.lens)])).transpose()?;
    let r = predict_range(&lens.fitted_ghosts, request).map_err(|e| match e {
        RangeError::Lens(e) => anyhow::Error::new(e).context(format!("--lens {}", args.lens.display())),
        other => other.into(),
    })?;
    print!("{}", report::text(&r));
    if let Some(mut outputs) = outputs.take() {
        if args.csv.is_some() {
            outputs.write("--csv", report::csv(&r).as_bytes())?;
        }
        if args.svg.is_some() {
            outputs.write("--svg", report::svg(&r).as_bytes())?;
        }
        outputs.commit()?;
        for (_, p) in files {
            eprintln!("wrote {}", p.display());
        }
    }
    Ok(())
}
