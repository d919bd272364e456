//! The camera of a shot: each frame's [`Camera`], its settings taken, per setting, from the
//! first of (issue 31):
//! 1. a flag (the request's settings the user gave),
//! 2. the shot's keyframes ([`CameraKeys`]: a camera file, a USD camera),
//! 3. the frame's own input header (OpenEXR's standard `focus`, `aperture`, `expTime`,
//!    `isoSpeed`, and the focal length for the ideal lens),
//! 4. the lens file's or realcam's default.
//!
//! Each camera carries where each of its settings came from (`--explain`, the output header),
//! and an input header that disagrees with a flag or a key is warned about, once per setting.

use super::keys::{self, CameraKeys, ANIMATED};
use super::{Camera, CameraError, CameraField, CameraRequest};
use crate::io::lens_file::LensFile;
use crate::model::aperture::ApertureMask;
use crate::optics::Num;
use std::sync::Mutex;

/// Where a setting of a frame's camera came from.
#[derive(Clone, Debug, PartialEq)]
pub enum SettingSource {
    /// The command line (or the Python package's keyword).
    Flag,
    /// The shot's keyframes.
    Keys,
    /// The frame's input header: the attribute's name.
    Input(String),
    /// The lens file's or realcam's default.
    Default,
}

impl SettingSource {
    /// In words, for `--explain` and the output header's `realcam/source/<setting>`.
    pub fn describe(&self, field: CameraField, keys_origin: &str) -> String {
        match self {
            SettingSource::Flag => format!("flag {}", flag_of(field)),
            SettingSource::Keys => keys_origin.to_string(),
            SettingSource::Input(attribute) => format!("the input's {attribute} attribute"),
            SettingSource::Default => match field {
                CameraField::FocalLengthMm => "the lens file's".into(),
                CameraField::FNumber => "default: the lens's widest, f/2.8 at most".into(),
                _ => "default".into(),
            },
        }
    }
}

/// The flag that sets `field`.
fn flag_of(field: CameraField) -> &'static str {
    match field {
        CameraField::FocalLengthMm => "--focal-length",
        CameraField::FNumber => "--fstop",
        CameraField::FocusDistanceM => "--focus",
        CameraField::ShutterS => "--shutter",
        CameraField::ShutterAngleDeg => "--shutter-angle",
        CameraField::Iso => "--iso",
        CameraField::NitsPerUnit => "--nits-per-unit",
        CameraField::Blades => "--blades",
        CameraField::BladeRotationDeg => "--blade-rotation",
        CameraField::BladeCurvature => "--blade-curvature",
        CameraField::SphericalAberration => "--spherical-aberration",
        CameraField::CatsEye => "--cats-eye",
        CameraField::Grain => "--grain",
        _ => field.name(),
    }
}

/// The camera settings a frame's input header carries (OpenEXR's standard attributes; a
/// value that is not finite and positive is left out: renderers write 0 for "unknown").
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InputCamera {
    /// (setting, value in the setting's unit, the attribute's name).
    pub values: Vec<(CameraField, f64, String)>,
}

impl InputCamera {
    /// The settings of the attributes `focus` (m), `aperture` (f-number), `expTime` (s),
    /// `isoSpeed` of `attributes` (name, value as f64 when a number), and the focal length (mm)
    /// a renderer wrote, with its attribute's name.
    pub fn from_attributes<'a>(
        attributes: impl IntoIterator<Item = (&'a str, Option<f64>)>,
        focal_length_mm: Option<(f64, String)>,
    ) -> InputCamera {
        let mut values = Vec::new();
        for (name, value) in attributes {
            let field = match name {
                "focus" => CameraField::FocusDistanceM,
                "aperture" => CameraField::FNumber,
                "expTime" => CameraField::ShutterS,
                "isoSpeed" => CameraField::Iso,
                _ => continue,
            };
            if let Some(v) = value.filter(|v| v.is_finite() && *v > 0.0) {
                values.push((field, v, name.to_string()));
            }
        }
        if let Some((mm, name)) = focal_length_mm.filter(|(mm, _)| mm.is_finite() && *mm > 0.0) {
            values.push((CameraField::FocalLengthMm, mm, name));
        }
        InputCamera { values }
    }

