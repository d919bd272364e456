//! `realcam warm-up`: the pipelines a render uses compiled into the driver's shader cache and
//! realcam's pipeline cache (src/tools/warm_up.rs).

use crate::common::GpuArgs;
use anyhow::{anyhow, Context, Result};
use clap::{Args, Parser};
use realcam::flags::RenderArgs;

/// The render flags warmed up for by default: the defaults (the built-in default lens, f/2 as the
/// demo, grain), `--lens ideal` (the renderers' camera, circular and 6 blades).
const DEFAULT_CONFIGURATIONS: [&str; 5] =
    ["", "--fstop 2 --focus 2", "--grain 0.02", "--lens ideal", "--lens ideal --blades 6"];

#[derive(Args)]
pub struct WarmUpArgs {
    /// The render flags to warm up for, one configuration per argument (e.g. "--lens
    /// lenses/zeiss-otus-85-f1.4.toml --fstop 1.4"): the pipelines are specialised by the
    /// aperture and the film. Default: the defaults, `--fstop 2 --focus 2`, `--grain 0.02`,
    /// `--lens ideal`, `--lens ideal --blades 6`.
    #[arg(long = "flags", allow_hyphen_values = true)]
    configurations: Vec<String>,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// `realcam render`'s flags, parsed as the render parses them.
#[derive(Parser)]
struct Render {
    #[command(flatten)]
    args: RenderArgs,
}

pub fn run(args: &WarmUpArgs) -> Result<()> {
    let configurations: Vec<String> = if args.configurations.is_empty() {
        DEFAULT_CONFIGURATIONS.iter().map(|s| s.to_string()).collect()
    } else {
        args.configurations.clone()
    };
    let cameras = configurations
        .iter()
        .map(|flags| {
            let argv = ["render", "--color", "warm-up.exr", "-o", "warm-up-out.exr"].into_iter().map(String::from);
            let parsed = Render::try_parse_from(argv.chain(flags.split_whitespace().map(String::from)))
                .map_err(|e| anyhow!("--flags {flags:?}: {}", e.to_string().lines().next().unwrap_or_default()))?;
            let camera = parsed.args.camera().with_context(|| format!("--flags {flags:?}"))?;
            let name = if flags.is_empty() { "(defaults)".to_string() } else { flags.clone() };
            Ok((name, camera))
        })
        .collect::<Result<Vec<_>>>()?;
    let gpu = args.gpu.open()?;
    let start = std::time::Instant::now();
    let runs = realcam::tools::warm_up::run(&gpu, &cameras, |run| {
        realcam::session::report::say_on_stderr(&format!(
            "warmed up {:<26} {:6.2} s  ({})",
            run.name,
            run.seconds,
            run.passes.join(", ")
        ))
    })
    .map_err(|e| anyhow!("warm-up: {e}"))?;
    let mesa = std::env::var("MESA_SHADER_CACHE_DIR").unwrap_or_else(|_| "~/.cache/mesa_shader_cache".into());
    println!(
        "{} configurations in {:.1} s: their pipelines are in the driver's shader cache (Mesa: {mesa}) and realcam's pipeline cache",
        runs.len(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
