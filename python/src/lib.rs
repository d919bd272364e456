//! `import realcam`: the camera of the command line on NumPy arrays.
//!
//! The settings are the flags of `realcam render`, given as keyword arguments
//! (`Camera(fstop=2, focus=3.5, lens="ideal")` is `--fstop=2 --focus=3.5 --lens=ideal`): they are
//! parsed by the command line's own parser (`realcam::flags`) and rendered by the library's
//! render session (`realcam::session`), the one the command line runs, so the defaults, the lens
//! and film files and every error message are the CLI's. A `Camera` keeps its GPU device and
//! pipelines across `render` calls.

mod arrays;

use clap::Parser;
use pyo3::exceptions::{PyException, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use realcam::flags::RenderArgs;
use realcam::model::camera::ShotCamera;
use realcam::session::errors::{error_text, NameFlags};
use realcam::session::{RenderSettings, Session, StderrReport};

pyo3::create_exception!(realcam, RealcamError, PyException, "A realcam error; its message is the command line's.");

/// The flags of `realcam render`, parsed as the command line parses them.
#[derive(Parser)]
#[command(name = "realcam", no_binary_name = true)]
struct Flags {
    #[command(flatten)]
    render: RenderArgs,
}

/// Flags that name files of one frame: the arguments of `render` and `read_passes`, not settings.
const FRAME_FLAGS: [&str; 8] = ["color", "output", "png", "trace", "frame", "frames", "frames_from_env", "chunk_size"];

/// `--name=value` for each keyword argument, by its name: True gives the bare flag, False and
/// None nothing, a list or tuple the flag once per item.
fn flag_words(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, Vec<String>)>> {
    let mut words = Vec::new();
    let Some(kwargs) = kwargs else { return Ok(words) };
    for (key, value) in kwargs.iter() {
        let key: String = key.extract()?;
        if FRAME_FLAGS.contains(&key.as_str()) {
            return Err(PyTypeError::new_err(format!(
                "{key} is not a camera setting: Camera.render takes the arrays, realcam.read_passes the file"
            )));
        }
        let flag = format!("--{}", key.replace('_', "-"));
        let items: Vec<Bound<'_, PyAny>> = if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
            value.try_iter()?.collect::<PyResult<_>>()?
        } else {
            vec![value]
        };
        let mut these = Vec::new();
        for item in items {
            if item.is_none() {
                continue;
            }
            if let Ok(b) = item.downcast::<pyo3::types::PyBool>() {
                if b.is_true() {
                    these.push(flag.clone());
                }
                continue;
            }
            these.push(format!("{flag}={}", item.str()?));
        }
        words.push((key, these));
    }
    Ok(words)
}

/// [`flag_words`] that also takes the file keywords `allowed` (`png` of `render_file`).
fn flag_words_allowing(kwargs: Option<&Bound<'_, PyDict>>, allowed: &[&str]) -> PyResult<Vec<(String, Vec<String>)>> {
    let Some(kwargs) = kwargs else { return Ok(Vec::new()) };
    let files = PyDict::new(kwargs.py());
    let others = PyDict::new(kwargs.py());
    for (key, value) in kwargs.iter() {
        let name: String = key.extract()?;
        if allowed.contains(&name.as_str()) {
            files.set_item(key, value)?
        } else {
            others.set_item(key, value)?
        }
    }
    let mut words = flag_words(Some(&others))?;
    for (key, value) in files.iter() {
        let key: String = key.extract()?;
        words.push((key.clone(), vec![format!("--{key}={}", value.str()?)]));
    }
    Ok(words)
}

/// `settings` with `overrides` in place of the same keywords (a keyword set to None or False
/// removes the setting).
fn merged(settings: &[(String, Vec<String>)], overrides: Vec<(String, Vec<String>)>) -> Vec<(String, Vec<String>)> {
    let mut merged: Vec<(String, Vec<String>)> =
        settings.iter().filter(|(key, _)| !overrides.iter().any(|(k, _)| k == key)).cloned().collect();
    merged.extend(overrides);
    merged
}

/// The words of keyword settings, in order.
fn words(settings: &[(String, Vec<String>)]) -> Vec<String> {
    settings.iter().flat_map(|(_, w)| w.iter().cloned()).collect()
}

/// The render flags of `words`, with the frame's files named by `color` and the output
/// `output` (None: no output is written).
fn parse_flags(color: &str, output: Option<&str>, words: Vec<String>) -> PyResult<RenderArgs> {
    let output = output.unwrap_or("realcam-python.exr");
    let argv = ["--color", color, "--output", output].into_iter().map(String::from).chain(words);
    match Flags::try_parse_from(argv) {
        Ok(flags) => Ok(flags.render),
        // clap's first line (`error: unexpected argument '--fstp' found`), without its usage text.
        Err(e) => {
            let text = e.to_string();
            let first = text.lines().next().unwrap_or_default().trim_start_matches("error: ").to_string();
            Err(PyTypeError::new_err(first))
        }
    }
}

