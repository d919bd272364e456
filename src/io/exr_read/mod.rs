//! Loading the color, depth and velocity passes of a rendered frame from OpenEXR files.
//!
//! Channel names are case-sensitive and tried in this order; the first complete match wins.
//! In a multi-part file each channel is known by `<part name>.<channel>` (unless the channel
//! name already starts with the part name) and also by its bare name when that is unique.
//!
//! | pass     | channels                                  | convention / conversion to (dx, dy), px per frame toward the NEXT frame, x right, y DOWN |
//! |----------|-------------------------------------------|------------------------------------------------------------------------|
//! | color    | `<Layer>.Combined.R,G,B[,A]`              | Blender multilayer (any layer name, e.g. `ViewLayer`)                   |
//! | color    | `R,G,B[,A]`                               | Nuke / common                                                           |
//! | color    | `rgba.red,green,blue[,alpha]`             |                                                                         |
//! | color    | `<prefix>.R,G,B[,A]`                      | only when exactly one such prefix exists (e.g. `beauty.R`)              |
//! | depth    | `<Layer>.Depth.Z`                         | Blender                                                                 |
//! | depth    | `Z`, `depth.Z`, `depth.R`, `depth`        | common, Nuke                                                            |
//! | depth    | the only channel of a one-channel file    | whatever its name (`Y`, `R`, ...)                                       |
//! | velocity | `<Layer>.Vector.X,Y,Z,W`, `X,Y,Z,W` (whole file) | Blender, y UP: next (-Z, +W), previous (X, -Y)              |
//! | velocity | `<Layer>.Vector.X,Y` (no Z,W)             | Blender: previous (X, -Y), next = -previous (constant velocity)         |
//! | velocity | `forward.u,v` [+ `backward.u,v`]          | Nuke, y UP: next (u, -v), previous (bu, -bv)                            |
//! | velocity | `motion.u,v` / `motion.x,y`               | Nuke single vector: next (u, -v)                                        |
//! | velocity | `motion_vector.R,G` (or `.X,Y`)           | Arnold raw, over the renderer's shutter: next (R, -G) / interval        |
//! | velocity | `velocity.X,Y`/`.R,G`, `VRayVelocity.R,G` | V-Ray, current to next frame, y UP: next (x, -y)                        |
//! | velocity | `vel.X,Y`                                 | RE:Vision single vector, y UP: next (x, -y)                             |
//!
//! With [`VelocityFormat::Auto`] the format comes from the names, and names of two formats in
//! one file are an error; a named format reads only its own names (`ndc` and `revision` also the
//! generic single-vector names, read as that format). `velocity_scale` and `velocity_flip_y`
//! apply after the conversion.
//!
//! Overrides ([`PassSources`]): color takes a layer prefix `P` (reads `P.R,P.G,P.B[,P.A]`) or an
//! explicit list `R,G,B[,A]`; depth takes one exact channel name; velocity takes 4 names
//! (Blender `X,Y,Z,W`) or 2 names `x,y`, read in the named format, or with `auto` as Blender
//! previous-frame vectors when the first contains `.Vector.`, else as px toward the next frame, y UP
//! (x, -y). The conventions used are written to [`ScenePasses::channel_report`].

use super::{Image, IoError, MemoryBudget, PassSources, ScenePasses, VelocityFormat};
use channels::{choose_layer, color_image, interleave};
use file::ExrFile;
use std::path::Path;

mod channels;
mod file;
mod passes;
mod velocity;

pub use file::{DECODER_PANICS, STRUCTURAL_ATTRIBUTES};

/// Whether a header attribute describes channels: Cryptomatte's `cryptomatte/<id>/...` (name,
/// hash, conversion, manifest), `multiView` (the views' channel prefixes) and Blender's
/// `BlenderMultiChannel` (which has Blender read the channels as view layers and passes).
/// They go with the channels: into an output only with the input's other channels
/// (`--keep-layers`).
pub fn describes_channels(attribute: &str) -> bool {
    attribute.starts_with("cryptomatte/") || attribute == "multiView" || attribute == "BlenderMultiChannel"
}

/// Reads the color of an EXR file as RGBA (alpha = 1 when absent) using the same channel
/// discovery as [`load_passes`]. Values are returned as stored (NaN/Inf kept).
pub fn read_exr_rgba(path: &Path) -> Result<Image, IoError> {
    read_exr_rgba_within(path, &MemoryBudget::system())
}

