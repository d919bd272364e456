//! `realcam lens analyze` and `realcam lens import-lensfun`.

use crate::common::write_text;
use anyhow::Result;
use clap::{Args, Subcommand};
use realcam::io::lens_analysis;
use realcam::io::lensfun::{import, ImportOptions};
use realcam::session::errors::NameFlags;
use std::path::{Path, PathBuf};

#[derive(Subcommand)]
pub enum LensCommand {
    /// Analyze a prescription (a prescription file such as lenses/tessar-walch.toml, or a lens
    /// file with [[surface]] tables) by real ray tracing.
    Analyze {
        file: PathBuf,
        /// f-number to analyze at; default: the prescription's own stop.
        #[arg(long = "fstop")]
        f_number: Option<f64>,
        /// Field angles in degrees (the first must be 0 for --write-tables).
        #[arg(long = "field", default_value = "0,5,10,15,20", value_delimiter = ',')]
        field_deg: Vec<f64>,
        /// Write a lens file with the derived tables: FILE's own settings (or, for a bare
        /// prescription, ones derived from it) plus its surfaces, [tables] and
        /// [longitudinal_color] replaced by the traced values.
        #[arg(long = "write-tables", value_name = "LENS_FILE")]
        write_tables: Option<PathBuf>,
    },
    /// Convert a lens of the lensfun database (its distortion, lateral colour and vignetting
    /// calibrations) into a lens file: printed, or written with --out.
    ImportLensfun(ImportLensfunArgs),
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct ImportLensfunArgs {
    /// The lens model as lensfun names it, e.g. "Carl Zeiss Planar T* 1,4/50 ZF.2" (case,
    /// ',' or '.' and spacing do not matter; the maker may be prefixed).
    model: String,
    /// Write the lens file here (atomically) instead of printing it.
    #[arg(long)]
    out: Option<PathBuf>,
    /// For a zoom: use the calibrations at the focal length nearest this (no interpolation);
    /// default the shortest.
    #[arg(long = "focal-length", value_name = "MM")]
    focal_length_mm: Option<f64>,
    /// Vignetting: per f-number, the calibration at the focus distance nearest this; default the farthest.
    #[arg(long = "distance-m", value_name = "M")]
    distance_m: Option<f64>,
    /// The widest f-number, when lensfun's entry and the model name do not give it (overrides them).
    #[arg(long = "f-number-min", value_name = "N")]
    f_number_min: Option<f64>,
    /// Closest focus in metres (not in lensfun; default 10 focal lengths, marked as assumed).
    #[arg(long = "focus-min-m", value_name = "M")]
    focus_min_m: Option<f64>,
    /// Aperture blades (not in lensfun; default 0, circular, marked as assumed).
    #[arg(long)]
    blades: Option<u32>,
    /// Diagonal of the sensor the tables are for, in mm; default full frame (43.27 mm).
    #[arg(long = "sensor-diagonal-mm", value_name = "MM")]
    sensor_diagonal_mm: Option<f64>,
    /// The lensfun database folder; default $REALCAM_LENSFUN_DIR or /usr/share/lensfun/version_1.
    #[arg(long = "lensfun-dir", value_name = "DIR")]
    lensfun_dir: Option<PathBuf>,
}

pub fn run(command: &LensCommand) -> Result<()> {
    match command {
        LensCommand::Analyze { file, f_number, field_deg, write_tables } => {
            analyze(file, *f_number, field_deg, write_tables.as_deref())
        }
        LensCommand::ImportLensfun(args) => import_lensfun(args),
    }
}

fn analyze(file: &Path, f_number: Option<f64>, field_deg: &[f64], write_tables: Option<&Path>) -> Result<()> {
    let report = lens_analysis::analyze(file, f_number, field_deg).name_flags()?;
    print!("{}", report.analysis);
    if let Some(out) = write_tables {
        write_text(out, &report.lens_file_with_tables(out).name_flags()?)?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

fn import_lensfun(args: &ImportLensfunArgs) -> Result<()> {
    let options = ImportOptions {
        focal_length_mm: args.focal_length_mm,
        distance_m: args.distance_m,
        f_number_min: args.f_number_min,
        focus_min_m: args.focus_min_m,
        blades: args.blades,
        sensor_diagonal_mm: args.sensor_diagonal_mm,
    };
    let imported = import(&args.model, &options, args.lensfun_dir.as_deref()).name_flags()?;
    let crop = imported.entry.crop_factor.map_or_else(|| "not given".to_string(), |c| c.to_string());
    eprintln!("lensfun entry: {} (crop factor {crop})", imported.entry.at);
    for other in &imported.others {
        let crop = other.crop_factor.map_or_else(|| "not given".to_string(), |c| c.to_string());
        eprintln!("  not used: the same model at {} (crop factor {crop})", other.at);
    }
    match &args.out {
        Some(out) => {
            write_text(out, &imported.toml)?;
            eprintln!("wrote {}", out.display());
        }
        None => print!("{}", imported.toml),
    }
    Ok(())
}
