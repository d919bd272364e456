//! A database entry converted into a lens file: the calibrations chosen, sampled against
//! image height, and the settings lensfun does not give.

use super::*;

/// The focal length among `items` nearest `focal_mm`.
fn nearest_focal<T>(items: &[T], focal: impl Fn(&T) -> f64, focal_mm: f64) -> Option<f64> {
    items.iter().map(&focal).min_by(|a, b| (a - focal_mm).abs().total_cmp(&(b - focal_mm).abs()))
}

/// The heights of the tables: `HEIGHT_SAMPLES` from 0 to `max_mm`, plus the `special` heights
/// inside (0, max_mm) (grid points within a quarter step of one are dropped).
fn sample_heights(max_mm: f64, special: &[f64]) -> Vec<f64> {
    let step = max_mm / (HEIGHT_SAMPLES - 1) as f64;
    let special: Vec<f64> = special.iter().copied().filter(|&s| s > 0.25 * step && s < max_mm - 0.25 * step).collect();
    let mut h: Vec<f64> = (0..HEIGHT_SAMPLES)
        .map(|i| if i == HEIGHT_SAMPLES - 1 { max_mm } else { i as f64 * step })
        .filter(|g| *g == 0.0 || *g == max_mm || special.iter().all(|s| (s - g).abs() >= 0.25 * step))
        .collect();
    h.extend(special);
    h.sort_by(f64::total_cmp);
    h.dedup();
    h
}

pub(super) fn positive(name: &'static str, value: Option<f64>) -> Result<Option<f64>, LensfunError> {
    match value {
        Some(v) if !(v.is_finite() && v > 0.0) => Err(LensfunError::BadOption { name, value: v }),
        _ => Ok(value),
    }
}

/// The calibrations an import uses.
pub(super) struct Selection<'a> {
    /// The lens file's focal length: the calibrated one nearest the request.
    pub(super) focal_length_mm: f64,
    pub(super) distortion: Option<&'a Distortion>,
    pub(super) tca: Option<&'a Tca>,
    /// Increasing f-number, one per f-number.
    pub(super) vignetting: Vec<&'a Vignetting>,
}

impl<'a> Selection<'a> {
    /// For a zoom, the calibrations at the focal length nearest `requested_mm` (default the
    /// shortest calibrated), without interpolation; for vignetting, per f-number the distance
    /// nearest `distance_m` (default the farthest).
    pub(super) fn choose(
        entry: &'a LensEntry,
        requested_mm: Option<f64>,
        distance_m: Option<f64>,
        warnings: &mut Vec<String>,
    ) -> Result<Selection<'a>, LensfunError> {
        let model = &entry.model;
        let mut focals: Vec<f64> = entry.distortion.iter().map(|d| d.focal_mm).collect();
        focals.extend(entry.tca.iter().map(|t| t.focal_mm));
        focals.extend(entry.vignetting.iter().map(|v| v.focal_mm));
        let focal_length_mm = if focals.is_empty() {
            warnings.push(format!("{model}: lensfun has no calibration for this lens; the lens file has no tables"));
            requested_mm.or(entry.focal_range_mm.map(|r| r.0)).or_else(|| focal_length_from_model(model)).ok_or_else(
                || LensfunError::Missing {
                    model: model.clone(),
                    message: "no focal length: no calibration, no <focal> and none in the model name".into(),
                },
            )?
        } else {
            let shortest = focals.iter().copied().fold(f64::INFINITY, f64::min);
            let chosen = nearest_focal(&focals, |f| *f, requested_mm.unwrap_or(shortest)).unwrap_or(shortest);
            if let Some(r) = requested_mm.filter(|r| (chosen - r).abs() > 1e-9) {
                warnings.push(format!(
                    "{model}: no calibration at {r} mm; using the nearest calibrated focal length, {chosen} mm"
                ));
            }
            chosen
        };
        // Each kind of calibration at its focal length nearest the chosen one.
        let mut nearest = |what: &str, nearest: Option<f64>| {
            if let Some(f) = nearest.filter(|f| (f - focal_length_mm).abs() > 1e-9) {
                warnings.push(format!(
                    "{model}: lensfun has no {what} calibration at {focal_length_mm} mm; using the one at {f} mm"
                ));
            }
            nearest
        };
        let distortion = nearest("distortion", nearest_focal(&entry.distortion, |d| d.focal_mm, focal_length_mm))
            .and_then(|f| entry.distortion.iter().find(|d| d.focal_mm == f));
        let tca = nearest("TCA", nearest_focal(&entry.tca, |t| t.focal_mm, focal_length_mm))
            .and_then(|f| entry.tca.iter().find(|t| t.focal_mm == f));
        let vignetting_focal = nearest("vignetting", nearest_focal(&entry.vignetting, |v| v.focal_mm, focal_length_mm));
        let mut vignetting: Vec<&Vignetting> = Vec::new();
        if let Some(f) = vignetting_focal {
            let at_focal: Vec<&Vignetting> = entry.vignetting.iter().filter(|v| v.focal_mm == f).collect();
            let mut f_numbers: Vec<f64> = at_focal.iter().map(|v| v.f_number).collect();
            f_numbers.sort_by(f64::total_cmp);
            f_numbers.dedup();
            for n in f_numbers {
                let candidates = at_focal.iter().copied().filter(|v| v.f_number == n);
                // Distances compared in dioptres (1/m), in which focus differences are even
                // (lensfun's 1000 m, its infinity, is then next to infinity itself).
                let best = match distance_m {
                    Some(d) => {
                        let off = |v: &Vignetting| (1.0 / v.distance_m - 1.0 / d).abs();
                        candidates.min_by(|a, b| off(a).total_cmp(&off(b)))
                    }
                    None => candidates.max_by(|a, b| a.distance_m.total_cmp(&b.distance_m)),
                };
                vignetting.extend(best);
            }
        }
        Ok(Selection { focal_length_mm, distortion, tca, vignetting })
    }
}

