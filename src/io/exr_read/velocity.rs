//! Finding the velocity channels of every supported format and converting them to pixels per
//! frame toward the next frame, x right, y down.

use super::channels::{in_layer, interleave, split_list};
use super::file::{Chan, ExrFile};
use super::{Image, IoError, VelocityFormat};

/// Two channels of a velocity pass and their conversion: (dx, dy) = (sx * x, sy * y) px per
/// frame, x right, y down.
pub(super) struct Vector<'a> {
    pub(super) x: &'a Chan,
    pub(super) y: &'a Chan,
    pub(super) sx: f32,
    pub(super) sy: f32,
}

/// The velocity channels found: toward the next frame and, when present, toward the previous.
pub(super) struct Velocity<'a> {
    pub(super) next: Option<Vector<'a>>,
    pub(super) prev: Option<Vector<'a>>,
    pub(super) format: VelocityFormat,
    pub(super) rule: String,
}

pub(super) const BLENDER_XYZW: &str =
    "Blender Vector, x right/y up: X,Y = p[f-1]-p[f] -> previous (X, -Y); Z,W = p[f]-p[f+1] -> next (-Z, +W) px/frame";
pub(super) const BLENDER_XY: &str =
    "Blender Vector X,Y = p[f-1]-p[f], x right/y up: previous (X, -Y) px/frame, constant velocity assumed";
pub(super) const NEXT_Y_UP: &str = "px toward the next frame, x right/y up: next (x, -y) px/frame";
pub(super) const VELOCITY_LOOKED_FOR: &str = "<layer>.Vector.X/Y[/Z/W], X,Y,Z,W (whole file), forward.u/v [+ backward.u/v], motion.u/v, motion.x/y, motion_vector.R/G, velocity.X/Y, velocity.R/G, VRayVelocity.R/G, vel.X/Y";

/// Single-vector channel pairs, by the format their names stand for.
pub(super) const SINGLE_VECTORS: [(&str, &str, VelocityFormat); 10] = [
    ("motion.u", "motion.v", VelocityFormat::Nuke),
    ("motion.x", "motion.y", VelocityFormat::Nuke),
    ("motion_vector.R", "motion_vector.G", VelocityFormat::Arnold),
    ("motion_vector.X", "motion_vector.Y", VelocityFormat::Arnold),
    ("velocity.X", "velocity.Y", VelocityFormat::Vray),
    ("velocity.R", "velocity.G", VelocityFormat::Vray),
    ("VRayVelocity.R", "VRayVelocity.G", VelocityFormat::Vray),
    ("VRayVelocity.X", "VRayVelocity.Y", VelocityFormat::Vray),
    ("vel.X", "vel.Y", VelocityFormat::Revision),
    ("vel.x", "vel.y", VelocityFormat::Revision),
];

/// What a single forward vector of `format` means, in words.
pub(super) fn single_rule(format: VelocityFormat) -> &'static str {
    match format {
        VelocityFormat::Arnold => "Arnold raw motion_vector: px over the renderer's shutter interval, forward, x right/y up: next (x, -y) / interval",
        VelocityFormat::Vray => "V-Ray velocity: px from the current to the next frame, x right/y up: next (x, -y) px/frame",
        VelocityFormat::Revision => "RE:Vision single vector: px per frame, forward, +y up: next (x, -y) px/frame",
        VelocityFormat::Ndc => "NDC: a frame width (height) of 2 per frame, forward, y up: next (x W/2, -y H/2) px/frame",
        _ => NEXT_Y_UP,
    }
}

pub(super) fn forward<'a>(x: &'a Chan, y: &'a Chan) -> Option<Vector<'a>> {
    Some(Vector { x, y, sx: 1.0, sy: -1.0 })
}

/// Every velocity format whose channel names the file has, in the order tried.
pub(super) fn velocity_candidates<'a>(f: &'a ExrFile, layer: Option<&str>) -> Vec<Velocity<'a>> {
    let mut found = Vec::new();
    let blender = |next, prev, rule: &str| Velocity { next, prev, format: VelocityFormat::Blender, rule: rule.into() };
    for c in f.chans.iter().filter(in_layer(f, layer)) {
        if let Some(layer) = c.name.strip_suffix(".Vector.X") {
            let n = |s: &str| f.find(&format!("{layer}.Vector.{s}"));
            match (n("Y"), n("Z"), n("W")) {
                (Some(y), Some(z), Some(w)) => {
                    let next = Some(Vector { x: z, y: w, sx: -1.0, sy: 1.0 });
                    let prev = Some(Vector { x: c, y, sx: 1.0, sy: -1.0 });
                    found.push(blender(next, prev, BLENDER_XYZW));
                }
                (Some(y), _, _) => found.push(blender(None, Some(Vector { x: c, y, sx: 1.0, sy: -1.0 }), BLENDER_XY)),
                _ => {}
            }
        }
    }
    if f.chans.len() == 4 {
        if let Some(c) = f.find_all(&["X", "Y", "Z", "W"]) {
            let next = Some(Vector { x: c[2], y: c[3], sx: -1.0, sy: 1.0 });
            found.push(blender(next, Some(Vector { x: c[0], y: c[1], sx: 1.0, sy: -1.0 }), BLENDER_XYZW));
        }
    }
    if let (Some(u), Some(v)) = (f.find("forward.u"), f.find("forward.v")) {
        let prev = match (f.find("backward.u"), f.find("backward.v")) {
            (Some(bu), Some(bv)) => forward(bu, bv),
            _ => None,
        };
        let rule = if prev.is_some() {
            "Nuke forward/backward: px toward the next/previous frame, x right/y up: next (u, -v), previous (bu, -bv) px/frame"
        } else {
            "Nuke forward: px toward the next frame, x right/y up: next (u, -v) px/frame, constant velocity assumed"
        };
        found.push(Velocity { next: forward(u, v), prev, format: VelocityFormat::Nuke, rule: rule.into() });
    }
    for (x, y, format) in SINGLE_VECTORS {
        if let (Some(cx), Some(cy)) = (f.find(x), f.find(y)) {
            found.push(Velocity { next: forward(cx, cy), prev: None, format, rule: single_rule(format).into() });
        }
    }
    found
}

