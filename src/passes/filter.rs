//! The shape of the passes that filter the colour into a new colour through one shader reading
//! a table: `color_in`, `color_out` and a buffer `Table` (distortion, astigmatism, coma,
//! vignette, film). Their modules declare the shader and its twin and plan; the recording and
//! its barriers are written here once.

use super::barriers::{after_compute_write, overwrite};
use super::{groups_for, FrameImages};
use crate::gpu::{GpuImage, GpuResult, Kernel, Recorder, Shader, SpecializedKernel, Twin};
use std::sync::Arc;

/// A filter shader: a twin whose bindings are [`FilterBindings`].
pub trait FilterShader: Twin + for<'a> Shader<Bindings<'a> = FilterBindings<'a>> {}

impl<S: Twin + for<'a> Shader<Bindings<'a> = FilterBindings<'a>>> FilterShader for S {}

/// A filter's pipeline for one run: its kernel, or its specialised kernel with the run's
/// constants (a filter whose paths are switched per run, e.g. film's response and noise).
pub trait FilterKernel<S: FilterShader> {
    fn dispatch(
        &self,
        rec: &mut Recorder,
        bindings: &FilterBindings<'_>,
        push: &S::Push,
        groups: [u32; 3],
    ) -> GpuResult<()>;
}

impl<S: FilterShader> FilterKernel<S> for Kernel<S> {
    fn dispatch(
        &self,
        rec: &mut Recorder,
        bindings: &FilterBindings<'_>,
        push: &S::Push,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        Kernel::dispatch(self, rec, bindings, push, groups)
    }
}

impl<S: FilterShader> FilterKernel<S> for (&SpecializedKernel<S>, &[u32]) {
    fn dispatch(
        &self,
        rec: &mut Recorder,
        bindings: &FilterBindings<'_>,
        push: &S::Push,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        self.0.dispatch(rec, self.1, bindings, push, groups)
    }
}

crate::shader_bindings! {
    /// The bindings of a filter shader.
    pub struct FilterBindings {
        color_in: image(color_in),
        color_out: image(color_out),
        table: buffer(Table),
    }
}

/// Record one filter pass named `label`: the table uploaded, the colour filtered into a new
/// image (`color (<label>)`), which becomes the colour.
pub fn record<S>(
    kernel: &impl FilterKernel<S>,
    rec: &mut Recorder,
    images: &mut FrameImages,
    label: &str,
    table: &[f32],
    push: &S::Push,
) -> GpuResult<()>
where
    S: FilterShader,
{
    rec.begin_pass(label);
    // The table: `Recorder::upload_buffer` records its copy -> compute-read barrier.
    let table = rec.upload_buffer(&format!("{label} table"), table)?;
    let output = dispatch(kernel, rec, images.color(), &table, push, &format!("color ({label})"))?;
    rec.end_pass();
    images.set_color(None, output);
    Ok(())
}

/// One dispatch of a filter from `input` into a new image `output_name`, returned.
pub fn dispatch<S>(
    kernel: &impl FilterKernel<S>,
    rec: &mut Recorder,
    input: &GpuImage,
    table: &crate::gpu::GpuBuffer,
    push: &S::Push,
    output_name: &str,
) -> GpuResult<Arc<GpuImage>>
where
    S: FilterShader,
{
    let output = rec.create_image(output_name, input.width, input.height, input.format)?;
    // input: written by the previous compute pass (or by the upload, whose own barrier made it
    //   visible to compute reads; the extra dependency is then free). A filter may read it
    //   anywhere around a pixel, so all of it must be written and visible.
    // output: written from scratch; its old contents are discarded.
    rec.image_barriers(&[after_compute_write(input), overwrite(&output)]);
    let bindings = FilterBindings { color_in: input, color_out: &output, table };
    kernel.dispatch(rec, &bindings, push, groups_for(input.width, input.height))?;
    Ok(output)
}
