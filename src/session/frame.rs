//! One frame: its passes read and planned, rendered on the session's GPU, written.

use super::colour::choose_working_space;
use super::errors::NameFlags;
use super::{RenderSettings, Session};
use crate::io::colour_config::DisplayView;
use crate::io::output::Outputs;
use crate::io::{self, ExrWriteOptions, Image, ScenePasses};
use crate::model::camera::{Camera, InputCamera, ShotCamera};
use crate::model::frame::Frame;
use crate::optics::colour::Chromaticities;
use crate::pipeline::bands::FrameRender;
use crate::pipeline::planner::{self, Plan};
use anyhow::Result;
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One frame rendered, ready to write.
pub struct RenderedFrame {
    pub image: Image,
    /// The PNG preview's image (display-encoded: through the config's view, or the film curve
    /// and the sRGB curve), when a PNG is asked for.
    pub preview: Option<Image>,
    /// The input's other channels (--keep-layers), written beside R, G, B, A.
    pub kept_channels: Vec<(String, Vec<f32>)>,
    /// The colour space of `image`.
    pub working_space: Chromaticities,
    /// The OpenColorIO display and view of the preview, when a config gives one.
    pub display_view: Option<Arc<DisplayView>>,
    pub exr_options: ExrWriteOptions,
    pub profile: crate::gpu::Profile,
}

/// Renders the frame whose passes `settings` name, frame `frame` of `shot`.
pub fn render_image(
    settings: &RenderSettings,
    shot: &ShotCamera,
    frame: Option<i64>,
    session: &mut Session,
) -> Result<RenderedFrame> {
    render_loaded(settings, load_frame(settings, shot, frame)?, session)
}

/// A frame's passes read, in their working colour space, and planned: the work before the GPU,
/// which a sequence does for the next frame while the GPU renders this one.
pub struct LoadedFrame {
    pub frame: Frame,
    /// The frame's camera: the shot's settings at this frame, with the input header's.
    pub camera: Camera,
    /// What the frame's camera settings brought to say (an input header that disagrees).
    pub camera_warnings: Vec<String>,
    pub plan: Plan,
    /// The input's other channels (--keep-layers), written beside R, G, B, A.
    pub kept_channels: Vec<(String, Vec<f32>)>,
    /// The colour input's header attributes, for the output's header
    /// ([`ScenePasses::header_attributes`](crate::io::ScenePasses::header_attributes)).
    pub header_attributes: Vec<(String, exr::meta::attribute::AttributeValue)>,
    channel_report: String,
    space_line: String,
    /// The OpenColorIO display and view of the preview, when a config gives one.
    display_view: Option<Arc<DisplayView>>,
    focal_length_warning: Option<String>,
}

/// Reads the passes `settings` name and plans them as frame `frame` (None: a single frame
/// without a number) of `shot`, whose camera takes the input header's settings where neither a
/// flag nor a key gives them.
pub fn load_frame(settings: &RenderSettings, shot: &ShotCamera, frame: Option<i64>) -> Result<LoadedFrame> {
    load_frame_as(settings, shot, frame, Camera::clone)
}

/// [`load_frame`] with the frame's camera made `adapt(camera)` (a long exposure's frames stop
/// at the sensor).
pub(super) fn load_frame_as(
    settings: &RenderSettings,
    shot: &ShotCamera,
    frame: Option<i64>,
    adapt: impl Fn(&Camera) -> Camera,
) -> Result<LoadedFrame> {
    let passes = io::load_passes(&settings.sources).name_flags()?;
    let input = input_camera(&passes);
    let frame_camera = shot.camera(frame, &input).name_flags()?;
    let mut loaded = plan_frame(settings, &adapt(&frame_camera.camera), passes)?;
    loaded.camera_warnings = frame_camera.warnings;
    Ok(loaded)
}

