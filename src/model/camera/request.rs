//! What the user asks of a camera, and the command line's defaults.

use super::{BokehMode, CocLimit, CocModel, FilmMode, MotionBlurMode};
use crate::optics::sensor::SensorFit;

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
    /// A sensor format name or `WxH` in mm ([`Sensor::parse`](crate::optics::Sensor::parse));
    /// full frame when None.
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
    /// Apply the film's curve to the output
    /// ([`Camera::film_on_output`](super::Camera::film_on_output)).
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
    /// Resolve anti-aliased depth edges
    /// ([`Camera::resolve_depth_edges`](super::Camera::resolve_depth_edges)).
    pub resolve_depth_edges: bool,
    /// Sensor noise at ISO 100 ([`Camera::grain`](super::Camera::grain)); 0: none.
    pub grain: f64,
    /// Seed of the noise.
    pub seed: u32,
    /// Record lens flare where it would be visible; None: the lens's default, on for every lens
    /// but the ideal one (the renderer's camera draws no flare).
    pub flare: Option<bool>,
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
    /// Which model draws the lens's ghosts (`--flare-ghosts`).
    pub flare_ghosts: crate::model::flare::FlareGhosts,
}

impl Default for CameraRequest {
    /// The lens file's focal length, aperture and aberrations, focused at 2 m, on a full-frame
    /// sensor; 1/50 s at ISO 100 with a scene value of 1 at 160 cd/m^2 (a scene value of 0.18
    /// is middle grey at f/2); exposure and vignetting on, the filmic curve, no clamp on the CoC
    /// ([`CocLimit::DEFAULT`]), tiled bokeh, no grain, lens flare from one stop
    /// over saturation (none for the ideal lens).
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
            flare: None,
            flare_threshold: crate::model::flare::FlareSettings::DEFAULT_THRESHOLD,
            flare_lights: Vec::new(),
            flare_ghosts: crate::model::flare::FlareGhosts::Auto,
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
            flare: Some(false),
            film: Some(FilmMode::Linear),
            ..CameraRequest::default()
        }
    }

    /// This request with the focal length, f-number and focus distance given.
    pub fn with_lens(self, focal_length_mm: f64, f_number: f64, focus_distance_m: f64) -> CameraRequest {
        CameraRequest { focal_length_mm: Some(focal_length_mm), f_number: Some(f_number), focus_distance_m, ..self }
    }
}