/// The converted tables, against image height.
pub(super) struct Tables {
    pub(super) heights_mm: Vec<f64>,
    pub(super) distortion_percent: Option<Vec<f64>>,
    /// (red, blue) extra percent over green.
    pub(super) lateral_color_percent: Option<Vec<(f64, f64)>>,
    /// (f-number, relative illumination), increasing f-number.
    pub(super) vignetting: Vec<(f64, Vec<f64>)>,
    /// Some vignetting value was outside (0, 2] and clamped.
    pub(super) clamped: bool,
}

impl Tables {
    /// The selected calibrations sampled from 0 to `target_mm` (see the module documentation
    /// for the models and their units).
    pub(super) fn sample(sensor: &CalibrationSensor, selection: &Selection, target_mm: f64) -> Tables {
        let unit_mm = sensor.half_short_side_mm();
        let calibrated_mm = sensor.half_diagonal_mm();
        // The model's slope at the axis (module documentation): paraxial height = d0 r_u.
        let d0 = selection.distortion.map_or(1.0, |d| 1.0 + d.model.excess(0.0));
        let r_u = |h: f64| h / (d0 * unit_mm);
        let heights_mm = sample_heights(target_mm, &[d0 * unit_mm, calibrated_mm]);
        // Real over ideal height, r_d / h = (1 + excess(r_u)) / d0: 1 + Kyaw 2013 eq 6.8 / 100.
        let ratio = |h: f64| selection.distortion.map_or(1.0, |d| (1.0 + d.model.excess(r_u(h))) / d0);
        let distortion_percent =
            selection.distortion.map(|_| heights_mm.iter().map(|&h| 100.0 * (ratio(h) - 1.0)).collect());
        // The red image lands at k(r_g) r_g, with r_g = h ratio the green (distorted) radius:
        // over the ideal height that is 100 (k ratio - 1) percent, and less green's D the
        // extra is 100 (k - 1) ratio (100 (k - 1) to first order).
        let lateral_color_percent = selection.tca.map(|t| {
            heights_mm
                .iter()
                .map(|&h| {
                    let ratio = ratio(h);
                    let (kr, kb) = t.model.factors(h * ratio / unit_mm);
                    (100.0 * (kr - 1.0) * ratio, 100.0 * (kb - 1.0) * ratio)
                })
                .collect()
        });
        let mut clamped = false;
        let vignetting = selection
            .vignetting
            .iter()
            .map(|v| {
                let values = heights_mm
                    .iter()
                    .map(|&h| {
                        let ri = v.relative_illumination(h / calibrated_mm);
                        clamped |= !(MIN_RELATIVE_ILLUMINATION..=2.0).contains(&ri);
                        ri.clamp(MIN_RELATIVE_ILLUMINATION, 2.0)
                    })
                    .collect();
                (v.f_number, values)
            })
            .collect();
        Tables { heights_mm, distortion_percent, lateral_color_percent, vignetting, clamped }
    }

