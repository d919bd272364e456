//! A camera in words and as EXR attributes.

use super::*;

impl Camera {
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
        let mut attributes: Vec<(String, ExrAttribute)> =
            attributes.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
        // Where each setting of a shot's camera came from (issue 31): `realcam/source/f_number`.
        for (field, source) in &self.setting_sources {
            attributes.push((format!("realcam/source/{}", field.name()), text(source)));
        }
        attributes
    }

    /// The settings of a shot's camera and where each came from, one per line (`--explain`).
    pub fn explain_sources(&self) -> Option<String> {
        if self.setting_sources.is_empty() {
            return None;
        }
        let value = |field: CameraField| match field {
            CameraField::FocalLengthMm => field.quantity(self.lens.focal_length_mm),
            CameraField::FNumber => field.quantity(self.lens.f_number),
            CameraField::FocusDistanceM => field.quantity(self.lens.focus_distance_mm / 1000.0),
            CameraField::ShutterS => field.quantity(self.shutter_s),
            CameraField::ShutterAngleDeg => field.quantity(self.shutter_s * self.motion.fps * 360.0),
            CameraField::Iso => field.quantity(self.iso),
            CameraField::NitsPerUnit => field.quantity(self.nits_per_unit),
            CameraField::Blades => field.quantity(self.aperture.blades.into()),
            CameraField::BladeRotationDeg => field.quantity(self.aperture.rotation_deg),
            CameraField::BladeCurvature => field.quantity(self.aperture.curvature),
            CameraField::SphericalAberration => field.quantity(self.aperture.spherical_aberration),
            CameraField::CatsEye => field.quantity(self.aperture.cats_eye),
            CameraField::Grain => field.quantity(self.grain),
            _ => field.label().to_string(),
        };
        let lines: Vec<String> =
            self.setting_sources.iter().map(|(field, source)| format!("    {}: {source}", value(*field))).collect();
        Some(format!("  settings from:\n{}", lines.join("\n")))
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
