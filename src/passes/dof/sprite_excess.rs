//! Tiled depth of field: each highlight sprite's excess taken out of its pixel of the input
//! colour in place (what the composite's exact gathers read), its value as it was saved; and,
//! for the per-channel runs of longitudinal colour, put back after the composite. One
//! invocation per sprite (indirect, as the binning). Shader: glsl/dof/dof_sprite_excess.comp.

use crate::gpu::shaders::dof_tiles::{ARGS_BIN_DISPATCH, SPRITE_WORDS};
use crate::gpu::{GpuResult, HostData, Kernel, Recorder, Shader, Twin};
use crate::passes::barriers::{args_for_indirect, buffer_after_compute_write, update_in_place};
use crate::passes::twin::finite_or_zero;

pub const NAME: &str = "dof_sprite_excess";

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SpriteExcessPush {
    pub sprite_capacity: i32,
    /// 0: take the excess out and save the pixel; 1: put the saved pixel back.
    pub restore: i32,
}

crate::shader_bindings! {
    /// The bindings of glsl/dof/dof_sprite_excess.comp.
    pub struct SpriteExcessBindings {
        color: image(color),
        args: buffer(Args),
        sprites: buffer(Sprites),
        saved: buffer(Saved),
    }
}

/// glsl/dof/dof_sprite_excess.comp: one invocation per sprite (indirect).
pub struct SpriteExcessShader;

impl Shader for SpriteExcessShader {
    const NAME: &'static str = NAME;
    type Bindings<'a> = SpriteExcessBindings<'a>;
    type Push = SpriteExcessPush;
}

impl Twin for SpriteExcessShader {
    fn cpu(pc: &SpriteExcessPush, _groups: [u32; 3], b: &mut [HostData]) {
        let count = crate::passes::twin::sprites_written(b[1].words(), pc.sprite_capacity);
        let sprites = b[2].words()[..count * SPRITE_WORDS as usize].to_vec();
        let mut saved = b[3].words().to_vec();
        let color = b[0].image_mut();
        for (i, s) in sprites.chunks_exact(SPRITE_WORDS as usize).enumerate() {
            let (x, y) = (f32::from_bits(s[0]).floor() as u32, f32::from_bits(s[1]).floor() as u32);
            let texel = color.texel_mut(x, y);
            let keep = &mut saved[4 * i..4 * i + 4];
            if pc.restore != 0 {
                for (t, w) in texel.iter_mut().zip(keep.iter()) {
                    *t = f32::from_bits(*w);
                }
                continue;
            }
            for (w, t) in keep.iter_mut().zip(texel.iter()) {
                *w = t.to_bits();
            }
            let c: [f32; 4] = std::array::from_fn(|k| finite_or_zero(texel[k]));
            for k in 0..3 {
                texel[k] = c[k] - f32::from_bits(s[4 + k]);
            }
            texel[3] = c[3];
        }
        *b[3].words_mut() = saved;
    }
}

/// The size of the saved pixels of `capacity` sprites, in bytes.
pub fn saved_buffer_bytes(capacity: u32) -> u64 {
    capacity.max(1) as u64 * 16
}

/// Record the dispatch: the excess out (`restore` false: after dof_highlights, before the
/// composite) or the saved pixels back (`restore` true: after the composite).
pub fn record(
    kernel: &Kernel<SpriteExcessShader>,
    rec: &mut Recorder,
    b: &SpriteExcessBindings<'_>,
    push: &SpriteExcessPush,
) -> GpuResult<()> {
    rec.begin_pass(if push.restore != 0 { "dof_sprite_restore" } else { NAME });
    // args (the sprite count, this dispatch's size) and sprites: written by dof_highlights (and
    //   args' counters by dof_bin since, for the restore); read as indirect arguments and here.
    // saved: written by the first dispatch, read by the restore (read-after-write); the first
    //   writes this run's own buffer, never touched before in the recording.
    // color: each sprite's pixel is read and rewritten in place. Every earlier read of the
    //   colour must be done first (the copy and small tiles, dof_downsample and dof_highlights
    //   read it as it was; before the restore, the composite read it less the excess), and
    //   every earlier write visible (the upload's copy or the pass before; the excess's).
    rec.buffer_barriers(&[args_for_indirect(b.args), buffer_after_compute_write(b.sprites)]);
    if push.restore != 0 {
        rec.buffer_barriers(&[buffer_after_compute_write(b.saved)]);
    }
    rec.image_barriers(&[update_in_place(b.color)]);
    kernel.dispatch_indirect(rec, b, push, b.args, ARGS_BIN_DISPATCH as u64 * 4)?;
    rec.end_pass();
    Ok(())
}
