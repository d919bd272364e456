//! The camera a render uses: lens, aperture, sensor, shutter, ISO, film. Built from a lens file
//! and the user's settings, checked against what the lens allows.

use crate::io::film_file::{FilmFile, FilmFileError};
use crate::io::lens_file::LensFile;
use crate::io::ExrAttribute;
use crate::model::aperture::ApertureShape;
use crate::optics::film::FilmCurve;
use crate::optics::sensor::SensorFit;
use crate::optics::{Num, OpticsError, Sensor, ThinLens};
use std::path::Path;

/// Defined with the thin lens (a lens file names it too); kept here, where a camera is set up.
pub use crate::optics::lens::CocModel;

/// Why [`Camera::new`] refused a request. A refused setting is named by its field, with the
/// value and what is allowed.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    #[error(transparent)]
    Optics(#[from] OpticsError),
    /// A setting the lens does not allow; [`CameraRequest::force`] lets it through.
    #[error("{} is outside what the lens {lens:?} allows ({allowed})", .field.quantity(*.value))]
    OutOfRange { field: CameraField, value: f64, lens: String, allowed: String },
    /// A setting no camera takes.
    #[error("{} must be {allowed}, got {}", .field.label(), Num(*.value))]
    Invalid { field: CameraField, value: f64, allowed: &'static str },
}

impl CameraError {
    /// The request's field the error is about; None for an optics error.
    pub fn field(&self) -> Option<CameraField> {
        match self {
            CameraError::Optics(_) => None,
            CameraError::OutOfRange { field, .. } | CameraError::Invalid { field, .. } => Some(*field),
        }
    }
}

/// A field of [`CameraRequest`] that [`Camera::new`] checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CameraField {
    FocalLengthMm,
    FNumber,
    FocusDistanceM,
    ShutterS,
    Iso,
    NitsPerUnit,
    Blades,
    SphericalAberration,
    CatsEye,
    MaxCoc,
    Grain,
    BladeRotationDeg,
    BladeCurvature,
    Fps,
    ShutterAngleDeg,
    ShutterRamp,
    RollingShutterS,
    MaxBlurPx,
    FlareThreshold,
    FlareLight,
}

impl CameraField {
    pub const ALL: [CameraField; 20] = [
        CameraField::FocalLengthMm,
        CameraField::FNumber,
        CameraField::FocusDistanceM,
        CameraField::ShutterS,
        CameraField::Iso,
        CameraField::NitsPerUnit,
        CameraField::Blades,
        CameraField::SphericalAberration,
        CameraField::CatsEye,
        CameraField::MaxCoc,
        CameraField::Grain,
        CameraField::BladeRotationDeg,
        CameraField::BladeCurvature,
        CameraField::Fps,
        CameraField::ShutterAngleDeg,
        CameraField::ShutterRamp,
        CameraField::RollingShutterS,
        CameraField::MaxBlurPx,
        CameraField::FlareThreshold,
        CameraField::FlareLight,
    ];

    /// The field's name in [`CameraRequest`].
    pub fn name(self) -> &'static str {
        match self {
            CameraField::FocalLengthMm => "focal_length_mm",
            CameraField::FNumber => "f_number",
            CameraField::FocusDistanceM => "focus_distance_m",
            CameraField::ShutterS => "shutter_s",
            CameraField::Iso => "iso",
            CameraField::NitsPerUnit => "nits_per_unit",
            CameraField::Blades => "blades",
            CameraField::SphericalAberration => "spherical_aberration",
            CameraField::CatsEye => "cats_eye",
            CameraField::MaxCoc => "max_coc",
            CameraField::Grain => "grain",
            CameraField::BladeRotationDeg => "blade_rotation_deg",
            CameraField::BladeCurvature => "blade_curvature",
            CameraField::Fps => "fps",
            CameraField::ShutterAngleDeg => "shutter_angle_deg",
            CameraField::ShutterRamp => "shutter_ramp",
            CameraField::RollingShutterS => "rolling_shutter_s",
            CameraField::MaxBlurPx => "max_blur_px",
            CameraField::FlareThreshold => "flare_threshold",
            CameraField::FlareLight => "flare_lights",
        }
    }

    /// The setting in words, as messages name it.
    pub fn label(self) -> &'static str {
        match self {
            CameraField::FocalLengthMm => "focal length",
            CameraField::FNumber => "f-number",
            CameraField::FocusDistanceM => "focus distance",
            CameraField::ShutterS => "shutter time",
            CameraField::Iso => "ISO",
            CameraField::NitsPerUnit => "nits per unit",
            CameraField::Blades => "number of aperture blades",
            CameraField::SphericalAberration => "spherical aberration",
            CameraField::CatsEye => "cat's eye",
            CameraField::MaxCoc => "maximum CoC diameter",
            CameraField::Grain => "grain",
            CameraField::BladeRotationDeg => "aperture rotation",
            CameraField::BladeCurvature => "blade curvature",
            CameraField::Fps => "frame rate",
            CameraField::ShutterAngleDeg => "shutter angle",
            CameraField::ShutterRamp => "shutter curve ramp",
            CameraField::RollingShutterS => "rolling-shutter readout time",
            CameraField::MaxBlurPx => "largest motion blur",
            CameraField::FlareThreshold => "flare threshold",
            CameraField::FlareLight => "a flare light's numbers",
        }
    }

    /// A value of this setting in words, with its unit: `f/2.8`, `focus distance 0.3 m`.
    pub fn quantity(self, value: f64) -> String {
        let value = Num(value);
        let unit = match self {
            CameraField::FNumber => return format!("f/{value}"),
            CameraField::FocalLengthMm => " mm",
            CameraField::FocusDistanceM => " m",
            CameraField::ShutterS => " s",
            CameraField::BladeRotationDeg => " deg",
            _ => "",
        };
        format!("{} {value}{unit}", self.label())
    }
}

/// The clamp on the CoC diameter: on the film in mm, so that one camera looks the same at every
/// resolution, or in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CocLimit {
    FilmMm(f64),
    Px(f64),
}

impl CocLimit {
    /// 1.2 mm on the film: 64 px of a 1920 px wide full-frame (36 mm) image, the clamp realcam
    /// had in pixels; a twentieth to a thirtieth of the frame's width on the usual sensors.
    pub const DEFAULT: CocLimit = CocLimit::FilmMm(1.2);

