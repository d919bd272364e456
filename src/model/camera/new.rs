//! [`Camera::new`]: a request checked against the lens file and made a camera.

use super::*;
use crate::model::flare::{FlareOff, FlareSettings};
use crate::optics::distortion::HeightTable;
use crate::optics::shutter::{ShutterCurve, ShutterTiming};

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

/// `Ok` when `value` is finite and `ok`; else the field refused with what is allowed.
fn require(field: CameraField, value: f64, ok: bool, allowed: &'static str) -> Result<(), CameraError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(CameraError::Invalid { field, value, allowed })
    }
}

/// The f-number, focus distance and focal length against the lens's range (unless forced or
/// the lens is the ideal one).
fn check_lens_range(
    lens_file: &LensFile,
    req: &CameraRequest,
    focal_length_mm: f64,
    f_number: f64,
) -> Result<(), CameraError> {
    let out_of_range = |field: CameraField, value: f64, allowed: String| {
        Err(CameraError::OutOfRange { field, value, lens: lens_file.name.clone(), allowed })
    };
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
    Ok(())
}

/// The shutter's settings checked (frame rate, angle or time, curve, rolling readout, blur
/// clamp): the frame rate, the open time (s) and the shutter's timing.
fn check_shutter(req: &CameraRequest) -> Result<(f64, f64, ShutterTiming), CameraError> {
    let fps = req.fps.unwrap_or(DEFAULT_FPS);
    require(CameraField::Fps, fps, fps > 0.0, "a positive number of frames per second")?;
    if let Some(angle) = req.shutter_angle_deg {
        require(CameraField::ShutterAngleDeg, angle, angle > 0.0 && angle <= 360.0, "in (0, 360] degrees")?;
    }
    // A shutter angle is a time: angle / 360 of a frame. The exposure uses it too.
    let shutter_s = req.shutter_angle_deg.map_or(req.shutter_s, |angle| angle / 360.0 / fps);
    require(CameraField::ShutterS, shutter_s, shutter_s > 0.0, "a positive number")?;
    if let ShutterCurve::Trapezoid { ramp } = req.shutter_curve {
        require(CameraField::ShutterRamp, ramp, ramp > 0.0 && ramp <= 0.5, "in (0, 0.5] of the open time")?;
    }
    if let Some(r) = req.rolling_shutter_s {
        require(CameraField::RollingShutterS, r, r >= 0.0, "a time >= 0 s")?;
    }
    require(CameraField::MaxBlurPx, req.max_blur_px, req.max_blur_px > 0.0, "a positive number of pixels")?;
    let mut timing = ShutterTiming::new(shutter_s, fps, req.shutter_position, req.shutter_curve);
    if let Some(r) = req.rolling_shutter_s {
        timing = timing.with_rolling(r, fps, req.rolling_direction);
    }
    Ok((fps, shutter_s, timing))
}

/// The exposure, bokeh, grain and flare settings checked; the number of aperture blades.
fn check_image_settings(lens_file: &LensFile, req: &CameraRequest) -> Result<u32, CameraError> {
    require(CameraField::Iso, req.iso, req.iso > 0.0, "a positive number")?;
    require(CameraField::NitsPerUnit, req.nits_per_unit, req.nits_per_unit > 0.0, "a positive number")?;
    if req.max_coc != CocLimit::None {
        let max_coc = req.max_coc.value();
        require(CameraField::MaxCoc, max_coc, max_coc >= 0.0, "a diameter >= 0 (px, or mm on the film)")?;
    }
    if let Some(c) = req.cats_eye {
        require(CameraField::CatsEye, c, (0.0..=1.0).contains(&c), "in [0, 1]")?;
    }
    if let Some(a) = req.spherical_aberration {
        require(CameraField::SphericalAberration, a, (-1.0..=1.0).contains(&a), "in [-1, 1]")?;
    }
    let blades = req.blades.unwrap_or(lens_file.aperture.blades);
    require(CameraField::Blades, blades.into(), blades == 0 || (3..=32).contains(&blades), "0 (circular) or 3..32")?;
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
    Ok(blades)
}

/// The aperture's shape: the request's settings, else the lens file's at `f_number`.
fn aperture_shape(lens_file: &LensFile, req: &CameraRequest, blades: u32, f_number: f64) -> ApertureShape {
    ApertureShape {
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
    }
}

/// The lens file's astigmatism (tangential, sagittal) scaled to the blur at `f_number`.
fn astigmatism(lens_file: &LensFile, f_number: f64) -> Option<(HeightTable, HeightTable)> {
    lens_file.tables.as_ref().and_then(|t| {
        let s = t.blur_scale(f_number);
        t.astigmatism().map(|(mut tan, mut sag)| {
            tan.values.iter_mut().chain(sag.values.iter_mut()).for_each(|v| *v *= s);
            (tan, sag)
        })
    })
}

