//! NumPy arrays to and from the passes the command line reads from EXR files, checked as the
//! EXR reader checks them: shapes agree, NaN/Inf colour becomes 0 (counted), NaN or negative
//! depth is an error naming the first pixel.

use anyhow::{bail, Result};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use realcam::io::{Image, ScenePasses};

/// `array` as float32: a float32 array as it is, float16 and float64 converted (NumPy's
/// `astype`); any other dtype is refused with its name.
pub fn float32<'py>(what: &str, array: &Bound<'py, PyAny>) -> PyResult<PyReadonlyArrayDyn<'py, f32>> {
    if let Ok(a) = array.extract::<PyReadonlyArrayDyn<'py, f32>>() {
        return Ok(a);
    }
    let dtype = array.getattr("dtype").map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(format!("{what}: a NumPy array is expected, got {}", type_name(array)))
    })?;
    let name: String = dtype.getattr("name")?.extract()?;
    if !["float16", "float64"].contains(&name.as_str()) {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{what}: an array of float32 (or float16, float64, converted) is expected, got {name}"
        )));
    }
    array.call_method1("astype", ("float32",))?.extract()
}

fn type_name(object: &Bound<'_, PyAny>) -> String {
    object.get_type().name().map_or_else(|_| "?".into(), |n| n.to_string())
}

/// An array's values in row-major order, with its shape.
fn values(array: &PyReadonlyArrayDyn<'_, f32>) -> (Vec<usize>, Vec<f32>) {
    let view = array.as_array();
    (view.shape().to_vec(), view.iter().copied().collect())
}

/// `what` as an image of `channels` per pixel, `height` x `width` unless this is the first
/// array (`size` None); `shapes` says what the array may be.
fn image(
    what: &str,
    array: &PyReadonlyArrayDyn<'_, f32>,
    size: Option<(usize, usize)>,
    channels: &[usize],
    shapes: &str,
) -> Result<Image> {
    let (shape, mut data) = values(array);
    let (h, w, c) = match shape[..] {
        [h, w] if channels.contains(&1) => (h, w, 1),
        [h, w, c] if channels.contains(&c) && c > 1 => (h, w, c),
        _ => bail!("{what}: an array of shape {shapes} is expected, got shape {shape:?}"),
    };
    if let Some((height, width)) = size {
        if (h, w) != (height, width) {
            bail!("size mismatch: color is {width}x{height} px but {what} is {w}x{h} px (the arrays must have the same size)");
        }
    }
    if h == 0 || w == 0 || u32::try_from(h).is_err() || u32::try_from(w).is_err() {
        bail!("{what}: an image of {w}x{h} px cannot be rendered");
    }
    if c == 3 {
        // RGB: alpha 1, as for an EXR without an alpha channel.
        data = data.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 1.0]).collect();
    }
    let channels = if c == 3 { 4 } else { c as u32 };
    Ok(Image { width: w as u32, height: h as u32, channels, data })
}

/// The passes of one frame from arrays: `color` H x W x 4 (or 3), `depth` H x W in metres,
/// `velocity` (and `velocity_prev`) H x W x 2 px per frame, x right, y down.
pub fn scene_passes(
    color: &PyReadonlyArrayDyn<'_, f32>,
    depth: &PyReadonlyArrayDyn<'_, f32>,
    velocity: Option<&PyReadonlyArrayDyn<'_, f32>>,
    velocity_prev: Option<&PyReadonlyArrayDyn<'_, f32>>,
    display_window: Option<(i32, i32, u32, u32)>,
    data_origin: (i32, i32),
    channel_report: Option<String>,
) -> Result<ScenePasses> {
    let mut color = image("color", color, None, &[3, 4], "(H, W, 4) or (H, W, 3)")?;
    let (w, h) = (color.width, color.height);
    let size = Some((h as usize, w as usize));
    let depth_m = image("depth", depth, size, &[1], "(H, W)")?;
    let velocity_px = velocity.map(|v| image("velocity", v, size, &[2], "(H, W, 2)")).transpose()?;
    let velocity_prev_px = velocity_prev.map(|v| image("velocity_prev", v, size, &[2], "(H, W, 2)")).transpose()?;
    if velocity_prev_px.is_some() && velocity_px.is_none() {
        bail!("velocity_prev: given without velocity (the motion toward the next frame)");
    }
    let mut color_nan_count = 0u64;
    for v in color.data.iter_mut().filter(|v| !v.is_finite()) {
        *v = 0.0;
        color_nan_count += 1;
    }
    if let Some((i, value_m)) = depth_m.data.iter().copied().enumerate().find(|(_, v)| v.is_nan() || *v < 0.0) {
        let count = depth_m.data.iter().filter(|v| v.is_nan() || **v < 0.0).count();
        bail!(
            "depth: the array has {count} invalid pixel(s) (NaN or negative depth); the first is pixel (x={}, y={}) with {value_m} m",
            i % w as usize,
            i / w as usize
        );
    }
    for v in velocity_px.iter().chain(&velocity_prev_px) {
        if let Some(bad) = v.data.iter().find(|x| !x.is_finite()) {
            bail!("velocity: the array holds {bad}; every vector must be finite (px per frame)");
        }
    }
    let report = channel_report.unwrap_or_else(|| {
        format!(
            "color, depth{}: NumPy arrays of {w}x{h} px{}",
            if velocity_px.is_some() { ", velocity" } else { "" },
            if color_nan_count > 0 {
                format!(", {color_nan_count} NaN/Inf colour value(s) replaced by 0")
            } else {
                String::new()
            }
        )
    });
    Ok(ScenePasses {
        color,
        depth_m,
        velocity_px,
        velocity_prev_px,
        velocity_format: None,
        display_window: display_window.unwrap_or((0, 0, w, h)),
        data_origin,
        channel_report: report,
        color_nan_count,
        // Arrays carry no other layers, no focal length and no colour space of their own: the
        // Camera's colorspace setting (or Rec.709) is the working space.
        kept_channels: Vec::new(),
        render_focal_length_mm: None,
        chromaticities: None,
        header_attributes: Vec::new(),
    })
}

/// An image as an H x W x C (H x W for one channel) float32 array.
pub fn to_numpy(py: Python<'_>, image: Image) -> PyResult<Bound<'_, PyAny>> {
    let (h, w, c) = (image.height as usize, image.width as usize, image.channels as usize);
    let flat = PyArray1::from_vec(py, image.data);
    Ok(match c {
        1 => flat.reshape([h, w])?.into_any(),
        _ => flat.reshape([h, w, c])?.into_any(),
    })
}

/// Loaded passes as the keyword arguments of `Camera.render`.
pub fn passes_dict(py: Python<'_>, passes: ScenePasses) -> PyResult<Bound<'_, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("color", to_numpy(py, passes.color)?)?;
    dict.set_item("depth", to_numpy(py, passes.depth_m)?)?;
    dict.set_item("velocity", passes.velocity_px.map(|v| to_numpy(py, v)).transpose()?)?;
    dict.set_item("velocity_prev", passes.velocity_prev_px.map(|v| to_numpy(py, v)).transpose()?)?;
    dict.set_item("display_window", passes.display_window)?;
    dict.set_item("data_origin", passes.data_origin)?;
    dict.set_item("channel_report", passes.channel_report)?;
    Ok(dict)
}