    /// The clamp in pixels of `pixel_pitch_mm`.
    pub fn px(self, pixel_pitch_mm: f64) -> f64 {
        match self {
            CocLimit::FilmMm(mm) => mm / pixel_pitch_mm,
            CocLimit::Px(px) => px,
        }
    }

    /// The number as given, in its unit.
    pub fn value(self) -> f64 {
        match self {
            CocLimit::FilmMm(v) | CocLimit::Px(v) => v,
        }
    }
}

impl std::fmt::Display for CocLimit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CocLimit::FilmMm(mm) => write!(f, "{} mm on the film", Num(*mm)),
            CocLimit::Px(px) => write!(f, "{} px", Num(*px)),
        }
    }
}

/// Which depth-of-field method renders the bokeh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BokehMode {
    /// Tiled gather-scatter: exact full-resolution gather for small CoC, fixed-cost
    /// half-resolution gather and highlight sprites for large CoC (src/passes/tiled_dof.rs).
    #[default]
    Tiled,
    /// Every pixel's exact aperture sprite evaluated at every pixel it covers (written as a
    /// gather over the largest CoC): the accuracy reference, cost grows with the CoC squared.
    Reference,
    /// Potmesil & Chakravarty's focus processor: every sample spread by the diffraction pattern
    /// of a defocused circular aperture at three wavelengths (src/optics/focus_processor.rs); no
    /// occlusion. The accuracy reference of `realcam accuracy`.
    Diffraction,
}

/// How sensor values become output values.
#[derive(Clone, Debug, PartialEq)]
pub enum FilmMode {
    /// Scene-referred linear sensor values (for compositing).
    Linear,
    /// Through the film's characteristic curve (display-referred).
    Curve(FilmCurve),
    /// Through a characteristic curve given as a table (a film file's [table]).
    Table(std::sync::Arc<crate::optics::film::FilmTable>),
}

/// The built-in film responses, by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilmPreset {
    /// [`FilmCurve::default_filmic`].
    #[default]
    Filmic,
    /// [`FilmCurve::preset`] `contrast`.
    Contrast,
    /// [`FilmCurve::preset`] `soft`.
    Soft,
    /// [`FilmMode::Linear`].
    Linear,
}

impl FilmMode {
    /// A film file's response.
    pub fn from_file(film: &crate::io::film_file::FilmFile) -> FilmMode {
        match &film.response {
            crate::io::film_file::FilmResponse::Curve(c) => FilmMode::Curve(*c),
            crate::io::film_file::FilmResponse::Table(t) => FilmMode::Table(std::sync::Arc::new(t.clone())),
        }
    }

    /// A built-in response.
    pub fn preset(preset: FilmPreset) -> FilmMode {
        let curve = |name: &str| FilmMode::Curve(FilmCurve::preset(name).unwrap_or_else(FilmCurve::default_filmic));
        match preset {
            FilmPreset::Filmic => FilmMode::Curve(FilmCurve::default_filmic()),
            FilmPreset::Contrast => curve("contrast"),
            FilmPreset::Soft => curve("soft"),
            FilmPreset::Linear => FilmMode::Linear,
        }
    }

    /// The response of the film file at `film_file` when there is one, else the preset's.
    pub fn choose(preset: FilmPreset, film_file: Option<&Path>) -> Result<FilmMode, FilmFileError> {
        match film_file {
            Some(path) => Ok(FilmMode::from_file(&FilmFile::load(path)?)),
            None => Ok(FilmMode::preset(preset)),
        }
    }
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub lens_name: String,
    /// The focal length the lens file is for (mm): the lens as designed, printed on its barrel.
    pub lens_file_focal_length_mm: f64,
    /// The lens file is the ideal lens (any focal length).
    pub lens_is_ideal: bool,
    pub lens: ThinLens,
    pub aperture: ApertureShape,
    pub sensor: Sensor,
    pub sensor_fit: SensorFit,
    pub shutter_s: f64,
    pub iso: f64,
    /// Luminance in cd/m^2 of one scene unit; sets the absolute exposure.
    pub nits_per_unit: f64,
    /// Apply the exposure gain (ISO, shutter, f-number). Off: sensor value = scene value.
    pub exposure: bool,
    pub vignetting: bool,
    /// The lens has natural vignetting (false for the ideal lens, or `natural_vignetting =
    /// false` in its file): `vignetting` is off then whatever the request.
    pub lens_vignettes: bool,
    pub film: FilmMode,
    /// The film's curve is applied to the rendered image (display-referred output); false:
    /// the output keeps scene-referred sensor values and the curve makes only the preview
    /// ([`crate::pipeline::render::preview_rgba`]).
    pub film_on_output: bool,
    /// Clamp on |CoC| ([`CocLimit::px`] for a frame's pitch).
    pub max_coc: CocLimit,
    pub bokeh: BokehMode,
    /// How the CoC follows depth.
    pub coc_model: CocModel,
    /// At anti-aliased depth edges, give each pixel the depth of the layer that brings most of
    /// its light (the CoC pass); off: the depth as stored.
    pub resolve_depth_edges: bool,
    /// A user-supplied aperture image replacing the bladed polygon in the bokeh.
    pub aperture_mask: Option<crate::model::aperture::ApertureMask>,
    /// Distortion and lateral colour against image height, from the lens file's tables.
    pub distortion: Option<crate::optics::distortion::DistortionTables>,
    /// Field curvature: the sharp image surface's offset behind the film (mm) against height.
    pub field_curvature: Option<crate::optics::distortion::HeightTable>,
    /// Relative illumination against image height, from the lens file (else cos^4).
    pub relative_illumination: Option<crate::optics::distortion::HeightTable>,
    /// Sensor noise at ISO 100 (standard deviation at sensor value 1); it grows with the square
    /// root of the ISO speed. 0: none.
    pub grain: f64,
    /// Seed of the noise (deterministic).
    pub seed: u32,
    /// Astigmatism: tangential and sagittal blur length (mm) against image height.
    pub astigmatism: Option<(crate::optics::distortion::HeightTable, crate::optics::distortion::HeightTable)>,
    /// Coma: the comet's length (mm, tangential coma) against image height, at this f-number.
    pub coma: Option<crate::optics::distortion::HeightTable>,
    /// Longitudinal colour: red and blue focus minus green focus (mm, + = behind).
    pub longitudinal_color_mm: Option<[f64; 2]>,
    /// The shutter in time and the motion-blur method.
    pub motion: Motion,
    /// Lens flare: ghosts, starburst and halo around bright lights.
    pub flare: crate::model::flare::FlareSettings,
}

