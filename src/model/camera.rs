//! The camera a render uses: lens, aperture, sensor, shutter, ISO, film. Built from a lens file
//! and the user's settings, checked against what the lens allows.

use crate::io::lens_file::LensFile;
use crate::model::aperture::ApertureShape;
use crate::optics::film::FilmCurve;
use crate::optics::sensor::SensorFit;
use crate::optics::{OpticsError, Sensor, ThinLens};

#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    #[error(transparent)]
    Optics(#[from] OpticsError),
    #[error("{what} is outside what the lens {lens:?} allows ({allowed}); pass --force to use it anyway")]
    OutOfRange { what: String, lens: String, allowed: String },
    #[error("{0}")]
    Invalid(String),
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

impl FilmMode {
    /// A film file's response.
    pub fn from_file(film: &crate::io::film_file::FilmFile) -> FilmMode {
        match &film.response {
            crate::io::film_file::FilmResponse::Curve(c) => FilmMode::Curve(*c),
            crate::io::film_file::FilmResponse::Table(t) => FilmMode::Table(std::sync::Arc::new(t.clone())),
        }
    }
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub lens_name: String,
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
    pub film: FilmMode,
    /// User clamp on |CoC| in pixels.
    pub max_coc_px: f64,
    pub bokeh: BokehMode,
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
}

/// What the user asked for; `None` takes the lens file's or the default.
#[derive(Clone, Debug, Default)]
pub struct CameraRequest {
    pub focal_length_mm: Option<f64>,
    pub f_number: Option<f64>,
    pub focus_distance_m: f64,
    pub sensor: Option<String>,
    pub sensor_fit: Option<SensorFit>,
    pub shutter_s: f64,
    pub iso: f64,
    pub nits_per_unit: f64,
    pub blades: Option<u32>,
    pub blade_rotation_deg: Option<f64>,
    /// Spherical aberration amount (-1..1); the lens file's when None.
    pub spherical_aberration: Option<f64>,
    /// Cat's eye at the frame corners (0..1); the lens file's when None.
    pub cats_eye: Option<f64>,
    pub exposure: bool,
    pub vignetting: bool,
    pub film: Option<FilmMode>,
    pub max_coc_px: f64,
    /// Allow settings outside the lens's range.
    pub force: bool,
    pub bokeh: BokehMode,
}

impl Camera {
    pub fn new(lens_file: &LensFile, req: &CameraRequest) -> Result<Camera, CameraError> {
        let focal_length_mm = req.focal_length_mm.unwrap_or(lens_file.focal_length_mm);
        let f_number = req.f_number.unwrap_or(lens_file.f_number_min.max(2.8));
        let focus_distance_mm = req.focus_distance_m * 1000.0;
        let name = lens_file.name.clone();
        let out_of_range =
            |what: String, allowed: String| CameraError::OutOfRange { what, lens: name.clone(), allowed };
        if !req.force {
            if f_number < lens_file.f_number_min - 1e-9 || f_number > lens_file.f_number_max + 1e-9 {
                return Err(out_of_range(
                    format!("f/{f_number}"),
                    format!("f/{} to f/{}", lens_file.f_number_min, lens_file.f_number_max),
                ));
            }
            if req.focus_distance_m < lens_file.focus_min_m {
                return Err(out_of_range(
                    format!("focus distance {} m", req.focus_distance_m),
                    format!("closest focus {} m", lens_file.focus_min_m),
                ));
            }
            if (focal_length_mm - lens_file.focal_length_mm).abs() > 1e-9 {
                return Err(out_of_range(
                    format!("focal length {focal_length_mm} mm"),
                    format!("a prime of {} mm", lens_file.focal_length_mm),
                ));
            }
        }
        let lens = ThinLens::new(focal_length_mm, f_number, focus_distance_mm)?
            .with_pupil_magnification(lens_file.pupil_magnification)?
            .with_transmittance(lens_file.transmittance)?;
        let sensor = Sensor::parse(req.sensor.as_deref().unwrap_or("full-frame"))?;
        for (what, v) in [("shutter", req.shutter_s), ("ISO", req.iso), ("nits per unit", req.nits_per_unit)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(CameraError::Invalid(format!("{what} must be a positive number, got {v}")));
            }
        }
        if !(req.max_coc_px.is_finite() && req.max_coc_px >= 0.0) {
            return Err(CameraError::Invalid(format!("--max-coc must be >= 0 px, got {}", req.max_coc_px)));
        }
        let blades = req.blades.unwrap_or(lens_file.aperture.blades);
        if let Some(c) = req.cats_eye {
            if !(0.0..=1.0).contains(&c) {
                return Err(CameraError::Invalid(format!("--cats-eye {c}: use a value in [0, 1]")));
            }
        }
        if let Some(sa) = req.spherical_aberration {
            if !(-1.0..=1.0).contains(&sa) {
                return Err(CameraError::Invalid(format!(
                    "--spherical-aberration {sa}: use a value in [-1, 1] or 'uniform'"
                )));
            }
        }
        if blades == 1 || blades == 2 || blades > 32 {
            return Err(CameraError::Invalid(format!("--blades {blades}: use 0 (circular) or 3..32")));
        }
        Ok(Camera {
            lens_name: lens_file.name.clone(),
            lens,
            aperture: ApertureShape {
                blades,
                rotation_deg: req.blade_rotation_deg.unwrap_or(lens_file.aperture.rotation_deg),
                curvature: lens_file.aperture.curvature_at(f_number, lens_file.f_number_min),
                spherical_aberration: req.spherical_aberration.unwrap_or(lens_file.spherical_aberration),
                cats_eye: req.cats_eye.unwrap_or(lens_file.aperture.cats_eye),
                // The user's --cats-eye holds at the frame corner; the lens file's may name its height.
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
            shutter_s: req.shutter_s,
            iso: req.iso,
            nits_per_unit: req.nits_per_unit,
            exposure: req.exposure,
            vignetting: req.vignetting,
            film: req.film.clone().unwrap_or(FilmMode::Curve(FilmCurve::default_filmic())),
            max_coc_px: req.max_coc_px,
            bokeh: req.bokeh,
            aperture_mask: None,
            distortion: lens_file.tables.as_ref().map(|t| t.distortion()),
            grain: 0.0,
            seed: 0,
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
        })
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

    /// Longitudinal colour as an offset of the signed CoC of the red and blue channels (px),
    /// for a lens focused at `focus`. A channel whose image surface lies delta behind green's
    /// sees, in the form of src/passes/coc.rs (Kyaw 2013 eq 5.3 with a film offset),
    /// C_c = D' (v w / (1 + delta w) - 1) with w = 1/f - 1/u, i.e. C_c - C_g = -D' delta w / (1 + delta w);
    /// w is taken at the focus distance (w = 1/v), which is exact at the focus plane and off by
    /// at most the magnification's fraction elsewhere.
    pub fn longitudinal_color_coc_px(&self, pixel_pitch_mm: f64) -> Option<[f64; 2]> {
        let [red_mm, blue_mm] = self.longitudinal_color_mm?;
        let l = &self.lens;
        let v_mm = l.image_distance_mm();
        let aperture_px = v_mm / (l.effective_f_number() * l.pupil_magnification) / pixel_pitch_mm;
        let w = 1.0 / v_mm;
        let offset = |delta: f64| -aperture_px * delta * w / (1.0 + delta * w);
        Some([offset(red_mm), offset(blue_mm)])
    }

    /// Settings recorded as EXR attributes on the output.
    pub fn attributes(&self) -> Vec<(String, String)> {
        let l = &self.lens;
        vec![
            ("realcam/lens".into(), self.lens_name.clone()),
            ("realcam/focal_length_mm".into(), format!("{}", l.focal_length_mm)),
            ("realcam/f_number".into(), format!("{}", l.f_number)),
            ("realcam/focus_distance_m".into(), format!("{}", l.focus_distance_mm / 1000.0)),
            ("realcam/sensor_mm".into(), format!("{}x{}", self.sensor.width_mm, self.sensor.height_mm)),
            ("realcam/shutter_s".into(), format!("{}", self.shutter_s)),
            ("realcam/iso".into(), format!("{}", self.iso)),
            ("realcam/aperture_blades".into(), format!("{}", self.aperture.blades)),
            ("realcam/exposure_gain".into(), format!("{}", self.exposure_gain())),
            (
                "realcam/film".into(),
                match self.film {
                    FilmMode::Linear => "linear (scene-referred)".into(),
                    FilmMode::Curve(_) => "characteristic curve".into(),
                    FilmMode::Table(_) => "characteristic curve (table)".into(),
                },
            ),
        ]
    }
}
