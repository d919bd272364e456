//! The converted lens file's text.

use super::*;

/// The lens file's text, with comments saying where every number comes from.
#[allow(clippy::too_many_arguments)]
pub(super) fn lens_file_text(
    entry: &LensEntry,
    others: &[LensEntry],
    sensor: &CalibrationSensor,
    selection: &Selection,
    settings: &Settings,
    tables: &Tables,
    distance_m: Option<f64>,
    diagonal_mm: f64,
) -> String {
    let (unit_mm, calibrated_mm, target_mm) =
        (sensor.half_short_side_mm(), sensor.half_diagonal_mm(), diagonal_mm / 2.0);
    let mut source = format!(
        "lensfun {} ({}, calibrated on crop factor {}",
        entry.file_name(),
        if entry.mounts.is_empty() { "no mount given".to_string() } else { entry.mounts.join(" / ") },
        sensor.crop_factor
    );
    for note in &entry.calibration_notes {
        let _ = write!(source, ", {note}");
    }
    source.push_str("); converted by realcam lens import-lensfun");

    // The comment at the top of the file (the writer makes each line a comment).
    let mut t = String::new();
    let _ = writeln!(t, "Converted from the lensfun database by `realcam lens import-lensfun {:?}`.", entry.model);
    let _ =
        writeln!(t, "Entry: {} (maker {}).", entry.at, if entry.maker.is_empty() { "not given" } else { &entry.maker });
    for o in others {
        let crop = o.crop_factor.map_or_else(|| "not given".to_string(), |c| c.to_string());
        let _ = writeln!(
            t,
            "Not used: the same model at {} (crop factor {crop}); the entry with the smallest crop\n\
             factor, the largest calibrated field, is used.",
            o.at
        );
    }
    let _ = writeln!(
        t,
        "Models: lensfun include/lensfun/lensfun.h.in, libs/lensfun/mod-coord.cpp, mod-color.cpp.\n\
         Calibration sensor: crop factor {crop}, aspect ratio {aspect}. r = 1 is {unit_mm:.4} mm for\n\
         distortion and TCA (half the shorter side, hypot(36, 24) / crop / hypot(aspect, 1) / 2) and\n\
         {calibrated_mm:.4} mm for vignetting (half the diagonal, hypot(36, 24) / crop / 2).",
        crop = sensor.crop_factor,
        aspect = sensor.aspect_ratio,
    );
    match selection.distortion {
        Some(d) => {
            let _ = writeln!(
                t,
                "Distortion at {} mm ({}): {}.\n  \
                 distortion_percent = 100 (r_d / (d0 r_u) - 1) at each paraxial ideal height h = d0 r_u\n  \
                 (Kyaw 2013 eq 6.8), d0 the model's slope at the axis.",
                d.focal_mm,
                d.at,
                d.model.describe()
            );
            let d0 = 1.0 + d.model.excess(0.0);
            if (d0 - 1.0).abs() > 5e-8 {
                let _ = writeln!(
                    t,
                    "  lensfun keeps r_u = 1 fixed, not the axis; here d0 = {}: the paraxial focal length\n  \
                     is d0 x {} mm (lensfun's real focal length), and the tables are referred to it, so\n  \
                     distortion is 0 at the centre.",
                    number_text(d0, 6),
                    d.focal_mm
                );
            }
        }
        None => {
            let _ = writeln!(t, "Distortion: none in lensfun for this lens.");
        }
    }
    match selection.tca {
        Some(c) => {
            let _ = writeln!(
                t,
                "TCA at {} mm ({}): {}, r the green radius.\n  \
                 lateral_color_*_percent = 100 (k - 1) (1 + distortion_percent / 100): red/blue over green.",
                c.focal_mm,
                c.at,
                c.model.describe()
            );
        }
        None => {
            let _ = writeln!(t, "TCA (lateral colour): none in lensfun for this lens.");
        }
    }
    match selection.vignetting.first() {
        Some(first) => {
            let used: Vec<String> =
                selection.vignetting.iter().map(|v| format!("f/{} at {} m", v.f_number, v.distance_m)).collect();
            let _ = writeln!(
                t,
                "Vignetting at {} mm ({} on), model pa: relative illumination 1 + k1 r^2 + k2 r^4 + k3 r^6;\n  \
                 per f-number {}: {}.",
                first.focal_mm,
                first.at,
                match distance_m {
                    Some(d) => format!("the calibration focused nearest {d} m (compared in dioptres)"),
                    None => "the calibration focused farthest".to_string(),
                },
                used.join(", ")
            );
        }
        None => {
            let _ = writeln!(t, "Vignetting: none in lensfun for this lens (the camera's cos^4 law applies).");
        }
    }
    if !tables.is_empty() {
        let _ = writeln!(
            t,
            "Tables: {HEIGHT_SAMPLES} heights from 0 to {target_mm:.4} mm (half the diagonal of a {diagonal_mm:.3} mm\n\
             target sensor), plus r = 1 and the edge of the calibrated field where they fall inside."
        );
    }
    if !tables.is_empty() && target_mm > calibrated_mm * (1.0 + 1e-9) {
        let _ = writeln!(
            t,
            "EXTRAPOLATED: lensfun's calibration covers heights up to {calibrated_mm:.2} mm (crop factor {});\n\
             the values beyond are its fitted polynomials extrapolated, not measured.",
            sensor.crop_factor
        );
    }
    if tables.clamped {
        let _ = writeln!(
            t,
            "The vignetting polynomial leaves (0, 2] inside the tables: those values are clamped to\n\
             [{MIN_RELATIVE_ILLUMINATION}, 2]."
        );
    }

    let s = settings;
    let mut w = LensFileWriter::new(&t);
    w.string("name", &entry.model, None)
        .string("source", &source, None)
        .number("focal_length_mm", selection.focal_length_mm, 4, None)
        .number("f_number_min", s.f_number_min.value, 3, Some(s.f_number_min.note))
        .number("f_number_max", s.f_number_max.value, 3, Some(s.f_number_max.note))
        .number("focus_min_m", s.focus_min_m.value, 4, Some(s.focus_min_m.note))
        .integer("aperture.blades", i64::from(s.blades.value), Some(s.blades.note));
    if !tables.is_empty() {
        w.tables(&tables.lens_tables(), None);
    }
    w.finish()
}
