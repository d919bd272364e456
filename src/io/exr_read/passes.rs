//! The steps of [`super::load_passes`]: the files opened side by side, each pass read, checked
//! and described in the channel report, and the other channels kept for the output.

use super::channels::{find_depth, interleave, names, same_size, Found};
use super::file::{Chan, ExrFile};
use super::velocity::{find_velocity, negated, vector_image, Velocity, VELOCITY_LOOKED_FOR};
use super::{color_image, Image, IoError, MemoryBudget, PassSources, VelocityFormat};
use std::path::{Path, PathBuf};

/// The velocity toward the next frame, toward the previous one, and the format they were read in.
pub(super) type VelocityPasses = (Option<Image>, Option<Image>, Option<VelocityFormat>);

/// Opens `path` unless it is `None` or `same`: then the caller reuses its open file.
fn open_other(
    path: &Option<PathBuf>,
    same: &Path,
    what: &str,
    budget: &MemoryBudget,
) -> Result<Option<ExrFile>, IoError> {
    match path {
        Some(p) if p != same => ExrFile::open(p, what, budget).map(Some),
        _ => Ok(None),
    }
}

/// The colour file, and the depth and velocity files where they are others.
pub(super) fn open_files(src: &PassSources) -> Result<(ExrFile, Option<ExrFile>, Option<ExrFile>), IoError> {
    // The depth and velocity files decode on threads of their own beside the colour's (scene A:
    // the three reads 31-41 ms one after another, 17-36 ms side by side); the colour's error,
    // if any, is the one reported first.
    let (cf, df_own, vf_own) = std::thread::scope(|scope| {
        let depth = scope.spawn(|| open_other(&src.depth_path, &src.color_path, "depth", &src.budget));
        let velocity = scope.spawn(|| open_other(&src.velocity_path, &src.color_path, "velocity", &src.budget));
        let cf = ExrFile::open(&src.color_path, "color", &src.budget);
        // The decoder's own panics are caught in ExrFile::open; any other is a bug, passed on.
        let joined =
            |t: std::thread::ScopedJoinHandle<'_, _>| t.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        (cf, joined(depth), joined(velocity))
    });
    Ok((cf?, df_own?, vf_own?))
}

/// The colour (NaN/Inf replaced by 0, counted), the channels it came from and the count.
pub(super) fn read_color<'a>(
    cf: &'a ExrFile,
    src: &PassSources,
    layer: Option<&str>,
    report: &mut Vec<String>,
) -> Result<(Image, Found<'a>, u64), IoError> {
    let (mut color, cfound) = color_image(cf, src.color_channels.as_deref(), layer)?;
    let c0 = cfound.chans[0];
    let mut color_nan_count = 0u64;
    for v in color.data.iter_mut().filter(|v| !v.is_finite()) {
        *v = 0.0;
        color_nan_count += 1;
    }
    if color_nan_count > 0 {
        log::warn!("color: {color_nan_count} NaN/Inf value(s) in \"{}\" replaced by 0", cf.path.display());
    }
    report.push(format!(
        "color: \"{}\" channels {} ({}), {}{}{}",
        cf.path.display(),
        names(&cfound.chans),
        cfound.rule,
        c0.type_name(),
        if cfound.chans.len() == 3 { ", alpha = 1 (none in file)" } else { "" },
        if color_nan_count > 0 { format!(", {color_nan_count} NaN/Inf value(s) replaced by 0") } else { String::new() }
    ));
    Ok((color, cfound, color_nan_count))
}

/// The depth in metres (negative or NaN: an error) and its channel; `color` is the colour's
/// file and first channel, whose size it must have.
pub(super) fn read_depth<'a>(
    df: &'a ExrFile,
    src: &PassSources,
    layer: Option<&str>,
    color: (&ExrFile, &Chan),
    report: &mut Vec<String>,
) -> Result<(Image, &'a Chan), IoError> {
    let unit_m = src.depth_unit_m;
    let dfound = find_depth(df, src.depth_channel.as_deref(), layer)?;
    let dc = dfound.chans[0];
    same_size("color", color.0, color.1, "depth", df, dc)?;
    let mut depth_m = interleave(&dfound.chans, 1, 0.0);
    let mut bad: Option<(usize, f32)> = None;
    let mut bad_count = 0u64;
    for (i, v) in depth_m.data.iter_mut().enumerate() {
        *v = (*v as f64 * unit_m) as f32;
        if v.is_nan() || *v < 0.0 {
            bad_count += 1;
            bad.get_or_insert((i, *v));
        }
    }
    if let Some((i, value_m)) = bad {
        return Err(IoError::InvalidDepth {
            path: df.path.clone(),
            channel: dc.name.clone(),
            x: i % dc.size.0,
            y: i / dc.size.0,
            value_m,
            count: bad_count,
        });
    }
    report.push(format!(
        "depth: \"{}\" channel {} ({}), {}, {unit_m} m per unit, used as stored (no planar/ray conversion)",
        df.path.display(),
        dc.name,
        dfound.rule,
        dc.type_name()
    ));
    Ok((depth_m, dc))
}