pub(super) fn find_velocity<'a>(
    f: &'a ExrFile,
    ovr: Option<&str>,
    format: VelocityFormat,
    layer: Option<&str>,
) -> Result<Option<Velocity<'a>>, IoError> {
    if let Some(o) = ovr {
        let names = split_list(o);
        let c = match names.len() {
            2 | 4 => f.require("velocity", o, &names)?,
            n => {
                return Err(IoError::BadOverride {
                    what: "velocity".into(),
                    requested: o.into(),
                    reason: format!("expected 2 or 4 channel names, got {n}"),
                })
            }
        };
        let blender_like = format == VelocityFormat::Blender
            || (format == VelocityFormat::Auto && (c.len() == 4 || names[0].contains(".Vector.")));
        return Ok(Some(if c.len() == 4 {
            if !matches!(format, VelocityFormat::Auto | VelocityFormat::Blender) {
                return Err(IoError::BadOverride {
                    what: "velocity".into(),
                    requested: o.into(),
                    reason: format!("4 channels are Blender's X,Y,Z,W; the {} format has 2", format.name()),
                });
            }
            Velocity {
                next: Some(Vector { x: c[2], y: c[3], sx: -1.0, sy: 1.0 }),
                prev: Some(Vector { x: c[0], y: c[1], sx: 1.0, sy: -1.0 }),
                format: VelocityFormat::Blender,
                rule: format!("override \"{o}\" as {BLENDER_XYZW}"),
            }
        } else if blender_like {
            Velocity {
                next: None,
                prev: Some(Vector { x: c[0], y: c[1], sx: 1.0, sy: -1.0 }),
                format: VelocityFormat::Blender,
                rule: format!("override \"{o}\" as {BLENDER_XY}"),
            }
        } else {
            let format = if format == VelocityFormat::Auto { VelocityFormat::Nuke } else { format };
            Velocity {
                next: forward(c[0], c[1]),
                prev: None,
                format,
                rule: format!("override \"{o}\" as {}", single_rule(format)),
            }
        }));
    }
    let mut candidates = velocity_candidates(f, layer);
    match format {
        VelocityFormat::Auto => {
            let mut formats: Vec<&str> = candidates.iter().map(|v| v.format.name()).collect();
            formats.dedup();
            if formats.len() > 1 {
                return Err(IoError::AmbiguousChannels {
                    what: "velocity".into(),
                    path: f.path.clone(),
                    candidates: format!("formats {}; choose one with --velocity-format", formats.join(", ")),
                });
            }
            Ok(candidates.into_iter().next())
        }
        // Channels named for no format in particular, read as the format the user named.
        VelocityFormat::Ndc | VelocityFormat::Revision => {
            let format_of = |mut v: Velocity<'a>| {
                v.format = format;
                v.rule = single_rule(format).into();
                v
            };
            let single = |v: &Velocity| v.prev.is_none() && v.next.is_some();
            let own = candidates.iter().position(|v| v.format == format && single(v));
            let index = own.or_else(|| candidates.iter().position(single));
            Ok(index.map(|i| format_of(candidates.swap_remove(i))))
        }
        _ => {
            candidates.retain(|v| v.format == format);
            Ok(candidates.into_iter().next())
        }
    }
}

/// A velocity vector image (2 channels, px per frame, x right, y down) from its channels, with
/// the format's extra factor and the user's scale and flip; NaN/Inf become 0 (counted).
pub(super) fn vector_image(v: &Vector, factor: [f32; 2], scale: f32, flip_y: bool, nonfinite: &mut u64) -> Image {
    let mut im = interleave(&[v.x, v.y], 2, 0.0);
    let flip = if flip_y { -1.0 } else { 1.0 };
    let s = [v.sx * factor[0] * scale, v.sy * factor[1] * scale * flip];
    for pair in im.data.chunks_exact_mut(2) {
        for (px, s) in pair.iter_mut().zip(s) {
            *px = if px.is_finite() {
                // `+ 0.0` turns -0 into +0.
                *px * s + 0.0
            } else {
                *nonfinite += 1;
                0.0
            };
        }
    }
    im
}

/// -v of a 2-channel vector image (the other half of a constant motion).
pub(super) fn negated(im: &Image) -> Image {
    Image { data: im.data.iter().map(|v| -v + 0.0).collect(), ..im.clone() }
}
