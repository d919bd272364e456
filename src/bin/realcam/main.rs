//! The realcam command line. Only argument handling lives here; the work is in the library.
//! One module per subcommand; [`common`] holds what they share. The render session and the
//! render flags live in the library (`realcam::session`, `realcam::flags`), shared with the
//! Python package.

mod accuracy;
mod bench;
mod common;
mod compare;
mod devices;
mod dof;
mod flare;
mod flare_fit;
mod flare_predict;
mod lens;
mod render;
mod synth;
mod warm_up;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "realcam", version, about = "A realistic camera for rendered images (Vulkan compute)")]
#[command(args_override_self = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render color + depth (+ velocity) EXR passes through a camera.
    Render(Box<realcam::flags::RenderArgs>),
    /// Print focusing, field of view, exposure and depth-of-field numbers for a lens setting.
    Dof(dof::DofArgs),
    /// List the Vulkan devices.
    Devices,
    /// Lenses: analyse a prescription by real ray tracing (paraxial data, distortion, field
    /// curves, spherical aberration, coma, relative illumination, colour) and write its tables
    /// into a lens file; import a lens from the lensfun database.
    Lens {
        #[command(subcommand)]
        command: lens::LensCommand,
    },
    /// Every depth-of-field method on your frame against the diffraction reference: GPU time,
    /// RMSE, PSNR, energy and FLIP, as Markdown, CSV and an SVG plot of error against time.
    Accuracy(accuracy::AccuracyArgs),
    /// The lens flare's ghost models against ghosts traced with real rays through the lens's
    /// prescription, for a point light at several angles: centroid, energy and size errors, and
    /// the CPU and GPU time of each.
    Flare(flare::FlareArgs),
    /// Walch's occurrence estimators (min, max, sum, average, log-average of the flare, and
    /// the contrast it leaves, eq 9.3) of a lens's [[fitted_ghost]] section for a light.
    FlarePredict(flare_predict::FlarePredictArgs),
    /// Trace a lens's ghosts over a range of light angles, fit Walch's primitive to each (ch.
    /// 7) and write each parameter as a polynomial of the angle (ch. 8) into a lens file's
    /// [[fitted_ghost]] section, with the error of the fits and of the polynomials.
    FlareFit(Box<flare_fit::FlareFitArgs>),
    /// GPU time per pass of the depth-of-field methods against the CoC radius (whole frame
    /// defocused), with the fast path's error against the reference.
    Bench(bench::BenchArgs),
    /// Compile the pipelines a render uses into the driver's and realcam's caches, so the first
    /// render on a fresh machine (a farm node, a container, CI) runs at warm speed: run once when
    /// the machine or the farm's image is built.
    WarmUp(warm_up::WarmUpArgs),
    /// Error of an image against a reference (RMSE, PSNR, energy), e.g. against a ray-traced
    /// ground truth.
    Compare {
        /// The image to judge (EXR).
        test: PathBuf,
        /// The reference (EXR).
        reference: PathBuf,
        /// Also measure the defocused discs of the isolated highlights a scene description
        /// lists (a Blender `camera.json`: objects with a role `highlight_*`): each disc's area
        /// (its energy over its plateau, background from an annulus) in both images, their
        /// ratio, and how many are within 2%.
        #[arg(long, value_name = "CAMERA_JSON", requires = "fstop")]
        highlights: Option<PathBuf>,
        /// The f-number both images were rendered at (with --highlights: the renderers' thin
        /// lens at the description's focus distance places each disc's window).
        #[arg(long, requires = "highlights")]
        fstop: Option<f64>,
    },
    /// Write the deterministic synthetic test scenes (testdata/ is made with this), or with
    /// --layered one generated layered scene with its exact defocused image.
    Synth {
        /// Output directory.
        #[arg(long, default_value = "testdata")]
        out: PathBuf,
        /// Instead: the random layered scene of this seed (src/tools/layered_scene.rs, as
        /// tests/generated_scenes.rs renders it): layered_SEED_color.exr (RGBA), _depth.exr (Z)
        /// and _truth.exr (the exact depth of field of `--lens ideal`), and the realcam flags of
        /// its camera.
        #[arg(long, value_name = "SEED")]
        layered: Option<u64>,
        /// Size of the layered scene.
        #[arg(long, default_value = "160x96", requires = "layered")]
        size: String,
        /// With --layered: the scene set in motion (`LayeredScene::random_moving`, as
        /// tests/generated_scenes.rs renders it): layered_SEED_motion_color.exr, _depth.exr,
        /// _vector.exr (Blender's X,Y,Z,W) and _truth.exr (the exact motion blur through a pinhole),
        /// and the realcam flags of its shutter.
        #[arg(long, requires = "layered")]
        motion: bool,
        /// Instead: the README demo K times as large with a velocity pass (the subject and the
        /// near pillar moving), demo_WxH_color.exr, _depth.exr and _vector.exr: 3 gives 1920x1080,
        /// 6 3840x2160, 12 7680x4320 (scripts/bench-gpu.sh).
        #[arg(long, value_name = "K", conflicts_with = "layered", value_parser = clap::value_parser!(u32).range(1..=24))]
        demo_scale: Option<u32>,
    },
}