/// Which motion-blur method renders the velocity pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MotionBlurMode {
    /// The tiled reconstruction gather (src/passes/motion_blur.rs): a fixed sample count.
    #[default]
    Fast,
    /// Every source pixel scattered along its path at many sub-frame times with depth ordering
    /// (src/passes/motion_reference.rs): the accuracy reference, cost grows with the blur length.
    Reference,
    /// No motion blur.
    Off,
}

/// The shutter in time: the frame rate that turns pixels per frame into pixels per exposure,
/// when the shutter is open and how, and the motion-blur method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    pub fps: f64,
    /// False: the user gave no frame rate and `fps` is the default.
    pub fps_given: bool,
    pub timing: crate::optics::shutter::ShutterTiming,
    pub mode: MotionBlurMode,
    /// Blur longer than this (px) is clamped.
    pub max_blur_px: f64,
}

/// The frame rate when none is given (film, Blender's and Nuke's default).
pub const DEFAULT_FPS: f64 = 24.0;

/// What the user asked for; `None` takes the lens file's or the default. [`Default`] is the
/// command line's defaults; set what differs with `..CameraRequest::default()`.
#[derive(Clone, Debug)]
pub struct CameraRequest {
    /// The lens file's when None.
    pub focal_length_mm: Option<f64>,
    /// The lens file's widest, but no wider than f/2.8, when None.
    pub f_number: Option<f64>,
    /// Planar, from the lens.
    pub focus_distance_m: f64,
    /// A sensor format name or `WxH` in mm ([`Sensor::parse`]); full frame when None.
    pub sensor: Option<String>,
    /// Horizontal when None.
    pub sensor_fit: Option<SensorFit>,
    pub shutter_s: f64,
    pub iso: f64,
    /// Luminance in cd/m^2 of one scene unit; sets the absolute exposure.
    pub nits_per_unit: f64,
    /// Aperture blades, 0 for circular; the lens file's when None.
    pub blades: Option<u32>,
    /// The lens file's when None.
    pub blade_rotation_deg: Option<f64>,
    /// Spherical aberration amount (-1..1); the lens file's when None.
    pub spherical_aberration: Option<f64>,
    /// Cat's eye at the frame corners (0..1); the lens file's when None.
    pub cats_eye: Option<f64>,
    /// Apply the exposure gain (ISO, shutter, f-number).
    pub exposure: bool,
    /// Apply natural vignetting.
    pub vignetting: bool,
    /// The filmic curve when None.
    pub film: Option<FilmMode>,
    /// Apply the film's curve to the output ([`Camera::film_on_output`]).
    pub film_on_output: bool,
    /// Clamp on |CoC|, on the film or in pixels.
    pub max_coc: CocLimit,
    /// Allow settings outside the lens's range.
    pub force: bool,
    pub bokeh: BokehMode,
    /// The lens file's (or its default) when None.
    pub coc_model: Option<CocModel>,
    /// Blade curvature, 0 straight .. 1 round; the lens file's when None.
    pub blade_curvature: Option<f64>,
    /// Resolve anti-aliased depth edges ([`Camera::resolve_depth_edges`]).
    pub resolve_depth_edges: bool,
    /// Sensor noise at ISO 100 ([`Camera::grain`]); 0: none.
    pub grain: f64,
    /// Seed of the noise.
    pub seed: u32,
    /// Record lens flare where it would be visible.
    pub flare: bool,
    /// A pixel belongs to a light from this many times the sensor's saturation.
    pub flare_threshold: f64,
    /// Lights given explicitly.
    pub flare_lights: Vec<crate::model::flare::FlareLight>,
    /// Frames per second of the sequence; [`DEFAULT_FPS`] when None.
    pub fps: Option<f64>,
    /// The shutter as an angle (degrees of a frame) instead of `shutter_s`; the exposure uses the
    /// time it makes.
    pub shutter_angle_deg: Option<f64>,
    pub shutter_position: crate::optics::shutter::ShutterPosition,
    pub shutter_curve: crate::optics::shutter::ShutterCurve,
    /// A rolling (focal-plane) shutter: the readout time from the first line to the last.
    pub rolling_shutter_s: Option<f64>,
    pub rolling_direction: crate::optics::shutter::RollingDirection,
    pub motion_blur: MotionBlurMode,
    /// Clamp on the motion blur length in pixels.
    pub max_blur_px: f64,
}

impl Default for CameraRequest {
    /// The lens file's focal length, aperture and aberrations, focused at 2 m, on a full-frame
    /// sensor; 1/50 s at ISO 100 with a scene value of 1 at 160 cd/m^2 (a scene value of 0.18
    /// is middle grey at f/2); exposure and vignetting on, the filmic curve, the CoC clamped at
    /// 1.2 mm on the film ([`CocLimit::DEFAULT`]), tiled bokeh, no grain, lens flare from one stop
    /// over saturation.
    fn default() -> Self {
        CameraRequest {
            focal_length_mm: None,
            f_number: None,
            focus_distance_m: 2.0,
            sensor: None,
            sensor_fit: None,
            shutter_s: 1.0 / 50.0,
            iso: 100.0,
            nits_per_unit: 160.0,
            blades: None,
            blade_rotation_deg: None,
            spherical_aberration: None,
            cats_eye: None,
            exposure: true,
            vignetting: true,
            film: None,
            film_on_output: true,
            max_coc: CocLimit::DEFAULT,
            force: false,
            bokeh: BokehMode::Tiled,
            coc_model: None,
            blade_curvature: None,
            resolve_depth_edges: true,
            grain: 0.0,
            seed: 0,
            fps: None,
            shutter_angle_deg: None,
            shutter_position: Default::default(),
            shutter_curve: Default::default(),
            rolling_shutter_s: None,
            rolling_direction: Default::default(),
            motion_blur: MotionBlurMode::Fast,
            max_blur_px: 512.0,
            flare: true,
            flare_threshold: crate::model::flare::FlareSettings::DEFAULT_THRESHOLD,
            flare_lights: Vec::new(),
        }
    }
}