    fn get(&self, field: CameraField) -> Option<(f64, &str)> {
        self.values.iter().find(|(f, _, _)| *f == field).map(|(_, v, name)| (*v, name.as_str()))
    }
}

/// A frame's camera refused, with where the refused setting came from when that was not a flag.
#[derive(Debug, thiserror::Error)]
#[error("{}{error}", .from.as_ref().map(|f| format!("{f}: ")).unwrap_or_default())]
pub struct ShotError {
    pub error: CameraError,
    /// `frame 12, the camera file "rack.toml"`; None when the flags alone made the camera.
    pub from: Option<String>,
}

/// A frame's camera and the warnings it brought (each said once per run).
pub struct FrameCamera {
    pub camera: Camera,
    pub warnings: Vec<String>,
}

/// The settings of a shot, from which each frame's camera is made.
pub struct ShotCamera {
    lens_file: LensFile,
    /// The flags' settings (realcam's defaults where none was given).
    request: CameraRequest,
    /// The settings the user gave as flags.
    flags: Vec<CameraField>,
    keys: Option<CameraKeys>,
    aperture_mask: Option<ApertureMask>,
    /// The camera of the flags and the keys' first frame, without any input: the one a run
    /// prepares its pipelines for.
    base: Camera,
    /// The settings a disagreement was warned about already.
    warned: Mutex<Vec<CameraField>>,
}

/// Whether two values of a setting differ by more than rounding (the header stores float32).
fn differ(a: f64, b: f64) -> bool {
    (a - b).abs() > 1e-4 * a.abs().max(b.abs())
}

/// The value of a setting an input header can carry, as `camera` has it.
fn camera_value(camera: &Camera, field: CameraField) -> Option<f64> {
    match field {
        CameraField::FocalLengthMm => Some(camera.lens.focal_length_mm),
        CameraField::FNumber => Some(camera.lens.f_number),
        CameraField::FocusDistanceM => Some(camera.lens.focus_distance_mm / 1000.0),
        CameraField::ShutterS => Some(camera.shutter_s),
        CameraField::Iso => Some(camera.iso),
        _ => None,
    }
}

impl ShotCamera {
    /// The shot of `request` (the settings in `flags` given by the user, the rest defaults)
    /// through `lens_file`, with `keys` over the frames. Every key's frame is checked now, so a
    /// setting the lens refuses stops the run before any work.
    pub fn new(
        lens_file: LensFile,
        request: CameraRequest,
        flags: Vec<CameraField>,
        keys: Option<CameraKeys>,
        aperture_mask: Option<ApertureMask>,
    ) -> Result<ShotCamera, ShotError> {
        let mut shot = ShotCamera {
            base: Camera::new(&lens_file, &request).map_err(|error| ShotError { error, from: None })?,
            lens_file,
            request,
            flags,
            keys,
            aperture_mask,
            warned: Mutex::new(Vec::new()),
        };
        let mut key_frames: Vec<f64> =
            shot.keys.iter().flat_map(|k| k.tracks.iter().flat_map(|(_, t)| t.keys().iter().map(|k| k.0))).collect();
        key_frames.sort_by(f64::total_cmp);
        key_frames.dedup();
        // The base is the camera of the first key's frame (of frame 0 without keys).
        let mut base = None;
        for &frame in key_frames.iter().chain(key_frames.is_empty().then_some(&0.0)) {
            let (camera, _) = shot.make(frame, &InputCamera::default())?;
            base.get_or_insert(camera);
        }
        shot.base = base.unwrap_or_else(|| shot.base.clone());
        Ok(shot)
    }

    /// The camera without any input's settings, at the keys' first frame.
    pub fn base(&self) -> &Camera {
        &self.base
    }

    pub fn keys(&self) -> Option<&CameraKeys> {
        self.keys.as_ref()
    }

