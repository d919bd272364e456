//! `realcam dof`: focusing, field of view, exposure and depth-of-field numbers for a lens setting.

use crate::common::LensArgs;
use anyhow::Result;
use clap::Args;
use realcam::model::camera::thin_lens;
use realcam::optics::dof::{dof_report, CocCriterion};
use realcam::optics::Sensor;

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct DofArgs {
    #[command(flatten)]
    lens: LensArgs,
    /// CoC criterion: an image CoC in mm (e.g. 0.03mm) or an angular ratio like 1/1000 (Potmesil & Chakravarty).
    #[arg(long, default_value = "0.03mm")]
    coc: String,
}

pub fn run(args: &DofArgs) -> Result<()> {
    let lens_file = args.lens.lens.load()?;
    let lens = thin_lens(&lens_file, args.lens.focal_length_mm, args.lens.f_number, args.lens.focus_m())?;
    let sensor = Sensor::parse(&args.lens.sensor)?;
    let criterion = CocCriterion::parse(&args.coc)?;
    println!("lens: {}", lens_file.name);
    print!("{}", dof_report(&lens, &sensor, criterion));
    Ok(())
}