impl CameraRequest {
    /// Depth of field alone: no exposure gain, vignetting, film curve or lens flare, so pixel
    /// values stay scene values, and no spherical aberration or cat's eye in the bokeh (which
    /// the diffraction reference does not model); the rest as [`Default`].
    pub fn blur_only() -> CameraRequest {
        CameraRequest {
            spherical_aberration: Some(0.0),
            cats_eye: Some(0.0),
            exposure: false,
            vignetting: false,
            flare: false,
            film: Some(FilmMode::Linear),
            ..CameraRequest::default()
        }
    }

    /// This request with the focal length, f-number and focus distance given.
    pub fn with_lens(self, focal_length_mm: f64, f_number: f64, focus_distance_m: f64) -> CameraRequest {
        CameraRequest { focal_length_mm: Some(focal_length_mm), f_number: Some(f_number), focus_distance_m, ..self }
    }
}

/// `lens_file` as a thin lens (its pupil magnification and transmittance) at a setting; the
/// lens file's focal length and widest aperture where none is given. Not checked against the
/// lens's range.
pub fn thin_lens(
    lens_file: &LensFile,
    focal_length_mm: Option<f64>,
    f_number: Option<f64>,
    focus_distance_m: f64,
) -> Result<ThinLens, OpticsError> {
    ThinLens::new(
        focal_length_mm.unwrap_or(lens_file.focal_length_mm),
        f_number.unwrap_or(lens_file.f_number_min),
        focus_distance_m * 1000.0,
    )?
    .with_pupil_magnification(lens_file.pupil_magnification)?
    .with_transmittance(lens_file.transmittance)
}