    /// The camera of frame `frame` (None: a single frame without a frame number, taken at the
    /// keys' first frame) whose input header says `input`, its grain seeded by the frame
    /// ([`Camera::at_frame`]).
    pub fn camera(&self, frame: Option<i64>, input: &InputCamera) -> Result<FrameCamera, ShotError> {
        let at = match frame {
            Some(f) => f as f64,
            None => self.keys.as_ref().and_then(|k| k.tracks.first()).map_or(0.0, |(_, t)| t.keys()[0].0),
        };
        let (camera, disagreements) = self.make(at, input).map_err(|ShotError { error, from }| ShotError {
            error,
            from: match (frame, from) {
                (Some(n), Some(f)) => Some(format!("frame {n}, {f}")),
                (Some(n), None) => Some(format!("frame {n}")),
                (None, from) => from,
            },
        })?;
        let mut warned = self.warned.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let mut warnings = Vec::new();
        for (field, text) in disagreements {
            if !warned.contains(&field) {
                warned.push(field);
                warnings.push(match frame {
                    Some(n) => format!("frame {n}: {text} (said once)"),
                    None => text,
                });
            }
        }
        let camera = match frame {
            Some(f) => camera.at_frame(f),
            None => camera,
        };
        Ok(FrameCamera { camera, warnings })
    }

    /// The camera at frame `at` with `input`'s settings where neither a flag nor a key gives
    /// one, and the settings where the input disagrees with what was used (setting, text).
    fn make(&self, at: f64, input: &InputCamera) -> Result<(Camera, Vec<(CameraField, String)>), ShotError> {
        let mut request = self.request.clone();
        let mut sources = Vec::new();
        let keys_origin = self.keys.as_ref().map_or("", |k| k.origin.as_str());
        let key_of = |field| self.keys.as_ref().and_then(|k| k.track(field));
        // A shutter angle among the flags or the keys decides the shutter time.
        let angle_source = if self.flags.contains(&CameraField::ShutterAngleDeg) {
            Some(SettingSource::Flag)
        } else {
            key_of(CameraField::ShutterAngleDeg).map(|_| SettingSource::Keys)
        };
        for field in ANIMATED {
            let source = if self.flags.contains(&field) {
                SettingSource::Flag
            } else if let Some(track) = key_of(field) {
                keys::set(&mut request, field, track.at(at));
                SettingSource::Keys
            } else if let (CameraField::ShutterS, Some(source)) = (field, &angle_source) {
                source.clone()
            } else if let Some((value, attribute)) = input.get(field) {
                // A lens file is a prime of its own focal length: the input's is only compared
                // with it (Camera::focal_length_warning); the ideal lens takes any.
                if field == CameraField::FocalLengthMm && !self.lens_file.ideal {
                    SettingSource::Default
                } else {
                    keys::set(&mut request, field, value);
                    SettingSource::Input(attribute.to_string())
                }
            } else {
                SettingSource::Default
            };
            if camera_value(&self.base, field).is_some() || source != SettingSource::Default {
                sources.push((field, source));
            }
        }
        let mut camera = Camera::new(&self.lens_file, &request).map_err(|error| {
            // The refused setting's source, unless a flag or a default (the flag names itself).
            let source = error.field().and_then(|f| sources.iter().find(|s| s.0 == f));
            let from = match source {
                Some((_, SettingSource::Keys)) => Some(keys_origin.to_string()),
                Some((_, SettingSource::Input(attribute))) => Some(format!("the input's {attribute} attribute")),
                _ => None,
            };
            ShotError { error, from }
        })?;
        camera.aperture_mask = self.aperture_mask.clone();
        // Where the camera's value came from elsewhere, a different one in the input is said.
        let mut disagreements = Vec::new();
        for (field, source) in &sources {
            let Some((value, attribute)) = input.get(*field) else { continue };
            let Some(used) = camera_value(&camera, *field) else { continue };
            if matches!(source, SettingSource::Input(_)) || !differ(value, used) {
                continue;
            }
            if *field == CameraField::FocalLengthMm && !self.lens_file.ideal {
                continue; // said by the lens file's own focal-length warning
            }
            let by = source.describe(*field, keys_origin);
            disagreements.push((
                *field,
                format!(
                    "the input's {attribute} attribute says {}, {by} says {}; {by} is used",
                    field.quantity(value),
                    Num(used)
                ),
            ));
        }
        camera.setting_sources =
            sources.into_iter().map(|(field, source)| (field, source.describe(field, keys_origin))).collect();
        Ok((camera, disagreements))
    }
}

#[cfg(test)]
mod tests {
    use super::super::keys::{Interpolation, Track};
    use super::*;

    fn ideal() -> LensFile {
        LensFile::built_in("ideal").unwrap()
    }

