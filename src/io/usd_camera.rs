//! A USD camera (`UsdGeomCamera` in a `.usda`, `.usdc` or `.usdz`) as a shot's keys: its
//! `focalLength`, `fStop`, `focusDistance` and `shutter:open`/`shutter:close`, each with its
//! time samples (time codes are the sequence's frame numbers, USD interpolates linearly between
//! samples) or its default value. Read through the `openusd` crate (pure Rust; see the README's
//! dependencies).
//!
//! Units, as USD's schema and the exporters write them: `focalLength` and `horizontalAperture`
//! in tenths of a scene unit, so in mm the value times 100 x the stage's `metersPerUnit` (0.01,
//! USD's centimetre, when unauthored: then mm as written). Blender's exporter follows the
//! schema (a 50 mm lens on a metre stage is `focalLength = 0.5`, aperture 0.36 for 36 mm); some
//! tools write mm whatever the unit. Which one a file uses is read from its aperture (its focal
//! length when it has none): the schema's conversion where that gives a sensor of 1-100 mm (a
//! lens of 1-2000 mm), mm as written where only that does. `focusDistance` in scene units,
//! times `metersPerUnit`; `fStop` an f-number, 0 meaning "no depth of field" (left out); the
//! shutter in time codes around the frame, so (close - open) x 360 is the shutter angle in
//! degrees.

use crate::model::camera::keys::{CameraKeys, Interpolation, Track};
use crate::model::camera::CameraField;
use openusd::usd;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum UsdCameraError {
    #[error("USD camera file \"{}\": {message}", .path.display())]
    Read { path: PathBuf, message: String },
    #[error("USD camera file \"{}\": no camera (UsdGeomCamera prim) in the stage", .path.display())]
    NoCamera { path: PathBuf },
    #[error("USD camera file \"{}\": {count} cameras ({list}); name one as FILE:PRIM_PATH", .path.display())]
    SeveralCameras { path: PathBuf, count: usize, list: String },
    #[error("USD camera file \"{}\": {prim} is not a camera", .path.display())]
    NotACamera { path: PathBuf, prim: String },
    #[error("USD camera file \"{}\", {attribute}: {message}", .path.display())]
    Attribute { path: PathBuf, attribute: String, message: String },
}

/// Whether `path` names a USD file by its extension.
pub fn is_usd(path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    matches!(ext.as_deref(), Some("usd" | "usda" | "usdc" | "usdz"))
}