    pub(super) fn is_empty(&self) -> bool {
        self.distortion_percent.is_none() && self.lateral_color_percent.is_none() && self.vignetting.is_empty()
    }

    /// The `[tables]` of the lens file.
    pub(super) fn lens_tables(&self) -> LensTables {
        let color =
            |pick: fn(&(f64, f64)) -> f64| self.lateral_color_percent.as_ref().map(|c| c.iter().map(pick).collect());
        LensTables {
            image_height_mm: self.heights_mm.clone(),
            distortion_percent: self.distortion_percent.clone(),
            lateral_color_red_percent: color(|c| c.0),
            lateral_color_blue_percent: color(|c| c.1),
            relative_illumination: None,
            tangential_blur_mm: None,
            sagittal_blur_mm: None,
            field_curvature_mm: None,
            coma_mm: None,
            at_f_number: None,
            vignetting: self
                .vignetting
                .iter()
                .map(|(f_number, values)| IlluminationAt { f_number: *f_number, relative_illumination: values.clone() })
                .collect(),
        }
    }
}

/// A setting of the lens file and where it comes from (a TOML comment).
pub(super) struct Setting<T> {
    pub(super) value: T,
    pub(super) note: &'static str,
}

/// The settings lensfun gives only sometimes or never.
pub(super) struct Settings {
    pub(super) f_number_min: Setting<f64>,
    pub(super) f_number_max: Setting<f64>,
    pub(super) focus_min_m: Setting<f64>,
    pub(super) blades: Setting<u32>,
}

impl Settings {
    pub(super) fn new(
        entry: &LensEntry,
        focal_length_mm: f64,
        options: &ImportOptions,
    ) -> Result<Settings, LensfunError> {
        let given = positive("f_number_min", options.f_number_min)?;
        let f_number_min = match (given, entry.f_number_min, f_number_from_model(&entry.model)) {
            (Some(n), ..) => Setting { value: n, note: "given in the import options (f_number_min)" },
            (None, Some(n), _) => Setting { value: n, note: "lensfun <aperture min>" },
            (None, None, Some(n)) => Setting { value: n, note: "from the model name (lensfun has no <aperture>)" },
            (None, None, None) => {
                return Err(LensfunError::Missing {
                    model: entry.model.clone(),
                    message: "no widest f-number: the entry has no <aperture min> and the model name none \
                              (like f/1.4, F1.4, 1:2 or 1,4/50); give it with --f-number-min"
                        .into(),
                })
            }
        };
        let f_number_max = match entry.f_number_max {
            Some(n) if n >= f_number_min.value => Setting { value: n, note: "lensfun <aperture max>" },
            _ => Setting {
                value: f_number_min.value.max(16.0),
                note: "ASSUMED: f/16 (or f_number_min if larger); lensfun gives no smallest aperture",
            },
        };
        let focus_min_m = match positive("focus_min_m", options.focus_min_m)? {
            Some(m) => Setting { value: m, note: "given in the import options (focus_min_m)" },
            None => Setting {
                value: 10.0 * focal_length_mm / 1000.0,
                note: "ASSUMED: 10 focal lengths; lensfun does not give the closest focus",
            },
        };
        let blades = match options.blades {
            Some(b) => Setting { value: b, note: "given in the import options (blades)" },
            None => Setting { value: 0, note: "ASSUMED: circular; lensfun does not give the blade count" },
        };
        Ok(Settings { f_number_min, f_number_max, focus_min_m, blades })
    }
}