/// [`read_exr_rgba`] within `budget`.
pub fn read_exr_rgba_within(path: &Path, budget: &MemoryBudget) -> Result<Image, IoError> {
    let f = ExrFile::open(path, "color", budget)?;
    Ok(color_image(&f, None, None)?.0)
}

/// Reads one channel, by exact (qualified) name, as a 1-channel image, values as stored.
pub fn read_exr_channel(path: &Path, channel: &str) -> Result<Image, IoError> {
    let f = ExrFile::open(path, "channel", &MemoryBudget::system())?;
    let c = f.require("channel", channel, &[channel])?;
    Ok(interleave(&c, 1, 0.0))
}

/// Whether `src` will likely give a velocity pass, judged from the files' headers alone (a few
/// kB read; the pixels are not): a velocity file or channels named, or channels in the colour
/// file's headers that name a velocity format. A session creates the motion blur's pipelines
/// beside the read when so. A file whose headers do not read says no; its read reports why.
pub fn velocity_likely(src: &PassSources) -> bool {
    if src.velocity_path.is_some() || src.velocity_channels.is_some() {
        return true;
    }
    file::ExrFile::names_only(&src.color_path)
        .is_some_and(|f| !velocity::velocity_candidates(&f, src.layer.as_deref()).is_empty())
}