/// The velocity (next frame, previous frame where the file has it, and its format), or none
/// where the file has none and none is required. The velocity's data origin joins `origins`.
pub(super) fn read_velocity(
    vf: &ExrFile,
    src: &PassSources,
    layer: Option<&str>,
    color: (&ExrFile, &Chan),
    origins: &mut Vec<(&'static str, (i32, i32))>,
    report: &mut Vec<String>,
) -> Result<VelocityPasses, IoError> {
    let explicit = src.velocity_path.is_some() || src.velocity_channels.is_some();
    if !(src.velocity_scale.is_finite() && src.velocity_scale != 0.0) {
        return Err(IoError::InvalidArgument {
            field: "velocity_scale",
            value: src.velocity_scale,
            allowed: "a finite, non-zero factor",
        });
    }
    match find_velocity(vf, src.velocity_channels.as_deref(), src.velocity_format, layer)? {
        Some(v) => convert_velocity(vf, src, v, color, origins, report),
        None if explicit || src.require_velocity => {
            let looked_for = match src.velocity_format {
                VelocityFormat::Auto => VELOCITY_LOOKED_FOR.to_string(),
                f => format!("{} (the {} format)", VELOCITY_LOOKED_FOR, f.name()),
            };
            Err(vf.missing("velocity", &looked_for))
        }
        None => {
            report.push(format!("velocity: none (no velocity channels in \"{}\")", vf.path.display()));
            Ok((None, None, None))
        }
    }
}

/// The velocity channels found made images of pixels per frame (see [`read_velocity`]).
fn convert_velocity(
    vf: &ExrFile,
    src: &PassSources,
    v: Velocity,
    (cf, c0): (&ExrFile, &Chan),
    origins: &mut Vec<(&'static str, (i32, i32))>,
    report: &mut Vec<String>,
) -> Result<VelocityPasses, IoError> {
    let first = v.next.as_ref().or(v.prev.as_ref()).map(|c| c.x).unwrap_or(c0);
    let mut chans = Vec::new();
    for c in v.next.iter().chain(&v.prev) {
        same_size("color", cf, c0, "velocity", vf, c.x)?;
        same_size("velocity", vf, c.x, "velocity", vf, c.y)?;
        chans.extend([c.x, c.y]);
    }
    origins.push(("velocity", first.origin));
    let factor = velocity_factor(vf, src, v.format, c0, &chans)?;
    let (scale, flip) = (src.velocity_scale as f32, src.velocity_flip_y);
    let mut nonfinite = 0u64;
    let next = v.next.as_ref().map(|c| vector_image(c, factor, scale, flip, &mut nonfinite));
    let prev = v.prev.as_ref().map(|c| vector_image(c, factor, scale, flip, &mut nonfinite));
    if nonfinite > 0 {
        log::warn!("velocity: {nonfinite} NaN/Inf value(s) in \"{}\" replaced by 0", vf.path.display());
    }
    let mut adjust = String::new();
    if scale != 1.0 {
        adjust += &format!(", scaled by {scale}");
    }
    if flip {
        adjust += ", y flipped";
    }
    report.push(format!(
        "velocity: \"{}\" channels {} ({}{adjust}), {}{}",
        vf.path.display(),
        names(&chans),
        v.rule,
        first.type_name(),
        if nonfinite > 0 { format!(", {nonfinite} NaN/Inf value(s) replaced by 0") } else { String::new() }
    ));
    // Only the previous-frame vector: constant velocity gives the next one.
    let next = match (next, &prev) {
        (Some(n), _) => n,
        (None, Some(p)) => negated(p),
        (None, None) => return Err(vf.missing("velocity", VELOCITY_LOOKED_FOR)),
    };
    let prev = if v.next.is_some() { prev } else { None };
    Ok((Some(next), prev, Some(v.format)))
}

/// Per-frame pixels from the format's own unit: the factor on (x, y).
fn velocity_factor(
    vf: &ExrFile,
    src: &PassSources,
    format: VelocityFormat,
    c0: &Chan,
    chans: &[&Chan],
) -> Result<[f32; 2], IoError> {
    Ok(match format {
        VelocityFormat::Ndc => [0.5 * c0.size.0 as f32, 0.5 * c0.size.1 as f32],
        VelocityFormat::Arnold => match src.velocity_interval_frames {
            Some(i) if i.is_finite() && i > 0.0 => [1.0 / i as f32; 2],
            Some(i) => {
                return Err(IoError::InvalidArgument {
                    field: "velocity_interval_frames",
                    value: i,
                    allowed: "a positive number of frames",
                })
            }
            None => {
                return Err(IoError::MissingSetting {
                    field: "velocity_interval_frames",
                    path: vf.path.clone(),
                    why: format!(
                        "holds Arnold motion vectors ({}), which span the renderer's shutter interval; the file does not say how long it was",
                        names(chans)
                    ),
                })
            }
        },
        _ => [1.0, 1.0],
    })
}

/// Warns of passes whose data window starts elsewhere than the colour's, and reports the
/// colour's data and display windows.
pub(super) fn report_windows(
    cf: &ExrFile,
    c0: &Chan,
    origins: Vec<(&'static str, (i32, i32))>,
    report: &mut Vec<String>,
) {
    for (what, o) in origins.into_iter().filter(|(_, o)| *o != c0.origin) {
        let msg = format!(
            "{what}: data window origin ({}, {}) px differs from color's ({}, {}) px; pixels are paired by index",
            o.0, o.1, c0.origin.0, c0.origin.1
        );
        log::warn!("{msg}");
        report.push(msg);
    }
    let dw = cf.display_window;
    report.push(format!(
        "data window: origin ({}, {}) px, {}x{} px; display window: origin ({}, {}) px, {}x{} px",
        c0.origin.0, c0.origin.1, c0.size.0, c0.size.1, dw.0, dw.1, dw.2, dw.3
    ));
}

/// Every channel of the colour's file `cf` and of the depth and velocity files where they are
/// others that the colour does not use, renamed where its name is taken, for the output
/// (`--keep-layers`); those of another size are left out.
pub(super) fn kept_channels(
    cf: &ExrFile,
    df_own: Option<&ExrFile>,
    vf_own: Option<&ExrFile>,
    cfound: &Found,
    report: &mut Vec<String>,
) -> Vec<(String, Vec<f32>)> {
    let files = [("color", Some(cf)), ("depth", df_own), ("velocity", vf_own)];
    let c0 = cfound.chans[0];
    let mut kept_channels: Vec<(String, Vec<f32>)> = Vec::new();
    let used: Vec<&str> = cfound.chans.iter().map(|c| c.name.as_str()).collect();
    let mut left_out = Vec::new();
    for (what, file) in files.into_iter().filter_map(|(w, f)| Some((w, f?))) {
        for c in &file.chans {
            if std::ptr::eq(file, cf) && used.contains(&c.name.as_str()) {
                continue;
            }
            if c.size != c0.size {
                left_out.push(format!(
                    "{} ({}x{} px, not the frame's {}x{})",
                    c.name, c.size.0, c.size.1, c0.size.0, c0.size.1
                ));
                continue;
            }
            let taken = |n: &str| ["R", "G", "B", "A"].contains(&n) || kept_channels.iter().any(|(k, _)| k == n);
            let name = if taken(&c.name) { format!("{what}.{}", c.name) } else { c.name.clone() };
            if taken(&name) {
                left_out.push(format!("{} (its name is taken)", c.name));
                continue;
            }
            kept_channels.push((name, c.to_f32()));
        }
    }
    let mut line = format!(
        "kept for the output: {} channel(s){}",
        kept_channels.len(),
        if kept_channels.is_empty() {
            String::new()
        } else {
            format!(" ({})", kept_channels.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", "))
        }
    );
    if !left_out.is_empty() {
        line += &format!("; left out: {}", left_out.join(", "));
        log::warn!("--keep-layers: channel(s) left out of the output: {}", left_out.join(", "));
    }
    report.push(line);
    kept_channels
}