/// The keys of the camera at `prim` (None: the stage's only camera) in the USD file at `path`.
pub fn load_usd_camera(path: &Path, prim: Option<&str>) -> Result<CameraKeys, UsdCameraError> {
    let read = |e: anyhow::Error| UsdCameraError::Read { path: path.to_path_buf(), message: format!("{e:#}") };
    if !path.is_file() {
        return Err(UsdCameraError::Read { path: path.to_path_buf(), message: "no such file".into() });
    }
    let stage = usd::Stage::open(&path.to_string_lossy()).map_err(read)?;
    let is_camera = |p: &str| -> Result<bool, UsdCameraError> {
        Ok(stage.prim(p).type_name().map_err(read)?.is_some_and(|t| t.as_str() == "Camera"))
    };
    let camera = match prim {
        Some(p) => {
            if !is_camera(p)? {
                return Err(UsdCameraError::NotACamera { path: path.to_path_buf(), prim: p.to_string() });
            }
            p.to_string()
        }
        None => {
            let mut prims = Vec::new();
            stage.traverse(usd::PrimPredicate::DEFAULT, |p| prims.push(p.to_string())).map_err(read)?;
            let mut cameras = Vec::new();
            for p in prims {
                if is_camera(&p)? {
                    cameras.push(p);
                }
            }
            match cameras.len() {
                0 => return Err(UsdCameraError::NoCamera { path: path.to_path_buf() }),
                1 => cameras.remove(0),
                count => {
                    let list = cameras.join(", ");
                    return Err(UsdCameraError::SeveralCameras { path: path.to_path_buf(), count, list });
                }
            }
        }
    };
    let meters_per_unit = stage
        .stage_metadata("metersPerUnit")
        .map_err(read)?
        .and_then(|v| v.cast::<f64>().ok())
        .filter(|m| m.is_finite() && *m > 0.0)
        .unwrap_or(0.01);
    // An attribute's samples (time code, value), or its default at every frame; None unauthored.
    let samples = |name: &str| -> Result<Option<Vec<(f64, f64)>>, UsdCameraError> {
        let attribute = stage.attribute(format!("{camera}.{name}").as_str());
        let bad = |message: String| UsdCameraError::Attribute {
            path: path.to_path_buf(),
            attribute: format!("{camera}.{name}"),
            message,
        };
        // A float as the decimal it was written as (2.8, not 2.799999952), as Blender shows it.
        let number = |v: openusd::sdf::Value| match v {
            openusd::sdf::Value::Float(f) => Ok(f.to_string().parse::<f64>().unwrap_or(f64::from(f))),
            v => v.cast::<f64>().map_err(|e| bad(e.to_string())),
        };
        if let Some(samples) = attribute.time_samples().map_err(read)?.filter(|s| !s.is_empty()) {
            return samples.into_iter().map(|(t, v)| Ok((t, number(v)?))).collect::<Result<Vec<_>, _>>().map(Some);
        }
        match attribute.get::<openusd::sdf::Value>().map_err(read)? {
            Some(v) => Ok(Some(vec![(0.0, number(v)?)])),
            None => Ok(None),
        }
    };
    let origin = format!("the USD camera {camera} of \"{}\"", path.display());
    let track = |field: CameraField, keys: Vec<(f64, f64)>| {
        let interpolation = Interpolation::Linear; // USD's default between time samples
        Track::new(keys, interpolation).map(|t| (field, t)).map_err(|e| UsdCameraError::Attribute {
            path: path.to_path_buf(),
            attribute: format!("{camera}.{}", field.name()),
            message: e.to_string(),
        })
    };
    let mut tracks = Vec::new();
    let focal = samples("focalLength")?;
    let mm_per_lens_unit = lens_unit_mm(meters_per_unit, samples("horizontalAperture")?.as_deref(), focal.as_deref());
    if let Some(keys) = focal {
        let keys = keys.into_iter().map(|(t, f)| (t, f * mm_per_lens_unit)).collect();
        tracks.push(track(CameraField::FocalLengthMm, keys)?);
    }
    if let Some(keys) = samples("focusDistance")? {
        let keys = keys.into_iter().map(|(t, d)| (t, d * meters_per_unit)).collect();
        tracks.push(track(CameraField::FocusDistanceM, keys)?);
    }
    // fStop 0: no depth of field in USD; the flag or the default decides then.
    if let Some(keys) = samples("fStop")?.filter(|k| k.iter().all(|(_, n)| *n > 0.0)) {
        tracks.push(track(CameraField::FNumber, keys)?);
    }
    if let (Some(open), Some(close)) = (samples("shutter:open")?, samples("shutter:close")?) {
        // The angle at each time either attribute has a sample (the other held or interpolated).
        let (open, close) =
            (track(CameraField::ShutterAngleDeg, open)?.1, track(CameraField::ShutterAngleDeg, close)?.1);
        let mut times: Vec<f64> = open.keys().iter().chain(close.keys()).map(|k| k.0).collect();
        times.sort_by(f64::total_cmp);
        times.dedup();
        let angles = times.into_iter().map(|t| (t, (close.at(t) - open.at(t)) * 360.0)).collect();
        tracks.push(track(CameraField::ShutterAngleDeg, angles)?);
    }
    Ok(CameraKeys { tracks, origin })
}