/// The camera settings the colour file's header carries (OpenEXR's `focus`, `aperture`,
/// `expTime`, `isoSpeed` and the focal length a renderer wrote).
pub fn input_camera(passes: &ScenePasses) -> InputCamera {
    use exr::meta::attribute::AttributeValue;
    let number = |v: &AttributeValue| match v {
        AttributeValue::F32(v) => Some(f64::from(*v)),
        AttributeValue::F64(v) => Some(*v),
        AttributeValue::I32(v) => Some(f64::from(*v)),
        _ => None,
    };
    InputCamera::from_attributes(
        passes.header_attributes.iter().map(|(name, value)| (name.as_str(), number(value))),
        passes.render_focal_length_mm.clone(),
    )
}

/// The frame of loaded `passes` (from files, or the Python package's arrays) in its working
/// colour space, its plan, and whether the lens file was made for another focal length than
/// the render's.
pub fn plan_frame(settings: &RenderSettings, camera: &Camera, mut passes: ScenePasses) -> Result<LoadedFrame> {
    let channel_report = passes.channel_report.clone();
    let kept_channels = std::mem::take(&mut passes.kept_channels);
    let header_attributes = std::mem::take(&mut passes.header_attributes);
    let render_focal_length = passes.render_focal_length_mm.clone();
    let mut frame = Frame::from_passes(passes, camera, settings.depth_kind);
    let wants_view = settings.png.is_some();
    let (space_line, display_view) = choose_working_space(&settings.colour, wants_view, &mut frame)?;
    let plan = if settings.explain { planner::plan(&frame, camera) } else { planner::plan_unexplained(&frame, camera) };
    // The render's focal length: what the input says, else --focal-length's.
    let render_mm = render_focal_length.as_ref().map_or(camera.lens.focal_length_mm, |(mm, _)| *mm);
    let focal_length_warning = camera.focal_length_warning(Some(render_mm)).map(|w| match &render_focal_length {
        Some((_, attribute)) => format!("{w} (its {attribute} attribute)"),
        None => w,
    });
    Ok(LoadedFrame {
        frame,
        camera: camera.clone(),
        camera_warnings: Vec::new(),
        plan,
        kept_channels,
        header_attributes,
        channel_report,
        space_line,
        display_view,
        focal_length_warning,
    })
}

/// Renders the `loaded` frame through its camera on the session's GPU; `--explain` and the
/// warnings are printed here, in frame order.
pub fn render_loaded(settings: &RenderSettings, loaded: LoadedFrame, session: &mut Session) -> Result<RenderedFrame> {
    let LoadedFrame {
        mut frame,
        camera,
        camera_warnings,
        plan,
        kept_channels,
        header_attributes,
        channel_report,
        space_line,
        display_view,
        focal_length_warning,
    } = loaded;
    let report = session.report();
    if settings.explain {
        report.say(&format!("inputs:\n{}", indent(&channel_report)));
        let (_, _, w, h) = frame.display_window;
        report.say(&camera.explain_camera(w, h));
        if let Some(sources) = camera.explain_sources() {
            report.say(&sources);
        }
        let film = match (camera.film_on_output, &display_view) {
            (true, None) => "in the EXR and the PNG (--film-in-exr)",
            (false, None) => "in the PNG preview only; the EXR is scene-referred",
            (true, Some(_)) => "in the EXR (--film-in-exr); the PNG shows the EXR through the config's view",
            (false, Some(_)) => {
                "not used: the PNG preview's tone curve is the config's view; the EXR is scene-referred"
            }
        };
        report.say(&format!("  film curve: {film}"));
        let flare = if camera.flare.enabled {
            "on around the lights bright enough (--no-flare turns it off)"
        } else {
            camera.flare.off_by.reason()
        };
        report.say(&format!("  lens flare: {flare}"));
        report.say(&format!("  {space_line}"));
        if let Some(dv) = &display_view {
            report.say(&format!(
                "  preview: OpenColorIO display {:?}, view {:?} (from {})",
                dv.display, dv.view, dv.space
            ));
        }
        report.say(&plan.explain());
    }
    for warning in &camera_warnings {
        report.say(&format!("warning: {warning}"));
    }
    if let Some(warning) = &focal_length_warning {
        report.say(&format!("warning: {warning}"));
    }
    if let Some(warning) = &plan.coc_clamp_warning {
        let hint =
            if plan.facts.clamp_is_frame_cover { "" } else { "; raise the clamp with --max-coc (none: no clamp)" };
        report.say(&format!("warning: {warning}{hint}"));
    }

    let FrameRender { rendered, bands } =
        session.render(&mut frame, &plan, &|band| planner::plan_band(band, &camera, &plan))?;
    if let (true, Some(bands)) = (settings.explain, &bands) {
        session.report().say(&format!("  in bands: {}", bands.why));
    }
    if settings.profile {
        session.report().say(rendered.profile.table().trim_end_matches('\n'));
        let pixels = frame.width as u64 * frame.height as u64;
        session.report().say(&rendered.profile.memory_line(pixels));
        session.report().say(&super::report::host_peak_line(pixels));
        if let Some(line) = session.take_startup() {
            session.report().say(&line);
        }
    }
    let image = Image { width: frame.width, height: frame.height, channels: 4, data: rendered.rgba };
    let preview = settings.png.as_ref().map(|_| Image {
        data: crate::pipeline::render::preview_rgba(
            &camera,
            &frame.working_space,
            &image.data,
            image.width,
            display_view.as_deref(),
        ),
        ..image.clone()
    });
    let (_, _, w, h) = frame.display_window;
    let attributes = output_attributes(&camera, w, h, &frame.working_space);
    let exr_options = ExrWriteOptions {
        float32: settings.float32,
        display_window: Some(frame.display_window),
        data_origin: frame.data_origin,
        attributes,
        float32_channels: Vec::new(),
        compression: settings.compression,
        // The input's own, beside realcam's (which win a clash; the input's then under
        // input/<name>).
        input_attributes: header_attributes,
    };
    let working_space = frame.working_space;
    Ok(RenderedFrame {
        image,
        preview,
        kept_channels,
        exr_options,
        working_space,
        display_view,
        profile: rendered.profile,
    })
}

