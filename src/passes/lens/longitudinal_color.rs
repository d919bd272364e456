//! Longitudinal (axial) chromatic aberration: red and blue focus in front of or behind green, so
//! each channel has its own signed CoC, shifted by a constant (Camera::longitudinal_color_coc_px).
//! The renderer runs the CoC pass and the depth-of-field method once per channel; this pass
//! (glsl/lens/longitudinal_color.comp) joins the three runs. It costs three depth-of-field runs:
//! the planner records it only for lenses with a longitudinal-colour entry whose offset is
//! visible.

use crate::gpu::{Gpu, GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::model::camera::BokehMode;
use crate::passes::barriers::{after_compute_write, overwrite};
use crate::passes::scene::{Channel, PlanInput, VISIBLE_COC_PX};
use crate::passes::{groups_for, Decision, FrameImages, Pass};

pub const NAME: &str = "longitudinal_color";

/// CPU twin: red of `red`, green and alpha of `green`, blue of `blue` (RGBA rows).
pub fn join_cpu(red: &[f32], green: &[f32], blue: &[f32]) -> Vec<f32> {
    let mut out = green.to_vec();
    for (i, px) in out.chunks_exact_mut(4).enumerate() {
        px[0] = red[4 * i];
        px[2] = blue[4 * i + 2];
    }
    out
}

crate::shader_bindings! {
    /// The bindings of glsl/lens/longitudinal_color.comp.
    pub struct JoinBindings {
        red_run: image(red_run),
        green_run: image(green_run),
        blue_run: image(blue_run),
        color_out: image(color_out),
    }
}

/// glsl/lens/longitudinal_color.comp; its push constants are the image size.
pub struct JoinShader;

impl Shader for JoinShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = JoinBindings<'a>;
    type Push = [i32; 2];
}

impl Twin for JoinShader {
    fn cpu(_size: &[i32; 2], _groups: [u32; 3], b: &mut [HostData]) {
        let joined = join_cpu(&b[0].image().texels, &b[1].image().texels, &b[2].image().texels);
        b[3].image_mut().texels = joined;
    }
}

/// Joins the per-channel depth-of-field runs.
pub struct LongitudinalColor {
    kernel: Kernel<JoinShader>,
}

impl Pass for LongitudinalColor {
    const NAME: &'static str = NAME;
    /// The image size.
    type Params = [i32; 2];

    fn plan(input: &PlanInput<'_>) -> Decision<[i32; 2]> {
        let (camera, f) = (input.camera, &input.facts);
        let nm = input.frame.channel_wavelengths_nm();
        let (Some([red_mm, blue_mm]), Some([r, b])) = (camera.longitudinal_color_mm_at(nm), f.channel_offsets_px)
        else {
            return Decision::skip("the lens file has no longitudinal_color");
        };
        let shifts = format!(
            "red focuses {red_mm:+.4} mm and blue {blue_mm:+.4} mm from green (at {:.0}/{:.0}/{:.0} nm): CoC \
             offsets {r:+.2} / {b:+.2} px",
            nm[0], nm[1], nm[2]
        );
        if !f.channel_offsets_visible() {
            Decision::skip(format!("{shifts}, at most {VISIBLE_COC_PX} px: invisible"))
        } else if camera.bokeh == BokehMode::Diffraction {
            Decision::skip(format!("{shifts}; the focus processor does not model it"))
        } else {
            let (w, h) = input.size();
            Decision::run(
                [w as i32, h as i32],
                format!("{shifts}: the depth of field runs once per channel (3x its cost)"),
            )
        }
    }

    fn new(gpu: &Gpu) -> GpuResult<Self> {
        Ok(LongitudinalColor { kernel: Kernel::new(gpu)? })
    }

    fn record(&self, rec: &mut Recorder, images: &mut FrameImages, size: &[i32; 2]) -> GpuResult<()> {
        rec.begin_pass(NAME);
        let runs = [Channel::Red, Channel::Green, Channel::Blue].map(|c| images.channel_color(c).cloned());
        let [red, green, blue] = runs;
        let (red, green, blue) = (red?, green?, blue?);
        let output = rec.create_image("color (depth of field)", images.width, images.height, red.format)?;
        // The three runs were written by the depth-of-field passes before; the output is
        // written from scratch.
        rec.image_barriers(&[
            after_compute_write(&red),
            after_compute_write(&green),
            after_compute_write(&blue),
            overwrite(&output),
        ]);
        let bindings = JoinBindings { red_run: &red, green_run: &green, blue_run: &blue, color_out: &output };
        self.kernel.dispatch(rec, &bindings, size, groups_for(output.width, output.height))?;
        rec.end_pass();
        images.set_color(None, output);
        Ok(())
    }
}
