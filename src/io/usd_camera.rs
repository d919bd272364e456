//! A USD camera (`UsdGeomCamera` in a `.usda`, `.usdc` or `.usdz`) as a shot's keys: its
//! `focalLength`, `fStop`, `focusDistance` and `shutter:open`/`shutter:close`, each with its
//! time samples (time codes are the sequence's frame numbers, USD interpolates linearly between
//! samples) or its default value. Read through the `openusd` crate (pure Rust; see the README's
//! dependencies).
//!
//! Units, as USD's schema and the exporters write them: `focalLength` in mm (the schema says
//! "tenths of a scene unit", which is mm at USD's default centimetre; Blender, Houdini and
//! Omniverse write mm whatever the unit); `focusDistance` in scene units, times the stage's
//! `metersPerUnit` (0.01 when unauthored); `fStop` an f-number, 0 meaning "no depth of field"
//! (left out); the shutter in time codes around the frame, so (close - open) x 360 is the shutter
//! angle in degrees.

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
    if let Some(keys) = samples("focalLength")? {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera as Blender's USD exporter writes an animation (a sample per frame, metres).
    const BLENDER_LIKE: &str = r#"#usda 1.0
(
    defaultPrim = "Camera"
    doc = "Blender v3.4.1"
    endTimeCode = 5
    metersPerUnit = 1
    startTimeCode = 1
    upAxis = "Z"
)

def Xform "Camera"
{
    uniform token[] xformOpOrder = ["xformOp:transform"]

    def Camera "Lens"
    {
        float focalLength = 50
        float focusDistance.timeSamples = {
            1: 1,
            2: 1.5,
            3: 2,
            4: 2.5,
            5: 3,
        }
        float fStop = 0
        float horizontalAperture = 36
        double shutter:close = 0.25
        double shutter:open = -0.25
        token projection = "perspective"
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
    fn a_blender_like_camera_gives_its_samples_in_metres_and_its_shutter_as_an_angle() {
        let path = write("blender", BLENDER_LIKE);
        let keys = load_usd_camera(&path, None).unwrap();
        let focus = keys.track(CameraField::FocusDistanceM).unwrap();
        assert_eq!(focus.keys(), &[(1.0, 1.0), (2.0, 1.5), (3.0, 2.0), (4.0, 2.5), (5.0, 3.0)]);
        assert!((focus.at(3.5) - 2.25).abs() < 1e-9, "linear between samples");
        assert_eq!(keys.track(CameraField::FocalLengthMm).unwrap().at(4.0), 50.0);
        // fStop 0 is USD's "no depth of field": no f-number from the file.
        assert!(keys.track(CameraField::FNumber).is_none());
        assert_eq!(keys.track(CameraField::ShutterAngleDeg).unwrap().at(2.0), 180.0);
        assert_eq!(keys.origin, format!("the USD camera /Camera/Lens of \"{}\"", path.display()));
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