/// The mm per unit of the file's `focalLength` and `horizontalAperture`: the schema's tenth of
/// a scene unit (100 x `meters_per_unit` mm) where the file's aperture (else its focal length)
/// is a plausible camera's in those units, else mm as written where it is in mm, else the
/// schema's.
fn lens_unit_mm(meters_per_unit: f64, aperture: Option<&[(f64, f64)]>, focal: Option<&[(f64, f64)]>) -> f64 {
    let schema = 100.0 * meters_per_unit;
    let (samples, plausible): (&[(f64, f64)], std::ops::RangeInclusive<f64>) = match (aperture, focal) {
        (Some(a), _) => (a, 1.0..=100.0),
        (None, Some(f)) => (f, 1.0..=2000.0),
        (None, None) => return schema,
    };
    let fits = |unit: f64| samples.iter().all(|(_, v)| plausible.contains(&(v * unit)));
    if !fits(schema) && fits(1.0) {
        1.0
    } else {
        schema
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera as Blender 4.2 LTS's USD exporter wrote a keyed rack focus and iris pull (a
    /// sample per frame; lens and apertures in tenths of a metre; abridged).
    const BLENDER: &str = r#"#usda 1.0
(
    defaultPrim = "root"
    doc = "Blender v4.2.23 LTS"
    endTimeCode = 3
    metersPerUnit = 1
    startTimeCode = 1
    timeCodesPerSecond = 24
    upAxis = "Z"
)

def Xform "root"
{
    def Xform "Camera"
    {
        def Camera "Camera"
        {
            float focalLength.timeSamples = {
                1: 0.5,
                2: 0.5,
                3: 0.5,
            }
            float focusDistance.timeSamples = {
                1: 1,
                2: 2,
                3: 3,
            }
            float fStop.timeSamples = {
                1: 2,
                2: 5,
                3: 8,
            }
            float horizontalAperture.timeSamples = {
                1: 0.36,
                2: 0.36,
                3: 0.36,
            }
            token projection = "perspective"
        }
    }
}
"#;

    /// A camera written in mm on a metre stage, with a shutter of half a frame.
    const IN_MM: &str = r#"#usda 1.0
(
    metersPerUnit = 1
)

def Xform "Camera"
{
    def Camera "Lens"
    {
        float focalLength = 50
        float focusDistance.timeSamples = {
            1: 1,
            5: 3,
        }
        float fStop = 0
        float horizontalAperture = 36
        double shutter:close = 0.25
        double shutter:open = -0.25
    }
}
"#;

    fn write(name: &str, text: &str) -> PathBuf {
        let dir = crate::io::test_dir(&format!("usd-{name}"));
        let path = dir.join("shot.usda");
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn a_blender_camera_gives_its_lens_in_mm_and_its_focus_in_metres() {
        let path = write("blender", BLENDER);
        let keys = load_usd_camera(&path, None).unwrap();
        let focus = keys.track(CameraField::FocusDistanceM).unwrap();
        assert_eq!(focus.keys(), &[(1.0, 1.0), (2.0, 2.0), (3.0, 3.0)]);
        assert!((focus.at(2.5) - 2.5).abs() < 1e-9, "linear between samples");
        // 0.5 tenths of a metre.
        assert!((keys.track(CameraField::FocalLengthMm).unwrap().at(2.0) - 50.0).abs() < 1e-9);
        assert_eq!(keys.track(CameraField::FNumber).unwrap().keys(), &[(1.0, 2.0), (2.0, 5.0), (3.0, 8.0)]);
        assert!(keys.track(CameraField::ShutterAngleDeg).is_none());
        assert_eq!(keys.origin, format!("the USD camera /root/Camera/Camera of \"{}\"", path.display()));
    }

    #[test]
    fn a_camera_in_mm_on_a_metre_stage_keeps_its_mm_and_its_shutter_is_an_angle() {
        let path = write("mm", IN_MM);
        let keys = load_usd_camera(&path, None).unwrap();
        // 36 tenths of a metre would be a 3.6 m sensor: the file is in mm.
        assert_eq!(keys.track(CameraField::FocalLengthMm).unwrap().at(4.0), 50.0);
        assert!((keys.track(CameraField::FocusDistanceM).unwrap().at(3.0) - 2.0).abs() < 1e-9);
        // fStop 0 is USD's "no depth of field": no f-number from the file.
        assert!(keys.track(CameraField::FNumber).is_none());
        assert_eq!(keys.track(CameraField::ShutterAngleDeg).unwrap().at(2.0), 180.0);
    }

    #[test]
    fn the_lens_unit_is_the_schemas_where_it_gives_a_camera_else_mm() {
        let one = |v: f64| vec![(0.0, v)];
        // The schema's tenth of a unit: mm on USD's centimetre, 100 mm on a metre.
        assert_eq!(lens_unit_mm(0.01, Some(&one(36.0)), Some(&one(50.0))), 1.0);
        assert_eq!(lens_unit_mm(1.0, Some(&one(0.36)), Some(&one(0.5))), 100.0);
        // mm on a metre stage, told by the aperture, else by the focal length.
        assert_eq!(lens_unit_mm(1.0, Some(&one(36.0)), Some(&one(0.5))), 1.0);
        assert_eq!(lens_unit_mm(1.0, None, Some(&one(50.0))), 1.0);
        assert_eq!(lens_unit_mm(1.0, None, Some(&one(0.35))), 100.0);
        // Neither plausible, or nothing to tell by: the schema's.
        assert_eq!(lens_unit_mm(1.0, Some(&one(1e6)), None), 100.0);
        assert_eq!(lens_unit_mm(0.01, None, None), 1.0);
    }

    #[test]
    fn the_stage_unit_scales_the_focus_distance_and_several_cameras_must_be_named() {
        // No metersPerUnit: USD's centimetre.
        let text = "#usda 1.0\n\ndef Camera \"A\"\n{\n    float focusDistance = 150\n    float fStop = 2.8\n}\n\n\
                    def Camera \"B\"\n{\n    float fStop.timeSamples = { 10: 2, 20: 8 }\n}\n";
        let path = write("units", text);
        let err = load_usd_camera(&path, None).unwrap_err().to_string();
        assert_eq!(
            err,
            format!("USD camera file \"{}\": 2 cameras (/A, /B); name one as FILE:PRIM_PATH", path.display())
        );
        let a = load_usd_camera(&path, Some("/A")).unwrap();
        assert!((a.track(CameraField::FocusDistanceM).unwrap().at(0.0) - 1.5).abs() < 1e-9);
        assert_eq!(a.track(CameraField::FNumber).unwrap().at(7.0), 2.8);
        let b = load_usd_camera(&path, Some("/B")).unwrap();
        assert_eq!(b.track(CameraField::FNumber).unwrap().at(15.0), 5.0);
        assert!(load_usd_camera(&path, Some("/C")).unwrap_err().to_string().ends_with("/C is not a camera"));
    }
}
