//! The lens, its setting and the GPU: the flags `render` shares with the other subcommands.

use crate::gpu::{Gpu, GpuOptions};
use crate::io::lens_file::LensFile;
use crate::model::camera::{CameraField, CameraRequest, CocModel};
use crate::optics::sensor::SensorFit;
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// The lens of a command: a lens file, or a lens of the lensfun database.
#[derive(Args, Clone)]
pub struct LensChoice {
    /// Lens file (TOML, see lenses/), or a built-in lens: `ideal` (the renderer's thin lens:
    /// any focal length and f-number, no aberration, the renderers' CoC) or `default`; the
    /// built-in default lens when neither this nor --lens-lensfun is given.
    #[arg(long)]
    pub lens: Option<PathBuf>,
    /// A lens of the lensfun database by model name (as `realcam lens import-lensfun` converts
    /// it with its defaults; for a zoom, its shortest calibrated focal length).
    #[arg(long = "lens-lensfun", value_name = "MODEL", conflicts_with = "lens")]
    pub lens_lensfun: Option<String>,
}

impl LensChoice {
    pub fn load(&self) -> Result<LensFile> {
        Ok(match (&self.lens, &self.lens_lensfun) {
            // A built-in name, unless a file of that name is there.
            (Some(p), _) => match p.to_str().and_then(LensFile::built_in) {
                Some(built_in) if !p.exists() => built_in,
                _ => LensFile::load(p)?,
            },
            (None, Some(model)) => {
                let options = crate::io::lensfun::ImportOptions::default();
                crate::io::lensfun::import_lens_file(model, &options, None)
                    .with_context(|| format!("--lens-lensfun {model:?}"))?
            }
            (None, None) => LensFile::default_lens(),
        })
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum FitArg {
    Horizontal,
    Vertical,
    Auto,
}

impl From<FitArg> for SensorFit {
    fn from(fit: FitArg) -> SensorFit {
        match fit {
            FitArg::Horizontal => SensorFit::Horizontal,
            FitArg::Vertical => SensorFit::Vertical,
            FitArg::Auto => SensorFit::Auto,
        }
    }
}

#[derive(Args, Clone)]
pub struct LensArgs {
    /// Lens file (TOML, see lenses/) or --lens-lensfun MODEL; the built-in default lens when absent.
    #[command(flatten)]
    pub lens: LensChoice,
    /// Focal length in mm (must match a prime lens file unless --force); default: the camera
    /// file's, else the lens file's (the ideal lens: the input's, else 50 mm).
    #[arg(long = "focal-length")]
    pub focal_length_mm: Option<f64>,
    /// f-number N; default: the camera file's, else the input's `aperture` attribute, else the
    /// lens's widest but no wider than f/2.8.
    #[arg(long = "fstop")]
    pub f_number: Option<f64>,
    /// Focus distance in metres (planar, from the lens); default: the camera file's, else the
    /// input's `focus` attribute, else 2 m.
    #[arg(long = "focus")]
    pub focus_m: Option<f64>,
    /// Sensor: full-frame (36x24), super35, aps-c, aps-c-canon, m43, 1in, apsh, medium-format, or WxH in mm.
    #[arg(long, default_value = "full-frame")]
    pub sensor: String,
    /// Which image dimension the sensor width maps to (Blender's sensor fit).
    #[arg(long = "sensor-fit", value_enum, default_value = "horizontal")]
    pub sensor_fit: FitArg,
    /// Allow settings outside the lens file's range.
    #[arg(long)]
    pub force: bool,
    /// How the CoC follows depth: `physical` (Kyaw 2013 eq 5.3: the film at the image distance,
    /// with focus breathing) or `renderer` (a thin lens at the pinhole keeping the image scale
    /// of the focal length, as Cycles, Arnold and RenderMan); default from the lens file.
    #[arg(long = "coc-model", value_enum)]
    pub coc_model: Option<CocModelArg>,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum CocModelArg {
    Physical,
    Renderer,
}

impl LensArgs {
    /// The focus distance of --focus, else the default 2 m.
    pub fn focus_m(&self) -> f64 {
        self.focus_m.unwrap_or(CameraRequest::default().focus_distance_m)
    }

    /// The settings of a shot these flags give (the rest may come from a camera file or the
    /// input's header).
    pub fn given(&self) -> Vec<CameraField> {
        let given = [
            (CameraField::FocalLengthMm, self.focal_length_mm.is_some()),
            (CameraField::FNumber, self.f_number.is_some()),
            (CameraField::FocusDistanceM, self.focus_m.is_some()),
        ];
        given.into_iter().filter_map(|(field, given)| given.then_some(field)).collect()
    }

    /// `base` with the lens setting, the sensor and --force of these flags.
    pub fn request(&self, base: CameraRequest) -> CameraRequest {
        CameraRequest {
            focal_length_mm: self.focal_length_mm,
            f_number: self.f_number,
            focus_distance_m: self.focus_m.unwrap_or(base.focus_distance_m),
            sensor: Some(self.sensor.clone()),
            sensor_fit: Some(self.sensor_fit.into()),
            force: self.force,
            coc_model: self.coc_model.map(|m| match m {
                CocModelArg::Physical => CocModel::Physical,
                CocModelArg::Renderer => CocModel::Renderer,
            }),
            ..base
        }
    }
}

#[derive(Args, Clone)]
pub struct GpuArgs {
    /// Enable the Khronos validation layer with synchronization validation (also REALCAM_VALIDATE=1).
    #[arg(long)]
    pub validate: bool,
    /// Vulkan device: index from `realcam devices` or part of its name (also REALCAM_DEVICE).
    #[arg(long)]
    pub device: Option<String>,
    /// At most this much GPU memory for a frame (e.g. 512M, 2G, 1.5GB; default: the device's
    /// memory); `render` renders a frame that needs more in horizontal bands, the other
    /// commands refuse it.
    #[arg(long, value_name = "BYTES", value_parser = crate::model::settings::parse_bytes)]
    pub max_gpu_memory: Option<u64>,
}

impl GpuArgs {
    /// The GPU these flags and the environment ask for (REALCAM_VALIDATE, REALCAM_DEVICE).
    pub fn options(&self) -> GpuOptions {
        let mut options = GpuOptions::from_env();
        options.validation |= self.validate;
        if self.device.is_some() {
            options.device = self.device.clone();
        }
        options.max_memory_bytes = self.max_gpu_memory;
        options
    }

    /// The GPU of [`GpuArgs::options`], opened; prints it.
    pub fn open(&self) -> Result<Gpu> {
        let gpu = crate::session::open_gpu(&self.options())?;
        crate::session::report::say_on_stderr(&format!("device: {}", gpu.info()));
        Ok(gpu)
    }
}