/// The flare settings: the request's, with the lens file's prescription, coatings and halo.
fn flare_settings(lens_file: &LensFile, req: &CameraRequest) -> FlareSettings {
    // The ideal lens is the renderer's camera: no flare unless asked for.
    let enabled = req.flare.unwrap_or(!lens_file.ideal);
    FlareSettings {
        enabled,
        off_by: if req.flare.is_none() && lens_file.ideal { FlareOff::IdealLens } else { FlareOff::Asked },
        threshold: req.flare_threshold,
        lights: req.flare_lights.clone(),
        // The file was checked when it was read: its surfaces make a prescription.
        prescription: (!lens_file.surfaces.is_empty())
            .then(|| {
                crate::optics::prescription::Prescription::from_specs(&lens_file.name, &lens_file.surfaces, "", "")
            })
            .and_then(Result::ok)
            .map(std::sync::Arc::new),
        coating_design_nm: lens_file.flare.coating_nm(),
        halo: crate::optics::flare::starburst::Halo {
            fraction: lens_file.flare.halo_fraction,
            radius_mm: lens_file.flare.halo_radius_mm,
        },
        ghosts: req.flare_ghosts,
        fitted: lens_file.fitted_ghosts.clone(),
    }
}

impl Camera {
    pub fn new(lens_file: &LensFile, req: &CameraRequest) -> Result<Camera, CameraError> {
        let focal_length_mm = req.focal_length_mm.unwrap_or(lens_file.focal_length_mm);
        let f_number = req.f_number.unwrap_or(lens_file.f_number_min.max(2.8));
        // What no lens can do (f/0, focus inside the focal length) first: --force cannot help.
        let lens = thin_lens(lens_file, Some(focal_length_mm), Some(f_number), req.focus_distance_m)?;
        check_lens_range(lens_file, req, focal_length_mm, f_number)?;
        let sensor = Sensor::parse(req.sensor.as_deref().unwrap_or("full-frame"))?;
        let (fps, shutter_s, timing) = check_shutter(req)?;
        let blades = check_image_settings(lens_file, req)?;
        let camera = Camera {
            lens_name: lens_file.name.clone(),
            lens_file_focal_length_mm: lens_file.focal_length_mm,
            lens_is_ideal: lens_file.ideal,
            lens,
            aperture: aperture_shape(lens_file, req, blades, f_number),
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
            astigmatism: astigmatism(lens_file, f_number),
            coma: lens_file.tables.as_ref().and_then(|t| t.coma(f_number)),
            longitudinal_color_mm: lens_file.longitudinal_color.map(|c| [c.red_mm, c.blue_mm]),
            motion: Motion {
                fps,
                fps_given: req.fps.is_some(),
                timing,
                mode: req.motion_blur,
                max_blur_px: req.max_blur_px,
            },
            flare: flare_settings(lens_file, req),
            setting_sources: Vec::new(),
        };
        check_overflow(&camera)?;
        Ok(camera)
    }
}

/// The largest gain from scene value to sensor value, and the largest spread of the grain at
/// sensor value 1: beyond them the frame's 32-bit values become Inf (issue 34).
const MAX_EXPOSURE_GAIN: f64 = 1e30;
const MAX_NOISE_SIGMA: f64 = 1e30;

/// Refuses an exposure whose gain, or grain whose spread, cannot be finite: the setting that
/// brightens it most (in stops from its default) is named, with the bound that would do.
fn check_overflow(c: &Camera) -> Result<(), CameraError> {
    use crate::optics::exposure::exposure_gain;
    let gain = c.exposure_gain();
    if c.exposure && (gain.is_nan() || gain > MAX_EXPOSURE_GAIN) {
        let settings = [
            (CameraField::Iso, c.iso, c.iso / 100.0),
            (CameraField::ShutterS, c.shutter_s, c.shutter_s * 50.0),
            (CameraField::NitsPerUnit, c.nits_per_unit, c.nits_per_unit / 160.0),
            (CameraField::FNumber, c.lens.f_number, (2.8 / c.lens.f_number).powi(2)),
        ];
        let (field, value, _) = settings.into_iter().fold(settings[0], |a, b| if b.2 > a.2 { b } else { a });
        // The gain is linear in ISO, time and nits per unit and goes as 1 / N^2: the gain with
        // the setting at 1, then the bound.
        let lens_at_1 = ThinLens { f_number: 1.0, ..c.lens };
        let (bound_word, bound) = match field {
            CameraField::Iso => {
                ("at most", MAX_EXPOSURE_GAIN / exposure_gain(&c.lens, c.shutter_s, 1.0, c.nits_per_unit))
            }
            CameraField::ShutterS => {
                ("at most", MAX_EXPOSURE_GAIN / exposure_gain(&c.lens, 1.0, c.iso, c.nits_per_unit))
            }
            CameraField::NitsPerUnit => {
                ("at most", MAX_EXPOSURE_GAIN / exposure_gain(&c.lens, c.shutter_s, c.iso, 1.0))
            }
            _ => (
                "at least",
                (exposure_gain(&lens_at_1, c.shutter_s, c.iso, c.nits_per_unit) / MAX_EXPOSURE_GAIN).sqrt(),
            ),
        };
        let what = "exposure's gain (scene value to sensor value)";
        return Err(CameraError::Overflow {
            field,
            value,
            what,
            result: gain,
            limit: MAX_EXPOSURE_GAIN,
            bound_word,
            bound,
        });
    }
    let sigma = c.noise_sigma();
    if sigma.is_nan() || sigma > MAX_NOISE_SIGMA {
        let bound = MAX_NOISE_SIGMA / (c.iso / 100.0).sqrt();
        return Err(CameraError::Overflow {
            field: CameraField::Grain,
            value: c.grain,
            what: "grain's spread at sensor value 1",
            result: sigma,
            limit: MAX_NOISE_SIGMA,
            bound_word: "at most",
            bound,
        });
    }
    Ok(())
}