/// The entry's calibration sensor, after checking realcam can use the entry at all.
pub(super) fn check_supported(entry: &LensEntry) -> Result<CalibrationSensor, LensfunError> {
    let unsupported = |at: &Location, message: String| LensfunError::Unsupported {
        model: entry.model.clone(),
        path: at.path.clone(),
        line: at.line,
        message,
    };
    if !entry.lens_type.eq_ignore_ascii_case("rectilinear") {
        return Err(unsupported(
            &entry.at,
            format!(
                "its type is {0} (<type>{0}</type>), not rectilinear: realcam's lens files describe \
                 rectilinear lenses only (distortion as a percentage of the rectilinear image height)",
                entry.lens_type
            ),
        ));
    }
    if let Some(d) = entry.distortion.iter().find(|d| matches!(d.model, DistortionModel::Unknown(_))) {
        return Err(unsupported(
            &d.at,
            format!("distortion {}: realcam knows poly3, poly5 and ptlens", d.model.describe()),
        ));
    }
    if let Some(t) = entry.tca.iter().find(|t| matches!(t.model, TcaModel::Unknown(_))) {
        return Err(unsupported(&t.at, format!("TCA {}: realcam knows linear and poly3", t.model.describe())));
    }
    if let Some(v) = entry.vignetting.iter().find(|v| v.model != "pa") {
        return Err(unsupported(&v.at, format!("vignetting model {:?}: realcam knows pa", v.model)));
    }
    let calibrated = !(entry.distortion.is_empty() && entry.tca.is_empty() && entry.vignetting.is_empty());
    match entry.calibration_sensor() {
        Some(s) => Ok(s),
        None if calibrated => Err(LensfunError::Missing {
            model: entry.model.clone(),
            message: format!(
                "the entry at {} has no <cropfactor>, so its calibration's radii have no size in mm",
                entry.at
            ),
        }),
        None => Ok(CalibrationSensor { crop_factor: 1.0, aspect_ratio: entry.aspect_ratio }),
    }
}

/// Converts one database entry into a lens file.
pub(super) fn convert(
    entry: &LensEntry,
    others: Vec<LensEntry>,
    options: &ImportOptions,
) -> Result<Imported, LensfunError> {
    options.check()?;
    let sensor = check_supported(entry)?;
    let requested_mm = positive("focal_length_mm", options.focal_length_mm)?;
    let distance_m = positive("distance_m", options.distance_m)?;
    let diagonal_mm = positive("sensor_diagonal_mm", options.sensor_diagonal_mm)?.unwrap_or(FULL_FRAME_DIAGONAL_MM);
    let mut warnings = Vec::new();
    let selection = Selection::choose(entry, requested_mm, distance_m, &mut warnings)?;
    let settings = Settings::new(entry, selection.focal_length_mm, options)?;
    let target_mm = diagonal_mm / 2.0;
    let tables = Tables::sample(&sensor, &selection, target_mm);
    let model = &entry.model;
    let extrapolated = !tables.is_empty() && target_mm > sensor.half_diagonal_mm() * (1.0 + 1e-9);
    if extrapolated {
        warnings.push(format!(
            "{model}: lensfun's calibration covers image heights up to {:.2} mm (crop factor {}); the tables from \
             there to {target_mm:.2} mm extrapolate its fitted polynomials",
            sensor.half_diagonal_mm(),
            sensor.crop_factor
        ));
    }
    if tables.clamped {
        warnings.push(format!(
            "{model}: the vignetting polynomial leaves (0, 2] inside the tables; clamped to [{MIN_RELATIVE_ILLUMINATION}, 2]"
        ));
    }
    if entry.center.is_some_and(|c| c != (0.0, 0.0)) {
        warnings.push(format!("{model}: lensfun's <center> offset is not used (realcam's tables are centred)"));
    }
    for w in &warnings {
        log::warn!("{w}");
    }
    let text = lens_file_text(entry, &others, &sensor, &selection, &settings, &tables, distance_m, diagonal_mm);
    let lens = LensFile::parse(&text, Path::new(&format!("<lensfun {model}>"))).map_err(|error| {
        let hint = if extrapolated {
            format!(
                ". The tables reach {target_mm:.2} mm but the calibration only {:.2} mm: give the sensor's \
                     diagonal in sensor_diagonal_mm (the calibration sensor's is {:.2} mm)",
                sensor.half_diagonal_mm(),
                2.0 * sensor.half_diagonal_mm()
            )
        } else {
            String::new()
        };
        LensfunError::Converted { model: model.clone(), error, hint }
    })?;
    Ok(Imported { toml: text, lens, entry: entry.clone(), others, warnings })
}