fn main() {
    realcam::session::PROCESS_START.get_or_init(std::time::Instant::now);
    // First, before any thread starts: SIGINT/SIGTERM remove the temporary outputs.
    realcam::io::output::remove_temporaries_on_signals();
    keep_freed_memory();
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render::run(&args).map(|open| {
            if let Some(session) = open {
                exit_leaving_open(session)
            }
        }),
        Command::Dof(args) => dof::run(&args),
        Command::Devices => devices::run(),
        Command::Lens { command } => lens::run(&command),
        Command::Accuracy(args) => accuracy::run(&args),
        Command::Flare(args) => flare::run(&args),
        Command::FlarePredict(args) => flare_predict::run(&args),
        Command::FlareFit(args) => flare_fit::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Compare { test, reference, highlights, fstop } => {
            compare::run(&test, &reference, highlights.as_deref().zip(fstop))
        }
        Command::Synth { out, layered, size, motion, demo_scale } => {
            synth::run(&out, layered, &size, motion, demo_scale)
        }
        Command::WarmUp(args) => warm_up::run(&args),
    };
    if let Err(e) = result {
        realcam::session::report::say_on_stderr(&format!("error: {}", error_text(&e)));
        std::process::exit(1);
    }
}

pub(crate) use realcam::session::errors::error_text;

/// Ends a successful render whose every output is written and renamed, at once: no destructor
/// or exit handler runs after this. Its last step would otherwise be to close the session's GPU
/// (on lavapipe: the device, its memory block by block, then LLVM's and Mesa's exit handlers),
/// which the OS does faster when the process ends: scene A's whole render, 11 interleaved runs
/// on lavapipe, 202 -> 190 ms median. Only the pipeline cache is written first, as closing the
/// device would.
fn exit_leaving_open(session: realcam::session::Session) -> ! {
    if let Some(gpu) = session.gpu() {
        gpu.save_pipeline_cache();
    }
    use std::io::Write;
    let _ = std::io::stdout().flush();
    let _ = std::io::stderr().flush();
    #[cfg(unix)]
    // SAFETY: _exit ends the process; nothing after it runs, so nothing it skips is used.
    unsafe {
        libc::_exit(0)
    }
    #[cfg(not(unix))]
    std::process::exit(0)
}

/// Frames are large (a 1280x720 RGBA float image is 15 MB) and a run allocates and frees many of
/// them: the passes' bytes, the GPU's images and staging buffers (lavapipe keeps them in host
/// memory), the EXR encoder's. By default glibc maps each such block afresh and unmaps it when
/// freed, so every one costs its page faults again (64,000 faults, 0.25 s of system time for
/// scene A). Served from the heap and kept there, freed blocks are reused: 43,000 faults, and
/// 0.12 s of system time instead of 0.22.
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    unsafe {
        const ONE_GIB: libc::c_int = 1 << 30;
        libc::mallopt(libc::M_MMAP_THRESHOLD, ONE_GIB);
        libc::mallopt(libc::M_TRIM_THRESHOLD, ONE_GIB);
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// Every long flag of the command line, all subcommands.
    fn long_flags(command: &clap::Command, out: &mut Vec<String>) {
        out.extend(command.get_arguments().filter_map(|a| a.get_long()).map(|l| format!("--{l}")));
        command.get_subcommands().for_each(|c| long_flags(c, out));
    }

    /// Here, not in the library's errors module: it needs the whole command line.
    #[test]
    fn every_field_has_a_flag_of_the_command_line() {
        let mut flags = Vec::new();
        long_flags(&super::Cli::command(), &mut flags);
        for (field, flag) in realcam::session::errors::FLAGS {
            assert!(flags.iter().any(|f| f == flag), "{field}: {flag} is no flag of realcam");
        }
        for field in realcam::model::camera::CameraField::ALL {
            assert_ne!(realcam::session::errors::flag(field.name()), field.name(), "{field:?} has no flag");
        }
    }

    #[test]
    fn each_cause_is_said_once() {
        let io = std::io::Error::other("it is a directory");
        let e = anyhow::Error::new(realcam::io::IoError::Read { what: "color".into(), path: "d".into(), source: io });
        assert_eq!(super::error_text(&e), "color: cannot read \"d\": it is a directory");
        let e = anyhow::anyhow!("invalid: reference to missing bytes").context("decoding x.exr");
        assert_eq!(super::error_text(&e), "decoding x.exr: invalid: reference to missing bytes");
    }
}