/// Loads color, depth and (when present or required) velocity; see the module docs for
/// the channel names and conventions.
pub fn load_passes(src: &PassSources) -> Result<ScenePasses, IoError> {
    let unit_m = src.depth_unit_m;
    if !(unit_m.is_finite() && unit_m > 0.0) {
        return Err(IoError::InvalidArgument {
            field: "depth_unit_m",
            value: unit_m,
            allowed: "a positive number of metres per depth unit",
        });
    }
    let (cf, df_own, vf_own) = passes::open_files(src)?;
    let df = df_own.as_ref().unwrap_or(&cf);
    let vf = vf_own.as_ref().unwrap_or(&cf);
    let mut report = Vec::new();

    // The view layer, chosen once for every pass.
    let (layer, layer_line) = choose_layer(&cf, src)?;
    let layer = layer.as_deref();
    report.extend(layer_line);

    let (color, cfound, color_nan_count) = passes::read_color(&cf, src, layer, &mut report)?;
    let c0 = cfound.chans[0];
    let (depth_m, dc) = passes::read_depth(df, src, layer, (&cf, c0), &mut report)?;
    let mut origins = vec![("depth", dc.origin)];
    let (velocity_px, velocity_prev_px, velocity_format) =
        passes::read_velocity(vf, src, layer, (&cf, c0), &mut origins, &mut report)?;
    passes::report_windows(&cf, c0, origins, &mut report);

    // The other channels, for the output.
    let kept_channels = if src.keep_layers {
        passes::kept_channels(&cf, df_own.as_ref(), vf_own.as_ref(), &cfound, &mut report)
    } else {
        Vec::new()
    };

    Ok(ScenePasses {
        color,
        depth_m,
        velocity_px,
        velocity_prev_px,
        velocity_format,
        display_window: cf.display_window,
        data_origin: c0.origin,
        channel_report: report.join("\n"),
        color_nan_count,
        kept_channels,
        render_focal_length_mm: cf.focal_length_mm.clone(),
        chromaticities: cf.chromaticities,
        header_attributes: cf
            .header_attributes
            .iter()
            .filter(|(name, _)| src.keep_layers || !describes_channels(name))
            .cloned()
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{test_dir, write_exr_channels, ExrWriteOptions};

    const W: u32 = 4;
    const H: u32 = 3;

    /// Writes `W`x`H` channels, each filled with a constant.
    fn write(path: &Path, chans: &[(&str, f32)], float32: bool) {
        let planes: Vec<Vec<f32>> = chans.iter().map(|&(_, v)| vec![v; (W * H) as usize]).collect();
        let list: Vec<(&str, &[f32])> = chans.iter().zip(&planes).map(|(c, p)| (c.0, p.as_slice())).collect();
        let opts = ExrWriteOptions { float32, ..Default::default() };
        write_exr_channels(path, W, H, &list, &opts).unwrap();
    }

    fn sources(color: &Path) -> PassSources {
        PassSources::new(color)
    }

    fn assert_const(im: &Image, expected: &[f32]) {
        assert_eq!((im.width, im.height, im.channels as usize), (W, H, expected.len()));
        for px in im.data.chunks_exact(expected.len()) {
            assert_eq!(px, expected);
        }
    }

    #[test]
    fn blender_multilayer() {
        let dir = test_dir("read-blender");
        let path = dir.join("passes.exr");
        // Constant motion v = (3, 2) px/frame, x right / y up: X,Y = Z,W = -v.
        let (vx, vy) = (3.0, 2.0);
        let mut chans = vec![
            ("ViewLayer.Combined.R", 0.5),
            ("ViewLayer.Combined.G", 0.25),
            ("ViewLayer.Combined.B", 2.0),
            ("ViewLayer.Combined.A", 1.0),
            ("ViewLayer.Depth.Z", 1.0e10),
            ("ViewLayer.Vector.X", -vx),
            ("ViewLayer.Vector.Y", -vy),
        ];
        write(&path, &chans, true);
        // Two-channel vectors (previous frame only), constant velocity assumed.
        let p = load_passes(&sources(&path)).unwrap();
        assert_const(p.velocity_px.as_ref().unwrap(), &[vx, -vy]);
        assert!(p.channel_report.contains("ViewLayer.Vector.X, ViewLayer.Vector.Y"), "{}", p.channel_report);
        chans.extend([("ViewLayer.Vector.Z", -vx), ("ViewLayer.Vector.W", -vy)]);
        write(&path, &chans, true);
        let p = load_passes(&sources(&path)).unwrap();
        assert_const(&p.color, &[0.5, 0.25, 2.0, 1.0]);
        assert_const(&p.depth_m, &[1.0e10]);
        assert_const(p.velocity_px.as_ref().unwrap(), &[vx, -vy]);
        assert_eq!((p.display_window, p.data_origin, p.color_nan_count), ((0, 0, W, H), (0, 0), 0));
        let r = &p.channel_report;
        assert!(r.contains("Blender multilayer ViewLayer.Combined"), "{r}");
        assert!(r.contains("ViewLayer.Depth.Z"), "{r}");
        assert!(r.contains("ViewLayer.Vector.Z, ViewLayer.Vector.W") && r.contains("next (-Z, +W)"), "{r}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_headers_alone_say_whether_a_velocity_pass_is_likely() {
        // What velocity_likely reads before the pixels must agree with what the read finds: a
        // Blender multilayer with and without its Vector pass, Nuke's forward vectors in a file
        // of its own channels, a velocity file named, and a file that does not read.
        let dir = test_dir("read-velocity-likely");
        let path = dir.join("passes.exr");
        let colour = [
            ("ViewLayer.Combined.R", 0.5),
            ("ViewLayer.Combined.G", 0.5),
            ("ViewLayer.Combined.B", 0.5),
            ("ViewLayer.Depth.Z", 2.0),
        ];
        write(&path, &colour, true);
        assert!(!velocity_likely(&sources(&path)));
        assert!(load_passes(&sources(&path)).unwrap().velocity_px.is_none());
        let mut with_vector = colour.to_vec();
        with_vector.extend([("ViewLayer.Vector.X", 1.0), ("ViewLayer.Vector.Y", 2.0)]);
        write(&path, &with_vector, true);
        assert!(velocity_likely(&sources(&path)));
        assert!(load_passes(&sources(&path)).unwrap().velocity_px.is_some());
        write(&path, &[("R", 0.5), ("G", 0.5), ("B", 0.5), ("Z", 2.0), ("forward.u", 1.0), ("forward.v", 0.0)], false);
        assert!(velocity_likely(&sources(&path)));
        assert!(load_passes(&sources(&path)).unwrap().velocity_px.is_some());
        let named = PassSources { velocity_path: Some(dir.join("v.exr")), ..sources(&dir.join("c.exr")) };
        assert!(velocity_likely(&named));
        assert!(!velocity_likely(&sources(&dir.join("missing.exr"))));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn view_layers_are_taken_whole_and_said() {
        let dir = test_dir("read-layers");
        let path = dir.join("layers.exr");
        let mut chans = Vec::new();
        for (layer, colour, depth) in [("Alpha", 0.25, 1.0), ("Beta", 0.75, 5.0)] {
            for c in ["R", "G", "B"] {
                chans.push((format!("{layer}.Combined.{c}"), colour));
            }
            chans.push((format!("{layer}.Depth.Z"), depth));
        }
        let chans: Vec<(&str, f32)> = chans.iter().map(|(n, v)| (n.as_str(), *v)).collect();
        write(&path, &chans, true);
        let load = |src: PassSources| load_passes(&src);
        // None asked: the first, said.
        let p = load(sources(&path)).unwrap();
        assert_const(&p.color, &[0.25, 0.25, 0.25, 1.0]);
        assert_const(&p.depth_m, &[1.0]);
        let expected = format!(
            "view layer: Alpha (the first; choose another with a layer option; layers in \"{}\": Alpha, Beta)",
            path.display()
        );
        assert!(p.channel_report.starts_with(&expected), "{}", p.channel_report);
        // The colour override's layer gives the depth too.
        let p = load(PassSources { color_channels: Some("Beta.Combined".into()), ..sources(&path) }).unwrap();
        assert_const(&p.color, &[0.75, 0.75, 0.75, 1.0]);
        assert_const(&p.depth_m, &[5.0]);
        assert!(
            p.channel_report.contains("depth: ") && p.channel_report.contains("Beta.Depth.Z"),
            "{}",
            p.channel_report
        );
        // Asked for.
        let p = load(PassSources { layer: Some("Beta".into()), ..sources(&path) }).unwrap();
        assert_const(&p.depth_m, &[5.0]);
        assert!(p.channel_report.starts_with("view layer: Beta (asked for;"), "{}", p.channel_report);
        // Never mixed, never a layer that is not there.
        let err = load(PassSources {
            layer: Some("Alpha".into()),
            color_channels: Some("Beta.Combined".into()),
            ..sources(&path)
        })
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "layer: \"{}\": the layer Alpha was asked for but the colour override \"Beta.Combined\" is of layer Beta; passes of two layers are never mixed",
                path.display()
            )
        );
        let err = load(PassSources { layer: Some("Gamma".into()), ..sources(&path) }).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!("layer: \"{}\": no view layer Gamma (layers: Alpha, Beta)", path.display())
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn nuke_naming_and_nan_color() {
        let dir = test_dir("read-nuke");
        let path = dir.join("nuke.exr");
        let chans = [("R", f32::NAN), ("G", 0.5), ("B", f32::INFINITY), ("A", 0.5), ("Z", 0.0)];
        write(&path, &chans, true);
        let no_velocity = load_passes(&sources(&path)).unwrap();
        assert!(no_velocity.velocity_px.is_none());
        assert_eq!(no_velocity.color_nan_count, 2 * (W * H) as u64);
        assert_const(&no_velocity.color, &[0.0, 0.5, 0.0, 0.5]);
        assert_const(&no_velocity.depth_m, &[0.0]);
        write(&path, &[&chans[..], &[("forward.u", 3.0), ("forward.v", 2.0)]].concat(), true);
        let p = load_passes(&sources(&path)).unwrap();
        assert_const(p.velocity_px.as_ref().unwrap(), &[3.0, -2.0]);
        assert!(p.channel_report.contains("channels forward.u, forward.v (Nuke forward: px toward the next frame"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn separate_files_units_and_half() {
        let dir = test_dir("read-separate");
        let (c, d, v) = (dir.join("c.exr"), dir.join("d.exr"), dir.join("v.exr"));
        write(&c, &[("beauty.R", 1.0), ("beauty.G", 2.0), ("beauty.B", 3.0)], false);
        write(&d, &[("Y", 250.0)], false);
        write(&v, &[("X", -1.0), ("Y", -1.0), ("Z", -4.0), ("W", 5.0)], true);
        let src = PassSources {
            depth_path: Some(d.clone()),
            velocity_path: Some(v.clone()),
            depth_unit_m: 0.01,
            ..sources(&c)
        };
        let p = load_passes(&src).unwrap();
        assert_const(&p.color, &[1.0, 2.0, 3.0, 1.0]);
        assert_const(&p.depth_m, &[2.5]);
        assert_const(p.velocity_px.as_ref().unwrap(), &[4.0, 5.0]);
        assert!(p.channel_report.contains("the only channel of a one-channel file"));
        // Overrides.
        write(&c, &[("a", 1.0), ("b", 2.0), ("c", 3.0), ("d", 4.0), ("mv.x", 1.0), ("mv.y", 2.0)], false);
        let src = PassSources {
            color_channels: Some("c, b, a".into()),
            depth_channel: Some("d".into()),
            velocity_channels: Some("mv.x,mv.y".into()),
            ..sources(&c)
        };
        let p = load_passes(&src).unwrap();
        assert_const(&p.color, &[3.0, 2.0, 1.0, 1.0]);
        assert_const(&p.depth_m, &[4.0]);
        assert_const(p.velocity_px.as_ref().unwrap(), &[1.0, -2.0]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn multi_part_file_with_offset_data_window() {
        use exr::prelude::*;
        let dir = test_dir("read-multipart");
        let path = dir.join("parts.exr");
        let part = |name: &str, chans: &[&str], v: f32| {
            let list = chans.iter().map(|c| AnyChannel::new(*c, FlatSamples::F32(vec![v; 12]))).collect();
            let mut attrs = LayerAttributes::named(name);
            attrs.layer_position = Vec2(10, -2);
            Layer::new((4, 3), attrs, Encoding::UNCOMPRESSED, AnyChannels::sort(list))
        };
        let layers = vec![part("ViewLayer.Combined", &["R", "G", "B", "A"], 0.5), part("ViewLayer.Depth", &["Z"], 7.0)];
        let bounds = IntegerBounds::new(Vec2(0, 0), Vec2(20, 10));
        Image::from_layers(ImageAttributes::new(bounds), layers).write().to_file(&path).unwrap();
        let p = load_passes(&sources(&path)).unwrap();
        assert_const(&p.color, &[0.5; 4]);
        assert_const(&p.depth_m, &[7.0]);
        assert_eq!((p.display_window, p.data_origin), ((0, 0, 20, 10), (10, -2)));
        assert!(p.channel_report.contains("ViewLayer.Depth.Z"), "{}", p.channel_report);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn error_messages() {
        let dir = test_dir("read-errors");
        let (c, d) = (dir.join("c.exr"), dir.join("d.exr"));
        let err = |src: &PassSources| load_passes(src).unwrap_err().to_string();

        let missing = dir.join("nope.exr");
        assert_eq!(err(&sources(&missing)), format!("color: file \"{}\" does not exist", missing.display()));
        std::fs::write(&d, "not an image").unwrap();
        let msg = err(&sources(&d));
        assert!(msg.contains(&format!("\"{}\" is not an OpenEXR file", d.display())), "{msg}");

        write(&c, &[("R", 1.0), ("G", 1.0), ("B", 1.0)], false);
        let msg = err(&sources(&c));
        assert!(
            msg.starts_with(&format!("depth: no depth channel in \"{}\" (looked for <layer>.Depth.Z, Z,", c.display())),
            "{msg}"
        );
        assert!(msg.ends_with("; channels found: B, G, R"), "{msg}");

        let src = PassSources { color_channels: Some("beauty".into()), ..sources(&c) };
        let msg = err(&src);
        assert!(msg.contains("channel \"beauty.R\" (from the override \"beauty\") not found"), "{msg}");
        assert!(msg.ends_with("channels found: B, G, R"), "{msg}");

        // Size mismatch: color 4x3 px, depth 2x2 px.
        write_exr_channels(&d, 2, 2, &[("Z", &[1.0; 4])], &ExrWriteOptions::default()).unwrap();
        let src = PassSources { depth_path: Some(d.clone()), ..sources(&c) };
        let msg = err(&src);
        assert!(
            msg.contains(&format!(
                "color (channel R) \"{}\" is 4x3 px but depth (channel Z) \"{}\" is 2x2 px",
                c.display(),
                d.display()
            )),
            "{msg}"
        );

        // NaN and negative depth.
        let mut z = vec![1.0; 12];
        z[4 + 2] = f32::NAN; // (x=2, y=1)
        z[2 * 4 + 3] = -1.0; // (x=3, y=2)
        write_exr_channels(&d, 4, 3, &[("Z", &z)], &ExrWriteOptions::default()).unwrap();
        let msg = err(&src);
        assert!(msg.contains(&format!("channel Z in \"{}\" has 2 invalid pixel(s)", d.display())), "{msg}");
        assert!(msg.contains("the first is pixel (x=2, y=1) of the data window with NaN m"), "{msg}");
        z[4 + 2] = 1.0;
        write_exr_channels(&d, 4, 3, &[("Z", &z)], &ExrWriteOptions::default()).unwrap();
        assert!(err(&src).contains("(x=3, y=2) of the data window with -1 m"));

        // Required velocity that is absent.
        let src = PassSources { require_velocity: true, depth_channel: Some("R".into()), ..sources(&c) };
        let msg = err(&src);
        assert!(msg.starts_with(&format!("velocity: no velocity channel in \"{}\"", c.display())), "{msg}");
        assert!(msg.ends_with("channels found: B, G, R"), "{msg}");
        for unit_m in [-1.0, 0.0, f64::NAN] {
            let src = PassSources { depth_unit_m: unit_m, ..sources(&c) };
            let e = load_passes(&src).unwrap_err();
            assert_eq!(e.field(), Some("depth_unit_m"));
            assert_eq!(
                e.to_string(),
                format!("depth_unit_m must be a positive number of metres per depth unit, got {unit_m}")
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn velocity_formats_that_need_a_setting_or_a_choice_say_so() {
        let dir = test_dir("read-velocity-formats");
        let path = dir.join("v.exr");
        let base = [("R", 1.0), ("G", 1.0), ("B", 1.0), ("Z", 2.0)];
        // Arnold's raw vectors span the renderer's shutter: without it, an error naming the file,
        // the channels and the setting; with it, px per frame.
        write(&path, &[&base[..], &[("motion_vector.R", 3.0), ("motion_vector.G", 1.0)]].concat(), true);
        let e = load_passes(&sources(&path)).unwrap_err();
        assert_eq!(e.field(), Some("velocity_interval_frames"));
        assert_eq!(
            e.to_string(),
            format!(
                "velocity: \"{}\" holds Arnold motion vectors (motion_vector.R, motion_vector.G), which span the renderer's shutter interval; the file does not say how long it was; give velocity_interval_frames",
                path.display()
            )
        );
        let src = PassSources { velocity_interval_frames: Some(0.5), ..sources(&path) };
        let p = load_passes(&src).unwrap();
        assert_const(p.velocity_px.as_ref().unwrap(), &[6.0, -2.0]);
        assert_eq!(p.velocity_format, Some(VelocityFormat::Arnold));
        // Scale and flip apply after the format's conversion.
        let src = PassSources { velocity_scale: 2.0, velocity_flip_y: true, ..src };
        assert_const(load_passes(&src).unwrap().velocity_px.as_ref().unwrap(), &[12.0, 4.0]);
        // Two formats' names in one file: auto refuses to guess; a named format reads its own.
        write(
            &path,
            &[&base[..], &[("forward.u", 3.0), ("forward.v", 1.0), ("vel.X", 5.0), ("vel.Y", 5.0)]].concat(),
            true,
        );
        let e = load_passes(&sources(&path)).unwrap_err().to_string();
        assert!(e.contains("formats nuke, revision; choose one with --velocity-format"), "{e}");
        let src = PassSources { velocity_format: VelocityFormat::Revision, ..sources(&path) };
        assert_const(load_passes(&src).unwrap().velocity_px.as_ref().unwrap(), &[5.0, -5.0]);
        // NDC: a frame width of 2 per frame (W = 4 px, H = 3 px).
        let src = PassSources {
            velocity_format: VelocityFormat::Ndc,
            velocity_channels: Some("vel.X,vel.Y".into()),
            ..sources(&path)
        };
        assert_const(load_passes(&src).unwrap().velocity_px.as_ref().unwrap(), &[10.0, -7.5]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The real Blender scene, when this machine has it: multilayer and separate files
    /// must load identically, and the Mover cube (centre at 3.5 m, expected centre motion
    /// (+76.19, -10.16) px/frame) moves at that motion scaled by 3.5 m / depth of the visible
    /// front face.
    #[test]
    fn half_channels_interleave_in_order_across_blocks() {
        // 97 x 61 = 5917 px crosses interleave's block of 4096 px. Each channel holds its own
        // ramp (every value exact in half); R, G, B without A read back in their pixels, in
        // order, with alpha 1; a fourth channel beyond the three stays the fill.
        let (w, h) = (97u32, 61u32);
        let n = (w * h) as usize;
        let ramp = |c: usize| -> Vec<f32> { (0..n).map(|i| ((i * 3 + c) % 2048) as f32 * 0.5).collect() };
        let planes = [ramp(0), ramp(1), ramp(2)];
        let dir = test_dir("read-interleave-blocks");
        let path = dir.join("rgb-half.exr");
        let list: Vec<(&str, &[f32])> = ["R", "G", "B"].into_iter().zip(planes.iter().map(Vec::as_slice)).collect();
        write_exr_channels(&path, w, h, &list, &ExrWriteOptions::default()).unwrap();
        let im = read_exr_rgba(&path).unwrap();
        assert_eq!((im.width, im.height, im.channels), (w, h, 4));
        for (i, px) in im.data.chunks_exact(4).enumerate() {
            assert_eq!(px, [planes[0][i], planes[1][i], planes[2][i], 1.0], "pixel {i}");
        }
    }

    #[test]
    fn blender_scene_a_if_present() {
        let dir = Path::new("/work/shared/data/sceneA");
        if !dir.join("passes.exr").exists() {
            eprintln!("note: {} not present; skipping the Blender scene A check", dir.display());
            return;
        }
        let multi = load_passes(&PassSources { require_velocity: true, ..sources(&dir.join("passes.exr")) }).unwrap();
        let separate = load_passes(&PassSources {
            depth_path: Some(dir.join("depth.exr")),
            velocity_path: Some(dir.join("velocity.exr")),
            ..sources(&dir.join("color.exr"))
        })
        .unwrap();
        eprintln!("{}\n{}", multi.channel_report, separate.channel_report);
        assert_eq!(multi.color, separate.color);
        assert_eq!(multi.depth_m, separate.depth_m);
        assert_eq!(multi.velocity_px, separate.velocity_px);
        let v = multi.velocity_px.unwrap();
        let (dx, dy, z) = (v.get(360, 604, 0), v.get(360, 604, 1), multi.depth_m.get(360, 604, 0));
        eprintln!("Mover at (360, 604): velocity ({dx}, {dy}) px/frame, depth {z} m");
        let scale = 3.5 / z;
        assert!((dx - 76.19 * scale).abs() < 0.5 && (dy + 10.16 * scale).abs() < 0.5, "({dx}, {dy})");
        assert_eq!(v.get(5, 5, 0), 0.0);
        assert_eq!(multi.depth_m.get(5, 5, 0), 1.0e10);
    }

    #[test]
    fn header_attributes_are_read_as_stored_without_the_layouts_and_cryptomatte_only_when_kept() {
        use exr::meta::attribute::{AttributeValue, Text};
        let dir = test_dir("read-header-attributes");
        let path = dir.join("a.exr");
        let t = |s: &str| AttributeValue::Text(Text::from(s));
        let input = vec![
            ("Frame".to_string(), t("7")),
            ("cryptomatte/abc/manifest".into(), t("{}")),
            ("owner".into(), t("studio")),
            ("samples".into(), AttributeValue::I32(64)),
        ];
        let planes = [vec![0.5f32; (W * H) as usize], vec![2.0f32; (W * H) as usize]];
        let list: Vec<(&str, &[f32])> =
            vec![("R", &planes[0]), ("G", &planes[0]), ("B", &planes[0]), ("Z", &planes[1])];
        let opts = ExrWriteOptions { input_attributes: input.clone(), ..Default::default() };
        write_exr_channels(&path, W, H, &list, &opts).unwrap();
        let names = |keep_layers: bool| -> Vec<String> {
            let p = load_passes(&PassSources { keep_layers, ..sources(&path) }).unwrap();
            for (name, value) in &p.header_attributes {
                if let Some((_, v)) = input.iter().find(|(n, _)| n == name) {
                    assert_eq!(value, v, "{name}");
                }
            }
            p.header_attributes.into_iter().map(|(name, _)| name).collect()
        };
        let software = crate::io::exr_write::SOFTWARE;
        assert_eq!(names(true), ["Frame", "cryptomatte/abc/manifest", "owner", "samples", "software"], "{software}");
        assert_eq!(names(false), ["Frame", "owner", "samples", "software"]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
