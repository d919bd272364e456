//! The bare pass: reads the frame's colour and writes it to a new image, nothing else
//! (glsl/copy.comp). `realcam bench` times it in the same run as the other passes and gives
//! every figure as a multiple of it, so the numbers carry over between devices. In a render it
//! is the flare's output where the frame holds no light (an indirect dispatch of every tile or
//! none, src/passes/flare/ghost_sprites.rs).

use super::barriers::{after_compute_write, overwrite};
use super::{groups_for, FrameImages, TILE_SIZE};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};

pub const NAME: &str = "copy";

crate::shader_bindings! {
    /// The bindings of glsl/copy.comp.
    pub struct CopyBindings {
        color_in: image(color_in),
        color_out: image(color_out),
    }
}

/// glsl/copy.comp; its push constants are the image size.
pub struct CopyShader;

impl Shader for CopyShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = CopyBindings<'a>;
    type Push = [i32; 2];
}

impl Twin for CopyShader {
    /// The texels of the dispatched groups (an indirect dispatch may have none).
    fn cpu(size: &[i32; 2], groups: [u32; 3], b: &mut [HostData]) {
        let input = b[0].image().clone();
        let w = (groups[0] * TILE_SIZE).min(size[0].max(0) as u32);
        let h = (groups[1] * TILE_SIZE).min(size[1].max(0) as u32);
        let out = b[1].image_mut();
        let c = input.channels as usize;
        for y in 0..h {
            for x in 0..w {
                out.texel_mut(x, y).copy_from_slice(&input.texels[(y * input.width + x) as usize * c..][..c]);
            }
        }
    }

    /// A copy is exact.
    const TOLERANCE: f32 = 0.0;
}

/// Record the bare pass: the colour copied into a new image, which becomes the colour.
pub fn record(kernel: &Kernel<CopyShader>, rec: &mut Recorder, images: &mut FrameImages) -> GpuResult<()> {
    rec.begin_pass(NAME);
    let input = images.color().clone();
    let output = rec.create_image("color (copy)", input.width, input.height, input.format)?;
    // input: written by the upload (its own barrier made it visible to compute reads) or by an
    //   earlier compute pass: wait for those writes. output: written from scratch.
    rec.image_barriers(&[after_compute_write(&input), overwrite(&output)]);
    let size = [input.width as i32, input.height as i32];
    let bindings = CopyBindings { color_in: &input, color_out: &output };
    kernel.dispatch(rec, &bindings, &size, groups_for(input.width, input.height))?;
    rec.end_pass();
    images.set_color(None, output);
    Ok(())
}