/// The output's EXR attributes: the camera's for a `width` x `height` frame, and the colour
/// space the output is in (the input's) as OpenEXR's chromaticities.
pub fn output_attributes(
    camera: &Camera,
    width: u32,
    height: u32,
    space: &Chromaticities,
) -> Vec<(String, io::ExrAttribute)> {
    let mut attributes = camera.attributes(width, height);
    let xy = [space.red, space.green, space.blue, space.white].map(|[x, y]| [x as f32, y as f32]);
    attributes.push(("chromaticities".into(), io::ExrAttribute::Chromaticities(xy)));
    attributes
}

/// Writes `rendered` into the reserved `outputs` that `settings` name; the paths written.
pub fn write_outputs(
    settings: &RenderSettings,
    mut outputs: Outputs,
    rendered: &RenderedFrame,
) -> Result<Vec<PathBuf>> {
    let image = &rendered.image;
    // Every output to its temporary first; renamed together only when all were written.
    let mut channels = io::rgba_planes(image);
    channels.extend(rendered.kept_channels.iter().map(|(name, data)| (name.as_str(), Cow::Borrowed(data.as_slice()))));
    // Kept channels as float32: a depth of 1e10 stays 1e10 (half ends at 65504).
    let exr_options = ExrWriteOptions {
        float32_channels: rendered.kept_channels.iter().map(|(name, _)| name.clone()).collect(),
        ..rendered.exr_options.clone()
    };
    outputs.write_with("output", |file, _| {
        io::write_exr_planes_to_file(file, &settings.output, image.width, image.height, channels, &exr_options)
    })?;
    if let Some(png) = &settings.png {
        outputs.write("png", &io::encode_png(png, rendered.preview.as_ref().unwrap_or(image))?)?;
    }
    if settings.trace.is_some() {
        outputs.write("trace", rendered.profile.chrome_trace_json().as_bytes())?;
    }
    outputs.commit()?;
    Ok(settings.output_paths().into_iter().map(Path::to_path_buf).collect())
}

fn indent(text: &str) -> String {
    text.lines().map(|l| format!("  {l}\n")).collect()
}