/// An error of the library or the command line's code, as a Python exception with the CLI's text.
fn py_err(e: anyhow::Error) -> PyErr {
    RealcamError::new_err(error_text(&e))
}

/// A camera: the settings of `realcam render` as keyword arguments (`fstop=2`, `focus=3.5`,
/// `lens="lenses/zeiss-planar-50-f1.4.toml"`, `film="linear"`, `no_exposure=True`, ...). It
/// opens the GPU at its first render and keeps the device and pipelines for the next, whatever
/// the settings do between renders (`set`, or a render's own keywords).
#[pyclass(unsendable, module = "realcam")]
struct Camera {
    /// The keyword settings as the command line's words, by keyword.
    words: Vec<(String, Vec<String>)>,
    settings: RenderSettings,
    shot: ShotCamera,
    session: Session,
    gpu_opens: u32,
    plan: Vec<(String, bool, String)>,
    explain: String,
    profile: Vec<(String, f64)>,
}

/// The settings and the shot of the keyword `settings`, for frames read from `color`.
fn settings_and_shot(
    color: &str,
    output: Option<&str>,
    settings: &[(String, Vec<String>)],
) -> PyResult<(RenderSettings, ShotCamera, RenderArgs)> {
    let args = parse_flags(color, output, words(settings))?;
    let shot = args.shot_camera().map_err(py_err)?;
    Ok((args.settings(), shot, args))
}

#[pymethods]
impl Camera {
    #[new]
    #[pyo3(signature = (**kwargs))]
    fn new(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Camera> {
        let words = flag_words(kwargs)?;
        let (settings, shot, _) = settings_and_shot("<arrays>", None, &words)?;
        let session = Session::new(&settings.gpu, std::sync::Arc::new(StderrReport::new(None)));
        Ok(Camera {
            words,
            settings,
            shot,
            session,
            gpu_opens: 0,
            plan: Vec::new(),
            explain: String::new(),
            profile: Vec::new(),
        })
    }

    /// Changes settings for the renders after it (`camera.set(focus=3, fstop=8)`; None removes
    /// one), on the same GPU device and pipelines. The device itself (`device`, `validate`) is
    /// the one the first render opened.
    #[pyo3(signature = (**kwargs))]
    fn set(&mut self, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let words = merged(&self.words, flag_words(kwargs)?);
        let (settings, shot, _) = settings_and_shot("<arrays>", None, &words)?;
        self.words = words;
        self.settings = RenderSettings { gpu: self.settings.gpu.clone(), ..settings };
        self.shot = shot;
        Ok(())
    }

    /// The camera image of one frame: `color` H x W x 4 (or 3) scene-linear RGBA, `depth`
    /// H x W planar depth in metres (`depth_kind="ray"` converts), `velocity` H x W x 2 px per
    /// frame toward the next frame, x right, y down, and optionally `velocity_prev` toward the
    /// previous one (else -velocity); float32, or float16/float64 converted. Returns H x W x 4
    /// float32. `display_window`, `data_origin` and `channel_report` are read_passes' (so that
    /// `camera.render(**realcam.read_passes(path))` renders a file as the command line does).
    /// `frame` is the frame number of a camera file's keys and the grain's seed; other
    /// keywords are settings for this render only (`camera.render(color, depth, focus=3)`).
    /// The GPU works without the GIL: other Python threads run meanwhile.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (color, depth, velocity=None, velocity_prev=None, display_window=None, data_origin=(0, 0), channel_report=None, frame=None, **settings))]
    fn render<'py>(
        &mut self,
        py: Python<'py>,
        color: &Bound<'py, PyAny>,
        depth: &Bound<'py, PyAny>,
        velocity: Option<&Bound<'py, PyAny>>,
        velocity_prev: Option<&Bound<'py, PyAny>>,
        display_window: Option<(i32, i32, u32, u32)>,
        data_origin: (i32, i32),
        channel_report: Option<String>,
        frame: Option<i64>,
        settings: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let color = arrays::float32("color", color)?;
        let depth = arrays::float32("depth", depth)?;
        let velocity = velocity.map(|v| arrays::float32("velocity", v)).transpose()?;
        let velocity_prev = velocity_prev.map(|v| arrays::float32("velocity_prev", v)).transpose()?;
        let passes = arrays::scene_passes(
            &color,
            &depth,
            velocity.as_ref(),
            velocity_prev.as_ref(),
            display_window,
            data_origin,
            channel_report,
        )
        .map_err(py_err)?;
        // This render's own settings, if it has any.
        let overridden = match settings.filter(|s| !s.is_empty()) {
            Some(kwargs) => Some(settings_and_shot("<arrays>", None, &merged(&self.words, flag_words(Some(kwargs))?))?),
            None => None,
        };
        let (render_settings, shot) = match &overridden {
            Some((settings, shot, _)) => (settings, shot),
            None => (&self.settings, &self.shot),
        };
        let camera =
            shot.camera(frame, &realcam::model::camera::InputCamera::default()).name_flags().map_err(py_err)?;
        let planned = realcam::session::plan_frame(render_settings, &camera.camera, passes).map_err(py_err)?;
        self.explain = planned.plan.explain();
        self.plan = planned
            .plan
            .passes
            .iter()
            .filter(|p| p.listed)
            .map(|p| (p.name.to_string(), p.runs(), p.why.clone()))
            .collect();
        let opened_before = self.session.gpu().is_some();
        let session = &mut self.session;
        let rendered = py.allow_threads(|| realcam::session::render_loaded(render_settings, planned, session));
        if !opened_before && self.session.gpu().is_some() {
            self.gpu_opens += 1;
        }
        let rendered = rendered.map_err(py_err)?;
        self.profile = rendered.profile.passes.iter().map(|p| (p.name.clone(), p.gpu_ms)).collect();
        arrays::to_numpy(py, rendered.image)
    }