    fn input(values: &[(&str, f64)]) -> InputCamera {
        InputCamera::from_attributes(values.iter().map(|(n, v)| (*n, Some(*v))), None)
    }

    #[test]
    fn each_setting_from_the_first_source_that_has_it() {
        let keys = CameraKeys {
            tracks: vec![(
                CameraField::FocusDistanceM,
                Track::new(vec![(1.0, 1.0), (11.0, 3.0)], Interpolation::Linear).unwrap(),
            )],
            origin: "the camera file \"rack.toml\"".into(),
        };
        let request = CameraRequest { f_number: Some(4.0), ..CameraRequest::default() };
        let shot = ShotCamera::new(ideal(), request, vec![CameraField::FNumber], Some(keys), None).unwrap();
        let header = input(&[("focus", 7.0), ("aperture", 8.0), ("isoSpeed", 400.0), ("expTime", 0.0)]);
        let FrameCamera { camera, warnings } = shot.camera(Some(6), &header).unwrap();
        // The flag's f/4 over the input's f/8; the keys' 2 m at frame 6 over the input's 7 m;
        // the input's ISO 400 over the default; expTime 0 is no exposure time: the default.
        assert_eq!(camera.lens.f_number, 4.0);
        assert!((camera.lens.focus_distance_mm - 2000.0).abs() < 1e-9);
        assert_eq!(camera.iso, 400.0);
        assert_eq!(camera.shutter_s, 1.0 / 50.0);
        let source = |f: CameraField| camera.setting_sources.iter().find(|s| s.0 == f).map(|s| s.1.clone());
        assert_eq!(source(CameraField::FNumber).unwrap(), "flag --fstop");
        assert_eq!(source(CameraField::FocusDistanceM).unwrap(), "the camera file \"rack.toml\"");
        assert_eq!(source(CameraField::Iso).unwrap(), "the input's isoSpeed attribute");
        assert_eq!(source(CameraField::ShutterS).unwrap(), "default");
        assert_eq!(
            warnings,
            [
                "frame 6: the input's aperture attribute says f/8, flag --fstop says 4; flag --fstop is used (said once)",
                "frame 6: the input's focus attribute says focus distance 7 m, the camera file \"rack.toml\" says 2; \
                 the camera file \"rack.toml\" is used (said once)",
            ]
        );
        // Said once per run.
        assert!(shot.camera(Some(7), &header).unwrap().warnings.is_empty());
    }

    #[test]
    fn a_setting_the_lens_refuses_names_where_it_came_from() {
        let lens = LensFile::default_lens();
        let shot = ShotCamera::new(lens, CameraRequest::default(), vec![], None, None).unwrap();
        let err = shot.camera(Some(3), &input(&[("aperture", 1.0)])).map(|_| ()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "frame 3, the input's aperture attribute: f/1 is outside what the lens \
             \"realcam standard 50 mm f/1.4\" allows (f/1.4 to f/16)"
        );
        // A key the lens refuses stops the run when the shot is made.
        let keys = CameraKeys {
            tracks: vec![(
                CameraField::FNumber,
                Track::new(vec![(1.0, 2.0), (9.0, 32.0)], Interpolation::Linear).unwrap(),
            )],
            origin: "the camera file \"iris.toml\"".into(),
        };
        let err = ShotCamera::new(LensFile::default_lens(), CameraRequest::default(), vec![], Some(keys), None)
            .map(|_| ())
            .unwrap_err();
        assert!(err.to_string().starts_with("the camera file \"iris.toml\": f/32 is outside"), "{err}");
    }

    #[test]
    fn the_input_focal_length_drives_only_the_ideal_lens() {
        let header = InputCamera::from_attributes([], Some((35.0, "Lens".to_string())));
        let ideal_shot = ShotCamera::new(ideal(), CameraRequest::default(), vec![], None, None).unwrap();
        assert_eq!(ideal_shot.camera(None, &header).unwrap().camera.lens.focal_length_mm, 35.0);
        let prime = ShotCamera::new(LensFile::default_lens(), CameraRequest::default(), vec![], None, None).unwrap();
        let camera = prime.camera(None, &header).unwrap().camera;
        assert_eq!(camera.lens.focal_length_mm, 50.0);
    }
}
