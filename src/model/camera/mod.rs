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

mod error;
pub mod keys;
mod new;
mod report;
mod request;
pub mod shot;

pub use error::{CameraError, CameraField};
pub use new::thin_lens;
pub use request::{CameraRequest, DEFAULT_FPS};
pub use shot::{FrameCamera, InputCamera, SettingSource, ShotCamera, ShotError};

/// Defined with the thin lens (a lens file names it too); kept here, where a camera is set up.
pub use crate::optics::lens::CocModel;

/// The clamp on the CoC diameter: none, on the film in mm, so that one camera looks the same
/// at every resolution, or in pixels. Whatever the clamp, the planner keeps a disc within twice
/// the frame's diagonal ([`crate::passes::scene::coc_clamp_px`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CocLimit {
    /// No clamp: every disc as large as the lens draws it.
    None,
    FilmMm(f64),
    Px(f64),
}

impl CocLimit {
    /// No clamp: a clamp changes the picture of an ordinary lens (50 mm f/1.4 focused at 1 m
    /// draws a point at 10 m as a disc of 1.7 mm on the film), and the tiled path's pyramid
    /// makes large discs cheap. (realcam clamped at 1.2 mm on the film before.)
    pub const DEFAULT: CocLimit = CocLimit::None;

    /// The clamp in pixels of `pixel_pitch_mm` (infinite for none).
    pub fn px(self, pixel_pitch_mm: f64) -> f64 {
        match self {
            CocLimit::None => f64::INFINITY,
            CocLimit::FilmMm(mm) => mm / pixel_pitch_mm,
            CocLimit::Px(px) => px,
        }
    }

    /// The number as given, in its unit (none: infinite).
    pub fn value(self) -> f64 {
        match self {
            CocLimit::None => f64::INFINITY,
            CocLimit::FilmMm(v) | CocLimit::Px(v) => v,
        }
    }
}

impl std::fmt::Display for CocLimit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CocLimit::None => write!(f, "no clamp"),
            CocLimit::FilmMm(mm) => write!(f, "{} mm on the film", Num(*mm)),
            CocLimit::Px(px) => write!(f, "{} px", Num(*px)),
        }
    }
}

/// Which depth-of-field method renders the bokeh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BokehMode {
    /// Tiled gather-scatter: exact full-resolution gather for small CoC, fixed-cost
    /// half-resolution gather and highlight sprites for large CoC (src/passes/dof/tiled.rs).
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
    /// Where the settings a shot may change came from, in words (a flag, the shot's keys, the
    /// input's header, a default), for `--explain` and the output header; empty for a camera
    /// made directly ([`ShotCamera`] fills it).
    pub setting_sources: Vec<(CameraField, String)>,
}

/// Which motion-blur method renders the velocity pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MotionBlurMode {
    /// The tiled reconstruction gather (src/passes/motion/blur.rs): a fixed sample count.
    #[default]
    Fast,
    /// Every source pixel scattered along its path at many sub-frame times with depth ordering
    /// (src/passes/motion/reference.rs): the accuracy reference, cost grows with the blur length.
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

/// The grain's seed of frame `frame` for the seed `seed`: the seed plus a bijective integer
/// mix of the frame number (two xorshift-multiply rounds, MurmurHash3's 64-bit finaliser),
/// which maps 0 to 0 and neighbouring frames to unrelated values.
pub fn frame_seed(seed: u32, frame: i64) -> u32 {
    let mut x = frame as u64;
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    x ^= x >> 33;
    seed.wrapping_add((x ^ (x >> 32)) as u32)
}

impl Camera {
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

    /// This camera for frame `frame` of a sequence: its grain seeded by the seed and the frame
    /// number ([`frame_seed`]), so that neighbouring frames' noise is independent and a frame
    /// rendered again gets the same noise. Frame 0 keeps the seed (a single frame's render).
    pub fn at_frame(&self, frame: i64) -> Camera {
        Camera { seed: frame_seed(self.seed, frame), ..self.clone() }
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
    /// sees, in the form of src/passes/dof/coc.rs (Kyaw 2013 eq 5.3 with a film offset),
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
        assert_eq!((c.shutter_s, c.iso, c.nits_per_unit, c.max_coc), (0.02, 100.0, 160.0, CocLimit::None));
        // No clamp; 1.2 mm on the film is 64 px of a 1920 px wide full-frame image.
        assert_eq!(c.max_coc.px(36.0 / 1920.0), f64::INFINITY);
        assert!((CocLimit::FilmMm(1.2).px(36.0 / 1920.0) - 64.0).abs() < 1e-12);
        // Flare on for a real lens, off for the ideal one unless asked for.
        assert!(c.flare.enabled);
        let ideal = LensFile::built_in("ideal").unwrap();
        let off = Camera::new(&ideal, &CameraRequest::default()).unwrap();
        assert_eq!((off.flare.enabled, off.flare.off_by), (false, crate::model::flare::FlareOff::IdealLens));
        let on = Camera::new(&ideal, &CameraRequest { flare: Some(true), ..CameraRequest::default() }).unwrap();
        assert!(on.flare.enabled);
        let asked = camera(&CameraRequest { flare: Some(false), ..CameraRequest::default() }).unwrap();
        assert_eq!((asked.flare.enabled, asked.flare.off_by), (false, crate::model::flare::FlareOff::Asked));
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