    /// Renders the EXR `color` (a multilayer file, or with `depth=`, `velocity=` files and the
    /// other reading keywords of `read_passes`) into the EXR `output` as `realcam render` does:
    /// the frame's header settings (`focus`, `aperture`, ...) where the camera has none, the
    /// camera's and the input's attributes in the output's header, written to a temporary file
    /// and renamed, never over an input. `frame` as for `render`; `png=` a preview too. Returns
    /// the paths written.
    #[pyo3(signature = (color, output, frame=None, **read))]
    fn render_file(
        &mut self,
        py: Python<'_>,
        color: &str,
        output: &str,
        frame: Option<i64>,
        read: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Vec<String>> {
        let read_words = flag_words_allowing(read, &["png"])?;
        let (settings, shot, _) = settings_and_shot(color, Some(output), &merged(&self.words, read_words))?;
        let settings = RenderSettings { gpu: self.settings.gpu.clone(), ..settings };
        let session = &mut self.session;
        let opened_before = session.gpu().is_some();
        let written = py.allow_threads(|| -> anyhow::Result<Vec<std::path::PathBuf>> {
            let outputs = settings.outputs()?;
            let loaded = realcam::session::load_frame(&settings, &shot, frame)?;
            let rendered = realcam::session::render_loaded(&settings, loaded, session)?;
            realcam::session::write_outputs(&settings, outputs, &rendered)
        });
        if !opened_before && self.session.gpu().is_some() {
            self.gpu_opens += 1;
        }
        Ok(written.map_err(py_err)?.iter().map(|p| p.display().to_string()).collect())
    }

    /// The passes of the last render: (name, runs, why), as `--explain` lists them.
    #[getter]
    fn plan(&self) -> Vec<(String, bool, String)> {
        self.plan.clone()
    }

    /// The last render's plan as `--explain` prints it.
    #[getter]
    fn explain(&self) -> String {
        self.explain.clone()
    }

    /// GPU milliseconds per pass of the last render (timestamp queries), in order.
    #[getter]
    fn profile(&self) -> Vec<(String, f64)> {
        self.profile.clone()
    }

    /// The Vulkan device, once a render has opened it.
    #[getter]
    fn device(&self) -> Option<String> {
        self.session.gpu().map(|gpu| gpu.info().to_string())
    }

    /// How many times this camera opened a GPU device (1 after any number of renders).
    #[getter]
    fn gpu_opens(&self) -> u32 {
        self.gpu_opens
    }
}

/// The passes of an EXR as `realcam render --color PATH` reads them: a dict with `color`
/// (H x W x 4), `depth` (H x W, metres), `velocity` and `velocity_prev` (H x W x 2, px per frame,
/// x right, y down, or None), `display_window`, `data_origin` and `channel_report`. Keyword
/// arguments are the reading flags of `render` (`depth="d.exr"`, `layer=`, `depth_unit=`,
/// `velocity_format=`, ...).
#[pyfunction]
#[pyo3(signature = (path, **kwargs))]
fn read_passes<'py>(py: Python<'py>, path: &str, kwargs: Option<&Bound<'py, PyDict>>) -> PyResult<Bound<'py, PyDict>> {
    let args = parse_flags(path, None, words(&flag_words(kwargs)?))?;
    let passes = realcam::io::load_passes(&args.settings().sources).name_flags().map_err(py_err)?;
    arrays::passes_dict(py, passes)
}

/// An EXR's RGBA as H x W x 4 float32 (alpha 1 where the file has none), e.g. `realcam render`'s output.
#[pyfunction]
fn read_exr<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyAny>> {
    let image = realcam::io::read_exr_rgba(std::path::Path::new(path)).map_err(|e| py_err(e.into()))?;
    arrays::to_numpy(py, image)
}

#[pymodule]
#[pyo3(name = "realcam")]
fn realcam_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Camera>()?;
    m.add_function(wrap_pyfunction!(read_passes, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add("RealcamError", m.py().get_type::<RealcamError>())?;
    Ok(())
}