impl Camera {
    pub fn new(lens_file: &LensFile, req: &CameraRequest) -> Result<Camera, CameraError> {
        let focal_length_mm = req.focal_length_mm.unwrap_or(lens_file.focal_length_mm);
        let f_number = req.f_number.unwrap_or(lens_file.f_number_min.max(2.8));
        let out_of_range = |field: CameraField, value: f64, allowed: String| {
            Err(CameraError::OutOfRange { field, value, lens: lens_file.name.clone(), allowed })
        };
        // What no lens can do (f/0, focus inside the focal length) first: --force cannot help.
        let lens = thin_lens(lens_file, Some(focal_length_mm), Some(f_number), req.focus_distance_m)?;
        if !req.force && !lens_file.ideal {
            if f_number < lens_file.f_number_min - 1e-9 || f_number > lens_file.f_number_max + 1e-9 {
                let allowed = format!("f/{} to f/{}", Num(lens_file.f_number_min), Num(lens_file.f_number_max));
                return out_of_range(CameraField::FNumber, f_number, allowed);
            }
            if req.focus_distance_m < lens_file.focus_min_m {
                let allowed = format!("closest focus {} m", Num(lens_file.focus_min_m));
                return out_of_range(CameraField::FocusDistanceM, req.focus_distance_m, allowed);
            }
            if (focal_length_mm - lens_file.focal_length_mm).abs() > 1e-9 {
                let allowed = format!("a prime of {} mm", Num(lens_file.focal_length_mm));
                return out_of_range(CameraField::FocalLengthMm, focal_length_mm, allowed);
            }
        }
        let sensor = Sensor::parse(req.sensor.as_deref().unwrap_or("full-frame"))?;
        let require = |field: CameraField, value: f64, ok: bool, allowed: &'static str| {
            if ok && value.is_finite() {
                Ok(())
            } else {
                Err(CameraError::Invalid { field, value, allowed })
            }
        };
        let fps = req.fps.unwrap_or(DEFAULT_FPS);
        require(CameraField::Fps, fps, fps > 0.0, "a positive number of frames per second")?;
        if let Some(angle) = req.shutter_angle_deg {
            require(CameraField::ShutterAngleDeg, angle, angle > 0.0 && angle <= 360.0, "in (0, 360] degrees")?;
        }
        // A shutter angle is a time: angle / 360 of a frame. The exposure uses it too.
        let shutter_s = req.shutter_angle_deg.map_or(req.shutter_s, |angle| angle / 360.0 / fps);
        require(CameraField::ShutterS, shutter_s, shutter_s > 0.0, "a positive number")?;
        if let crate::optics::shutter::ShutterCurve::Trapezoid { ramp } = req.shutter_curve {
            require(CameraField::ShutterRamp, ramp, ramp > 0.0 && ramp <= 0.5, "in (0, 0.5] of the open time")?;
        }
        if let Some(r) = req.rolling_shutter_s {
            require(CameraField::RollingShutterS, r, r >= 0.0, "a time >= 0 s")?;
        }
        require(CameraField::MaxBlurPx, req.max_blur_px, req.max_blur_px > 0.0, "a positive number of pixels")?;
        let mut timing =
            crate::optics::shutter::ShutterTiming::new(shutter_s, fps, req.shutter_position, req.shutter_curve);
        if let Some(r) = req.rolling_shutter_s {
            timing = timing.with_rolling(r, fps, req.rolling_direction);
        }
        require(CameraField::Iso, req.iso, req.iso > 0.0, "a positive number")?;
        require(CameraField::NitsPerUnit, req.nits_per_unit, req.nits_per_unit > 0.0, "a positive number")?;
        let max_coc = req.max_coc.value();
        require(CameraField::MaxCoc, max_coc, max_coc >= 0.0, "a diameter >= 0 (px, or mm on the film)")?;
        if let Some(c) = req.cats_eye {
            require(CameraField::CatsEye, c, (0.0..=1.0).contains(&c), "in [0, 1]")?;
        }
        if let Some(a) = req.spherical_aberration {
            require(CameraField::SphericalAberration, a, (-1.0..=1.0).contains(&a), "in [-1, 1]")?;
        }
        let blades = req.blades.unwrap_or(lens_file.aperture.blades);
        require(
            CameraField::Blades,
            blades.into(),
            blades == 0 || (3..=32).contains(&blades),
            "0 (circular) or 3..32",
        )?;
        require(CameraField::Grain, req.grain, req.grain >= 0.0, "a non-negative number")?;
        if let Some(r) = req.blade_rotation_deg {
            require(CameraField::BladeRotationDeg, r, true, "a finite angle in degrees")?;
        }
        if let Some(c) = req.blade_curvature {
            require(CameraField::BladeCurvature, c, (0.0..=1.0).contains(&c), "in [0, 1]")?;
        }
        require(CameraField::FlareThreshold, req.flare_threshold, req.flare_threshold > 0.0, "a positive factor")?;
        if let Some(bad) = req.flare_lights.iter().find(|l| !l.is_valid()) {
            let value =
                [bad.x_px, bad.y_px, bad.area_px].into_iter().chain(bad.energy).find(|v| !v.is_finite() || *v < 0.0);
            require(CameraField::FlareLight, value.unwrap_or(f64::NAN), false, "finite, with energy and area >= 0")?;
        }
        Ok(Camera {
            lens_name: lens_file.name.clone(),
            lens_file_focal_length_mm: lens_file.focal_length_mm,
            lens_is_ideal: lens_file.ideal,
            lens,
            aperture: ApertureShape {
                blades,
                rotation_deg: req.blade_rotation_deg.unwrap_or(lens_file.aperture.rotation_deg),
                curvature: req
                    .blade_curvature
                    .unwrap_or_else(|| lens_file.aperture.curvature_at(f_number, lens_file.f_number_min)),
                spherical_aberration: req.spherical_aberration.unwrap_or(lens_file.spherical_aberration),
                cats_eye: req.cats_eye.unwrap_or(lens_file.aperture.cats_eye),
                // A requested cat's eye holds at the frame corner; the lens file's may name its height.
                cats_eye_at_mm: if req.cats_eye.is_some() { None } else { lens_file.aperture.cats_eye_at_mm },
                // Traced LSA goes as the pupil height squared (third order); an amount the user
                // asks for replaces it.
                lsa_rim_mm: match (req.spherical_aberration, lens_file.longitudinal_spherical_aberration) {
                    (None, Some(l)) => Some(l.rim_mm * (l.at_f_number / f_number).powi(2)),
                    _ => None,
                },
            },
            sensor,
            sensor_fit: req.sensor_fit.unwrap_or(SensorFit::Horizontal),
            shutter_s,
            iso: req.iso,
            nits_per_unit: req.nits_per_unit,
            exposure: req.exposure,
            vignetting: req.vignetting && lens_file.natural_vignetting.unwrap_or(!lens_file.ideal),
            lens_vignettes: lens_file.natural_vignetting.unwrap_or(!lens_file.ideal),
            film: req.film.clone().unwrap_or(FilmMode::Curve(FilmCurve::default_filmic())),
            film_on_output: req.film_on_output,
            max_coc: req.max_coc,
            bokeh: req.bokeh,
            coc_model: req.coc_model.or(lens_file.coc_model).unwrap_or(if lens_file.ideal {
                CocModel::Renderer
            } else {
                CocModel::Physical
            }),
            resolve_depth_edges: req.resolve_depth_edges,
            aperture_mask: None,
            distortion: lens_file.tables.as_ref().map(|t| t.distortion()),
            grain: req.grain,
            seed: req.seed,
            relative_illumination: lens_file.tables.as_ref().and_then(|t| t.relative_illumination(f_number)),
            field_curvature: lens_file.tables.as_ref().and_then(|t| t.field_curvature()),
            astigmatism: lens_file.tables.as_ref().and_then(|t| {
                let s = t.blur_scale(f_number);
                t.astigmatism().map(|(mut tan, mut sag)| {
                    tan.values.iter_mut().chain(sag.values.iter_mut()).for_each(|v| *v *= s);
                    (tan, sag)
                })
            }),
            coma: lens_file.tables.as_ref().and_then(|t| t.coma(f_number)),
            longitudinal_color_mm: lens_file.longitudinal_color.map(|c| [c.red_mm, c.blue_mm]),
            motion: Motion {
                fps,
                fps_given: req.fps.is_some(),
                timing,
                mode: req.motion_blur,
                max_blur_px: req.max_blur_px,
            },
            flare: crate::model::flare::FlareSettings {
                enabled: req.flare,
                threshold: req.flare_threshold,
                lights: req.flare_lights.clone(),
                // The file was checked when it was read: its surfaces make a prescription.
                prescription: (!lens_file.surfaces.is_empty())
                    .then(|| {
                        crate::optics::prescription::Prescription::from_specs(
                            &lens_file.name,
                            &lens_file.surfaces,
                            "",
                            "",
                        )
                    })
                    .and_then(Result::ok)
                    .map(std::sync::Arc::new),
                coating_design_nm: lens_file.flare.coating_nm(),
                halo: crate::optics::flare::starburst::Halo {
                    fraction: lens_file.flare.halo_fraction,
                    radius_mm: lens_file.flare.halo_radius_mm,
                },
            },
        })
    }

    /// The signed CoC diameter (mm on the film) of a point at `object_distance_mm`, by the
    /// camera's CoC model.
    pub fn coc_mm(&self, object_distance_mm: f64) -> f64 {
        match self.coc_model {
            CocModel::Physical => self.lens.coc_mm(object_distance_mm),
            CocModel::Renderer => self.lens.coc_renderer_mm(object_distance_mm),
        }
    }

    /// Pixel pitch on the film for an image of this size.
    pub fn pixel_pitch_mm(&self, width_px: u32, height_px: u32) -> f64 {
        self.sensor.pixel_pitch_mm(width_px, height_px, self.sensor_fit)
    }

    /// Standard deviation of the sensor noise at sensor value 1 for this ISO speed.
    pub fn noise_sigma(&self) -> f64 {
        self.grain.max(0.0) * (self.iso / 100.0).sqrt()
    }

    /// Linear gain from scene value to sensor value (1 = saturation); 1 with exposure off.
    pub fn exposure_gain(&self) -> f64 {
        if self.exposure {
            crate::optics::exposure::exposure_gain(&self.lens, self.shutter_s, self.iso, self.nits_per_unit)
        } else {
            1.0
        }
    }

    /// Longitudinal colour at the channel wavelengths `nm` (R, G, B): the red and the blue
    /// channel's focus minus the green channel's (mm), from the lens file's C- and F-line values
    /// ([`crate::optics::wavelengths::channel_values`]).
    pub fn longitudinal_color_mm_at(&self, nm: [f64; 3]) -> Option<[f64; 2]> {
        let [red_mm, blue_mm] = self.longitudinal_color_mm?;
        Some(crate::optics::wavelengths::channel_values(red_mm, blue_mm, nm))
    }

    /// Longitudinal colour as an offset of the signed CoC of the red and blue channels (px) at
    /// the channel wavelengths `nm`, for a lens focused at `focus`. A channel whose image surface lies delta behind green's
    /// sees, in the form of src/passes/coc.rs (Kyaw 2013 eq 5.3 with a film offset),
    /// C_c = D' (v w / (1 + delta w) - 1) with w = 1/f - 1/u, i.e. C_c - C_g = -D' delta w / (1 + delta w);
    /// w is taken at the focus distance (w = 1/v), which is exact at the focus plane and off by
    /// at most the magnification's fraction elsewhere.
    pub fn longitudinal_color_coc_px(&self, pixel_pitch_mm: f64, nm: [f64; 3]) -> Option<[f64; 2]> {
        let [red_mm, blue_mm] = self.longitudinal_color_mm_at(nm)?;
        let l = &self.lens;
        let v_mm = l.image_distance_mm();
        let aperture_px = v_mm / (l.effective_f_number() * l.pupil_magnification) / pixel_pitch_mm;
        let w = 1.0 / v_mm;
        let offset = |delta: f64| -aperture_px * delta * w / (1.0 + delta * w);
        Some([offset(red_mm), offset(blue_mm)])
    }

    /// Settings recorded as typed EXR attributes on an output of `width_px` x `height_px`:
    /// OpenEXR's standard ones where they exist (`aperture` f-number, `expTime` s, `focus` m,
    /// `isoSpeed`, and OpenEXR 3.2's `lensModel`, `nominalFocalLength` mm (the lens's own),
    /// `effectiveFocalLength` mm (the one rendered), `tStop`, `sensorOverallDimensions` mm,
    /// `sensorPhotositePitch` um, `shutterAngle` deg, `framesPerSecond`), `realcam/...` for
    /// the rest.
    pub fn attributes(&self, width_px: u32, height_px: u32) -> Vec<(String, ExrAttribute)> {
        let l = &self.lens;
        let f32_ = |v: f64| ExrAttribute::F32(v as f32);
        let text = |v: &str| ExrAttribute::Text(v.to_string());
        let fps = self.motion.fps;
        let mut attributes = vec![
            ("aperture", f32_(l.f_number)),
            ("expTime", f32_(self.shutter_s)),
            ("focus", f32_(l.focus_distance_mm / 1000.0)),
            ("isoSpeed", f32_(self.iso)),
            ("lensModel", text(&self.lens_name)),
            ("nominalFocalLength", f32_(self.lens_file_focal_length_mm)),
            ("effectiveFocalLength", f32_(l.focal_length_mm)),
            // T-stop: the f-number of a lossless lens passing the same light, N / sqrt(T).
            ("tStop", f32_(l.f_number / l.transmittance.sqrt())),
            ("sensorOverallDimensions", ExrAttribute::V2f([self.sensor.width_mm as f32, self.sensor.height_mm as f32])),
            ("sensorPhotositePitch", f32_(self.pixel_pitch_mm(width_px, height_px) * 1000.0)),
            ("shutterAngle", f32_(self.shutter_s * fps * 360.0)),
            ("realcam/sensor_fit", text(self.sensor_fit.name())),
            ("realcam/aperture_blades", ExrAttribute::I32(self.aperture.blades as i32)),
            ("realcam/exposure_gain", f32_(self.exposure_gain())),
            (
                "realcam/film",
                text(match (&self.film, self.film_on_output) {
                    (FilmMode::Linear, _) | (_, false) => "linear (scene-referred)",
                    (FilmMode::Curve(_), true) => "characteristic curve",
                    (FilmMode::Table(_), true) => "characteristic curve (table)",
                }),
            ),
        ];
        // A whole number of frames per second as OpenEXR's rational (24/1), else in 1/1000.
        if fps.fract() == 0.0 && fps <= i32::MAX as f64 {
            attributes.push(("framesPerSecond", ExrAttribute::Rational(fps as i32, 1)));
        } else if fps * 1000.0 <= i32::MAX as f64 {
            attributes.push(("framesPerSecond", ExrAttribute::Rational((fps * 1000.0).round() as i32, 1000)));
        }
        attributes.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
    }

    /// The numbers a user matches against the 3D camera that rendered a frame whose display
    /// window is `width_px` x `height_px` (multi-line, for `--explain`): focal length,
    /// aperture and focus, sensor, fit, pixel pitch and field of view, the lens and the
    /// aberrations in use.
    pub fn explain_camera(&self, width_px: u32, height_px: u32) -> String {
        let l = &self.lens;
        let pitch_mm = self.pixel_pitch_mm(width_px, height_px);
        let (frame_w_mm, frame_h_mm) = (pitch_mm * f64::from(width_px), pitch_mm * f64::from(height_px));
        // Field of view of the frame on the film, the angle a pinhole at f sees.
        let fov_deg = |side_mm: f64| 2.0 * (side_mm / (2.0 * l.focal_length_mm)).atan().to_degrees();
        let mut aberrations = Vec::new();
        let table_in_use =
            |t: &Option<crate::optics::distortion::HeightTable>| t.as_ref().is_some_and(|t| !t.is_zero());
        if let Some(d) = &self.distortion {
            if !d.green_percent.is_zero() {
                aberrations.push("distortion".to_string());
            }
            if !d.red_extra_percent.is_zero() || !d.blue_extra_percent.is_zero() {
                aberrations.push("lateral colour".into());
            }
        }
        if let Some(mm) = self.longitudinal_color_mm.filter(|[r, b]| *r != 0.0 || *b != 0.0) {
            aberrations.push(format!("longitudinal colour (red {} mm, blue {} mm)", Num(mm[0]), Num(mm[1])));
        }
        if let Some(rim_mm) = self.aperture.lsa_rim_mm {
            aberrations.push(format!("spherical aberration (traced, rim {} mm)", Num(rim_mm)));
        } else if self.aperture.spherical_aberration != 0.0 {
            aberrations.push(format!("spherical aberration {}", Num(self.aperture.spherical_aberration)));
        }
        if table_in_use(&self.field_curvature) {
            aberrations.push("field curvature".into());
        }
        if self.astigmatism.as_ref().is_some_and(|(t, s)| !t.is_zero() || !s.is_zero()) {
            aberrations.push("astigmatism".into());
        }
        if table_in_use(&self.coma) {
            aberrations.push("coma".into());
        }
        if self.aperture.cats_eye > 0.0 {
            aberrations.push(format!("cat's eye {}", Num(self.aperture.cats_eye)));
        }
        if self.vignetting {
            let how = if self.relative_illumination.is_some() { "the lens's table" } else { "cos^4" };
            aberrations.push(format!("natural vignetting ({how})"));
        }
        if self.flare.enabled {
            let ghosts = if self.flare.prescription.is_some() { "ghosts, " } else { "" };
            aberrations.push(format!("lens flare ({ghosts}starburst, halo)"));
        }
        let aberrations = if aberrations.is_empty() { "none".to_string() } else { aberrations.join(", ") };
        let blades = match self.aperture.blades {
            0 => "circular aperture".to_string(),
            n => format!("{n} blades rotated {} deg", Num(self.aperture.rotation_deg)),
        };
        format!(
            "camera (match against the 3D camera):\n  lens: \"{}\" ({} mm lens file{})\n  focal length {} mm, f/{}, \
             focus {} m, {blades}; shutter {} s, ISO {}\n  sensor {} x {} mm, fit {}: the frame is {:.3} x {:.3} mm, \
             pixel pitch {:.6} mm ({:.3} um); field of view {:.2} x {:.2} deg\n  aberrations: {aberrations}",
            self.lens_name,
            Num(self.lens_file_focal_length_mm),
            if self.lens_is_ideal { ", the ideal lens: any focal length" } else { "" },
            Num(l.focal_length_mm),
            Num(l.f_number),
            Num(l.focus_distance_mm / 1000.0),
            Num(self.shutter_s),
            Num(self.iso),
            Num(self.sensor.width_mm),
            Num(self.sensor.height_mm),
            self.sensor_fit.name(),
            frame_w_mm,
            frame_h_mm,
            pitch_mm,
            pitch_mm * 1000.0,
            fov_deg(frame_w_mm),
            fov_deg(frame_h_mm),
        )
    }

    /// A warning when the lens file was made for another focal length than the render's
    /// (`render_focal_length_mm`: what the input says it was rendered with, else the camera's
    /// own focal length): its tables and aberrations belong to that focal length.
    pub fn focal_length_warning(&self, render_focal_length_mm: Option<f64>) -> Option<String> {
        let (lens_mm, render_mm) = (self.lens_file_focal_length_mm, render_focal_length_mm?);
        if self.lens_is_ideal || (lens_mm - render_mm).abs() <= 0.005 * render_mm {
            return None;
        }
        Some(format!(
            "the lens file \"{}\" is for {} mm but the render was made with {} mm: its field of view, tables \
             and aberrations do not match the render's camera",
            self.lens_name,
            Num(lens_mm),
            Num(render_mm)
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(req: &CameraRequest) -> Result<Camera, CameraError> {
        Camera::new(&LensFile::default_lens(), req)
    }

    #[test]
    fn the_default_request_is_the_command_line_default() {
        let c = camera(&CameraRequest::default()).unwrap();
        assert_eq!((c.lens.focal_length_mm, c.lens.f_number, c.lens.focus_distance_mm), (50.0, 2.8, 2000.0));
        assert_eq!((c.sensor.width_mm, c.sensor.height_mm, c.sensor_fit), (36.0, 24.0, SensorFit::Horizontal));
        assert_eq!((c.shutter_s, c.iso, c.nits_per_unit, c.max_coc), (0.02, 100.0, 160.0, CocLimit::FilmMm(1.2)));
        // 64 px of a 1920 px wide full-frame image.
        assert!((c.max_coc.px(36.0 / 1920.0) - 64.0).abs() < 1e-12);
        assert!(c.exposure && c.vignetting);
        assert_eq!(c.film, FilmMode::Curve(FilmCurve::default_filmic()));
        assert_eq!((c.bokeh, c.grain, c.seed), (BokehMode::Tiled, 0.0, 0));
    }

    #[test]
    fn blur_only_keeps_scene_values_and_a_plain_aperture() {
        let req = CameraRequest::blur_only().with_lens(35.0, 4.0, 3.0);
        let c = camera(&CameraRequest { force: true, ..req }).unwrap();
        assert_eq!((c.lens.focal_length_mm, c.lens.f_number, c.lens.focus_distance_mm), (35.0, 4.0, 3000.0));
        assert!(!c.exposure && !c.vignetting);
        assert_eq!(c.exposure_gain(), 1.0);
        assert_eq!(c.film, FilmMode::Linear);
        assert_eq!((c.aperture.spherical_aberration, c.aperture.cats_eye), (0.0, 0.0));
    }

    #[test]
    fn invalid_settings_name_the_field_the_value_and_what_is_allowed() {
        let cases = [
            (
                CameraRequest { iso: -5.0, ..Default::default() },
                CameraField::Iso,
                "ISO must be a positive number, got -5",
            ),
            (
                CameraRequest { shutter_s: 0.0, ..Default::default() },
                CameraField::ShutterS,
                "shutter time must be a positive number, got 0",
            ),
            (
                CameraRequest { max_coc: CocLimit::Px(-1.0), ..Default::default() },
                CameraField::MaxCoc,
                "maximum CoC diameter must be a diameter >= 0 (px, or mm on the film), got -1",
            ),
            (
                CameraRequest { cats_eye: Some(1.5), ..Default::default() },
                CameraField::CatsEye,
                "cat's eye must be in [0, 1], got 1.5",
            ),
            (
                CameraRequest { spherical_aberration: Some(f64::NAN), ..Default::default() },
                CameraField::SphericalAberration,
                "spherical aberration must be in [-1, 1], got NaN",
            ),
            (
                CameraRequest { blades: Some(2), ..Default::default() },
                CameraField::Blades,
                "number of aperture blades must be 0 (circular) or 3..32, got 2",
            ),
            (
                CameraRequest { grain: -0.5, ..Default::default() },
                CameraField::Grain,
                "grain must be a non-negative number, got -0.5",
            ),
            (
                CameraRequest { blade_rotation_deg: Some(f64::NAN), ..Default::default() },
                CameraField::BladeRotationDeg,
                "aperture rotation must be a finite angle in degrees, got NaN",
            ),
            (
                CameraRequest { blade_rotation_deg: Some(f64::INFINITY), ..Default::default() },
                CameraField::BladeRotationDeg,
                "aperture rotation must be a finite angle in degrees, got inf",
            ),
            (
                CameraRequest { iso: 1e308, nits_per_unit: f64::INFINITY, ..Default::default() },
                CameraField::NitsPerUnit,
                "nits per unit must be a positive number, got inf",
            ),
        ];
        for (req, field, message) in cases {
            let err = camera(&req).unwrap_err();
            assert!(matches!(err, CameraError::Invalid { .. }), "{err:?}");
            assert_eq!(err.field(), Some(field));
            assert_eq!(err.to_string(), message);
        }
        for blades in [0, 3, 32] {
            camera(&CameraRequest { blades: Some(blades), ..Default::default() }).unwrap();
        }
    }

    #[test]
    fn settings_outside_the_lens_need_force() {
        let lens = "\"realcam standard 50 mm f/1.4\"";
        let cases = [
            (CameraRequest { f_number: Some(1.0), ..Default::default() }, CameraField::FNumber, "f/1", "f/1.4 to f/16"),
            (
                CameraRequest { focus_distance_m: 0.3, ..Default::default() },
                CameraField::FocusDistanceM,
                "focus distance 0.3 m",
                "closest focus 0.45 m",
            ),
            (
                CameraRequest { focal_length_mm: Some(85.0), ..Default::default() },
                CameraField::FocalLengthMm,
                "focal length 85 mm",
                "a prime of 50 mm",
            ),
        ];
        for (req, field, what, allowed) in cases {
            let err = camera(&req).unwrap_err();
            assert!(matches!(err, CameraError::OutOfRange { .. }), "{err:?}");
            assert_eq!(err.field(), Some(field));
            assert_eq!(err.to_string(), format!("{what} is outside what the lens {lens} allows ({allowed})"));
            camera(&CameraRequest { force: true, ..req }).unwrap();
        }
    }

    #[test]
    fn what_no_lens_can_do_is_refused_without_offering_force() {
        for req in [
            CameraRequest { f_number: Some(0.0), ..Default::default() },
            CameraRequest { f_number: Some(0.0), force: true, ..Default::default() },
        ] {
            let err = camera(&req).unwrap_err();
            assert!(matches!(err, CameraError::Optics(_)), "{err:?}");
            assert_eq!(err.to_string(), "f-number must be positive, got f/0");
        }
        // A lens file's limit of 1e308 is printed as such, not as 309 digits.
        let mut lens = LensFile::default_lens();
        lens.f_number_max = 1e308;
        let err = Camera::new(&lens, &CameraRequest { f_number: Some(1.0), ..Default::default() }).unwrap_err();
        assert_eq!(
            err.to_string(),
            "f/1 is outside what the lens \"realcam standard 50 mm f/1.4\" allows (f/1.4 to f/1e308)"
        );
    }

    #[test]
    fn a_shutter_angle_is_a_time_and_the_exposure_uses_it() {
        // 180 degrees at 24 fps: 1/48 s, open a quarter frame either side of the frame time;
        // 90 degrees lets in half the light.
        let req = |angle| CameraRequest { fps: Some(24.0), shutter_angle_deg: Some(angle), ..Default::default() };
        let (half, quarter) = (camera(&req(180.0)).unwrap(), camera(&req(90.0)).unwrap());
        assert!((half.shutter_s - 1.0 / 48.0).abs() < 1e-15);
        let t = half.motion.timing;
        assert!((t.open_frames + 0.25).abs() < 1e-12 && (t.close_frames - 0.25).abs() < 1e-12);
        assert!((half.exposure_gain() / quarter.exposure_gain() - 2.0).abs() < 1e-12);
        // Without a frame rate: 24 assumed, and said to be.
        let assumed = camera(&CameraRequest::default()).unwrap();
        assert_eq!((assumed.motion.fps, assumed.motion.fps_given), (DEFAULT_FPS, false));
        for (req, field, message) in [
            (
                CameraRequest { fps: Some(0.0), ..Default::default() },
                CameraField::Fps,
                "frame rate must be a positive number of frames per second, got 0",
            ),
            (req(0.0), CameraField::ShutterAngleDeg, "shutter angle must be in (0, 360] degrees, got 0"),
            (
                CameraRequest { rolling_shutter_s: Some(-0.01), ..Default::default() },
                CameraField::RollingShutterS,
                "rolling-shutter readout time must be a time >= 0 s, got -0.01",
            ),
            (
                CameraRequest { max_blur_px: 0.0, ..Default::default() },
                CameraField::MaxBlurPx,
                "largest motion blur must be a positive number of pixels, got 0",
            ),
        ] {
            let err = camera(&req).unwrap_err();
            assert_eq!((err.field(), err.to_string()), (Some(field), message.to_string()));
        }
    }

    #[test]
    fn field_names_are_distinct() {
        let names: std::collections::BTreeSet<_> = CameraField::ALL.iter().map(|f| f.name()).collect();
        assert_eq!(names.len(), CameraField::ALL.len());
    }

    #[test]
    fn a_film_file_replaces_the_preset() {
        let films = Path::new(env!("CARGO_MANIFEST_DIR")).join("films");
        assert_eq!(FilmMode::choose(FilmPreset::Linear, None).unwrap(), FilmMode::Linear);
        assert_eq!(
            FilmMode::choose(FilmPreset::default(), None).unwrap(),
            FilmMode::Curve(FilmCurve::default_filmic())
        );
        let soft = FilmMode::Curve(FilmCurve::preset("soft").unwrap());
        assert_eq!(FilmMode::preset(FilmPreset::Soft), soft);
        assert_eq!(FilmMode::choose(FilmPreset::Linear, Some(&films.join("soft.toml"))).unwrap(), soft);
        let err = FilmMode::choose(FilmPreset::Linear, Some(&films.join("missing.toml"))).unwrap_err();
        assert!(err.to_string().contains("missing.toml"), "{err}");
    }

    #[test]
    fn thin_lens_takes_the_lens_file_where_nothing_is_given() {
        let file = LensFile::default_lens();
        let lens = thin_lens(&file, None, None, 3.0).unwrap();
        assert_eq!((lens.focal_length_mm, lens.f_number, lens.focus_distance_mm), (50.0, 1.4, 3000.0));
        assert_eq!((lens.pupil_magnification, lens.transmittance), (file.pupil_magnification, file.transmittance));
        assert!(thin_lens(&file, Some(50.0), Some(2.0), 0.03).is_err());
    }
}
