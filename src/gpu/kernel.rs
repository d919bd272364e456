//! A compute shader as the rest of the code sees it: one declaration ([`Shader`]) of its name,
//! its bindings and its push-constant type, from which both the descriptor-set layout and the
//! binding checks of every dispatch come; the declaration is checked against the SPIR-V's own
//! interface when the pipeline is created ([`Kernel::new`]). Every shader also has a CPU twin
//! ([`Twin`]) with one signature: the same work on host copies of its bindings.

use super::reflect::{interface, BindingKind, ShaderInterface};
use super::{shaders, Bind, ComputePipeline, Gpu, GpuBuffer, GpuError, GpuResult, Recorder};
use std::marker::PhantomData;

/// One binding of set 0 as a pass declares it: its name in the GLSL source (a storage image's
/// variable, a buffer's block name) and what it holds. Its position in the declaration is its
/// binding number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    pub name: &'static str,
    pub kind: BindingKind,
}

/// A storage image binding (`image2D` in layout GENERAL).
pub const fn image(name: &'static str) -> Binding {
    Binding { name, kind: BindingKind::StorageImage }
}

/// A storage buffer binding (a std430 `buffer` block).
pub const fn buffer(name: &'static str) -> Binding {
    Binding { name, kind: BindingKind::StorageBuffer }
}

/// The resources one dispatch of a shader binds, by name: a struct made by [`shader_bindings!`]
/// (crate::shader_bindings), whose one declaration gives both the descriptor-set layout
/// ([`ShaderBindings::DECLARATION`]) and the list bound at each dispatch.
pub trait ShaderBindings {
    /// The bindings of set 0 in binding order.
    const DECLARATION: &'static [Binding];
    /// The resources in binding order.
    fn binds(&self) -> Vec<Bind<'_>>;
}

/// Declares the bindings of a shader once, in binding order: `field: image(glsl_name)` for a
/// storage image, `field: buffer(BlockName)` for a storage buffer. Makes a struct of references
/// named by the fields, implementing [`ShaderBindings`].
#[macro_export]
macro_rules! shader_bindings {
    ($(#[$meta:meta])* $vis:vis struct $name:ident { $($(#[$fmeta:meta])* $field:ident: $kind:ident($glsl:ident)),* $(,)? }) => {
        $(#[$meta])*
        $vis struct $name<'a> {
            $($(#[$fmeta])* pub $field: &'a $crate::shader_bindings!(@type $kind),)*
        }
        impl $crate::gpu::ShaderBindings for $name<'_> {
            const DECLARATION: &'static [$crate::gpu::Binding] = &[$($crate::gpu::$kind(stringify!($glsl))),*];
            fn binds(&self) -> Vec<$crate::gpu::Bind<'_>> {
                vec![$($crate::shader_bindings!(@bind $kind, self.$field)),*]
            }
        }
    };
    (@type image) => { $crate::gpu::GpuImage };
    (@type buffer) => { $crate::gpu::GpuBuffer };
    (@bind image, $e:expr) => { $crate::gpu::Bind::Image($e) };
    (@bind buffer, $e:expr) => { $crate::gpu::Bind::Buffer($e) };
}

/// A compute shader `glsl/<effect>/<NAME>.comp`: its bindings and its push constants.
pub trait Shader: 'static {
    const NAME: &'static str;
    /// What one dispatch binds (declared with [`shader_bindings!`](crate::shader_bindings)).
    type Bindings<'a>: ShaderBindings;
    /// The `push_constant` block, byte for byte (`#[repr(C)]`, no padding).
    type Push: bytemuck::Pod;
    /// The name of the shader's variant compiled without subgroup operations (a `// variant`
    /// line in its source: build.rs), for devices that have none; `None` when the shader uses
    /// none. The same bindings, push constants and twin.
    const WITHOUT_SUBGROUP_OPS: Option<&'static str> = None;
}

/// The SPIR-V module shader `S` runs as on `gpu`: its variant without subgroup operations
/// where the device cannot broadcast within a subgroup.
fn module_name<S: Shader>(gpu: &Gpu) -> &'static str {
    match S::WITHOUT_SUBGROUP_OPS {
        Some(plain) if !gpu.subgroup_broadcast() => plain,
        _ => S::NAME,
    }
}

/// The module's SPIR-V, its interface checked against `S`'s declaration.
fn checked_spirv<S: Shader>(name: &'static str) -> GpuResult<&'static [u8]> {
    let spirv = shaders::spirv(name)?;
    let reflected = interface(spirv).map_err(|message| GpuError::Interface { shader: name, message })?;
    check_interface(name, declaration::<S>(), std::mem::size_of::<S::Push>() as u32, &reflected)?;
    Ok(spirv)
}

/// The bindings of shader `S` in binding order.
pub fn declaration<S: Shader>() -> &'static [Binding] {
    <S::Bindings<'static> as ShaderBindings>::DECLARATION
}

/// Host copy of one binding: what a CPU twin reads and writes.
#[derive(Clone, Debug, PartialEq)]
pub enum HostData {
    Image(HostImage),
    /// The buffer's 32-bit words (u32, or f32 through `f32::from_bits`).
    Buffer(Vec<u32>),
}

/// Host copy of an image: `channels` f32 values per texel, rows top first.
#[derive(Clone, Debug, PartialEq)]
pub struct HostImage {
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub texels: Vec<f32>,
}

impl HostImage {
    pub fn new(width: u32, height: u32, channels: u32, texels: Vec<f32>) -> HostImage {
        HostImage { width, height, channels, texels }
    }

    /// Texel (x, y), clamped to the edge.
    pub fn clamped(&self, x: i32, y: i32) -> &[f32] {
        let x = x.clamp(0, self.width as i32 - 1) as usize;
        let y = y.clamp(0, self.height as i32 - 1) as usize;
        let c = self.channels as usize;
        let i = (y * self.width as usize + x) * c;
        &self.texels[i..i + c]
    }

    /// Texel (x, y) for writing.
    pub fn texel_mut(&mut self, x: u32, y: u32) -> &mut [f32] {
        let c = self.channels as usize;
        let i = (y as usize * self.width as usize + x as usize) * c;
        &mut self.texels[i..i + c]
    }
}

impl HostData {
    pub fn image(&self) -> &HostImage {
        match self {
            HostData::Image(i) => i,
            HostData::Buffer(_) => panic!("a twin read a buffer binding as an image"),
        }
    }

    pub fn image_mut(&mut self) -> &mut HostImage {
        match self {
            HostData::Image(i) => i,
            HostData::Buffer(_) => panic!("a twin wrote a buffer binding as an image"),
        }
    }

    pub fn words(&self) -> &[u32] {
        match self {
            HostData::Buffer(w) => w,
            HostData::Image(_) => panic!("a twin read an image binding as a buffer"),
        }
    }

    pub fn words_mut(&mut self) -> &mut Vec<u32> {
        match self {
            HostData::Buffer(w) => w,
            HostData::Image(_) => panic!("a twin wrote an image binding as a buffer"),
        }
    }

    /// A buffer's word `i` as f32.
    pub fn f32_at(&self, i: usize) -> f32 {
        f32::from_bits(self.words()[i])
    }
}

/// The CPU twin of a shader: the same work on host copies of its bindings, the test oracle of
/// the GPU (tests/gpu_twins.rs runs every dispatch of every pass against its twin).
pub trait Twin: Shader {
    /// Run the dispatch of `groups` workgroups on `bindings` (in binding order), updating the
    /// written ones in place. Texels the shader does not write keep their values.
    fn cpu(push: &Self::Push, groups: [u32; 3], bindings: &mut [HostData]);

    /// Largest difference allowed between GPU and twin, relative to max(|twin value|, 1): f32
    /// arithmetic and transcendental functions differ in their last bits between a GPU and the CPU.
    const TOLERANCE: f32 = 1e-4;

    /// Put what the GPU writes in a scheduling-dependent order (atomic appends) into a canonical
    /// order, before the comparison.
    fn canonical(_push: &Self::Push, _bindings: &mut [HostData]) {}
}

/// Why a dispatch did not match its twin: the first binding and element that differ.
pub fn compare_with_twin(
    shader: &str,
    declared: &[Binding],
    gpu: &[HostData],
    cpu: &[HostData],
    tolerance: f32,
) -> Result<(), String> {
    for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        let name = declared.get(i).map_or("?", |b| b.name);
        let (gv, cv): (Vec<f32>, Vec<f32>) = match (g, c) {
            (HostData::Image(g), HostData::Image(c)) => (g.texels.clone(), c.texels.clone()),
            (HostData::Buffer(g), HostData::Buffer(c)) => {
                // Integer words must match exactly; float words within the tolerance. A word is
                // compared as f32 when both sides read as finite floats of ordinary size.
                if g.len() != c.len() {
                    return Err(format!(
                        "{shader} binding {i} ({name}): {} words on the GPU, {} in the twin",
                        g.len(),
                        c.len()
                    ));
                }
                for (k, (&a, &b)) in g.iter().zip(c).enumerate() {
                    let (fa, fb) = (f32::from_bits(a), f32::from_bits(b));
                    let floats = fa.is_finite() && fb.is_finite() && (fa.abs() > 1e-30 || fb.abs() > 1e-30);
                    let same = a == b || (floats && (fa - fb).abs() <= tolerance * fb.abs().max(1.0));
                    if !same {
                        let shown = |w: u32, f: f32| if floats { format!("{f}") } else { format!("{w}") };
                        return Err(format!(
                            "{shader} binding {i} ({name}) word {k}: GPU {}, twin {}",
                            shown(a, fa),
                            shown(b, fb)
                        ));
                    }
                }
                continue;
            }
            _ => return Err(format!("{shader} binding {i} ({name}): the GPU and the twin hold different kinds")),
        };
        if gv.len() != cv.len() {
            return Err(format!("{shader} binding {i} ({name}): sizes differ"));
        }
        for (k, (&a, &b)) in gv.iter().zip(&cv).enumerate() {
            let same = a.to_bits() == b.to_bits() || (a - b).abs() <= tolerance * b.abs().max(1.0);
            if !same {
                let (w, ch) = match g {
                    HostData::Image(img) => (img.width.max(1) as usize, img.channels.max(1) as usize),
                    HostData::Buffer(_) => (1, 1),
                };
                let texel = k / ch;
                return Err(format!(
                    "{shader} binding {i} ({name}) texel ({}, {}) channel {}: GPU {a}, twin {b}",
                    texel % w,
                    texel / w,
                    k % ch
                ));
            }
        }
    }
    Ok(())
}

/// The pipeline of shader `S`, its interface checked against `S`'s declaration.
pub struct Kernel<S: Twin> {
    pipeline: ComputePipeline,
    _shader: PhantomData<S>,
}

impl<S: Twin> Kernel<S> {
    /// Create the pipeline after checking the SPIR-V's bindings and push-constant size against
    /// `S::BINDINGS` and `S::Push`.
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let name = module_name::<S>(gpu);
        let spirv = checked_spirv::<S>(name)?;
        let push_bytes = std::mem::size_of::<S::Push>() as u32;
        let pipeline = ComputePipeline::new(gpu, name, spirv, declaration::<S>(), push_bytes, &[])?;
        Ok(Kernel { pipeline, _shader: PhantomData })
    }

    /// Bind the resources, push the constants and dispatch `groups` workgroups.
    pub fn dispatch(
        &self,
        rec: &mut Recorder,
        bindings: &S::Bindings<'_>,
        push: &S::Push,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        rec.dispatch(&self.pipeline, &bindings.binds(), bytemuck::bytes_of(push), groups, twin_of::<S>())
    }

    /// Like [`Kernel::dispatch`], with the group counts read from `args` at `offset_bytes`.
    pub fn dispatch_indirect(
        &self,
        rec: &mut Recorder,
        bindings: &S::Bindings<'_>,
        push: &S::Push,
        args: &GpuBuffer,
        offset_bytes: u64,
    ) -> GpuResult<()> {
        let binds = bindings.binds();
        rec.dispatch_indirect(&self.pipeline, &binds, bytemuck::bytes_of(push), args, offset_bytes, twin_of::<S>())
    }
}

/// The pipelines of shader `S` specialised by constants (`layout(constant_id = i) const` in the
/// GLSL takes `constants[i]`), each compiled on its first dispatch and kept. A pass uses this
/// where the constants depend on the frame (the lens's aperture paths): the driver then compiles
/// out the paths the constants switch off. On lavapipe that is the difference that matters, as
/// it runs both sides of every branch and every loop body at least once; on a GPU with real
/// branching it saves registers.
pub struct SpecializedKernel<S: Twin> {
    gpu: Gpu,
    /// The SPIR-V module (`S::NAME`, or its variant without subgroup operations).
    module: &'static str,
    variants: std::sync::Mutex<Vec<(Vec<u32>, std::sync::Arc<ComputePipeline>)>>,
    _shader: PhantomData<S>,
}

impl<S: Twin> SpecializedKernel<S> {
    /// Check the SPIR-V's interface against `S` now; pipelines come with the first dispatch of
    /// each set of constants.
    pub fn new(gpu: &Gpu) -> GpuResult<Self> {
        let module = module_name::<S>(gpu);
        checked_spirv::<S>(module)?;
        Ok(SpecializedKernel { gpu: gpu.clone(), module, variants: Default::default(), _shader: PhantomData })
    }

    fn pipeline(&self, constants: &[u32]) -> GpuResult<std::sync::Arc<ComputePipeline>> {
        // A poisoned lock only means another thread panicked while holding it; the list of
        // finished pipelines is still valid.
        let mut variants = self.variants.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, p)) = variants.iter().find(|(c, _)| c == constants) {
            return Ok(p.clone());
        }
        let push_bytes = std::mem::size_of::<S::Push>() as u32;
        let spirv = shaders::spirv(self.module)?;
        let p = std::sync::Arc::new(ComputePipeline::new(
            &self.gpu,
            self.module,
            spirv,
            declaration::<S>(),
            push_bytes,
            constants,
        )?);
        variants.push((constants.to_vec(), p.clone()));
        Ok(p)
    }

    /// Compile the pipeline of `constants` now (a pass's `prepare`), not at its first dispatch.
    pub fn prepare(&self, constants: &[u32]) -> GpuResult<()> {
        self.pipeline(constants).map(|_| ())
    }

    /// [`Kernel::dispatch_indirect`] with the pipeline of `constants`.
    pub fn dispatch_indirect(
        &self,
        rec: &mut Recorder,
        constants: &[u32],
        bindings: &S::Bindings<'_>,
        push: &S::Push,
        args: &GpuBuffer,
        offset_bytes: u64,
    ) -> GpuResult<()> {
        let pipeline = self.pipeline(constants)?;
        let binds = bindings.binds();
        rec.dispatch_indirect(&pipeline, &binds, bytemuck::bytes_of(push), args, offset_bytes, twin_of::<S>())
    }

    /// [`Kernel::dispatch`] with the pipeline of `constants`.
    pub fn dispatch(
        &self,
        rec: &mut Recorder,
        constants: &[u32],
        bindings: &S::Bindings<'_>,
        push: &S::Push,
        groups: [u32; 3],
    ) -> GpuResult<()> {
        let pipeline = self.pipeline(constants)?;
        rec.dispatch(&pipeline, &bindings.binds(), bytemuck::bytes_of(push), groups, twin_of::<S>())
    }
}

/// A shader's twin with its push constants as bytes, for the recorder's twin check.
pub struct TwinFn {
    pub run: fn(push: &[u8], groups: [u32; 3], bindings: &mut [HostData]),
    pub canonical: fn(push: &[u8], bindings: &mut [HostData]),
    pub tolerance: f32,
}

fn twin_of<S: Twin>() -> TwinFn {
    TwinFn {
        run: |push, groups, bindings| S::cpu(bytemuck::from_bytes(push), groups, bindings),
        canonical: |push, bindings| S::canonical(bytemuck::from_bytes(push), bindings),
        tolerance: S::TOLERANCE,
    }
}

/// The declaration against the shader's interface: the same bindings in the same order, of the
/// same kinds and names, and a push-constant type as large as the shader's block.
pub fn check_interface(
    shader: &'static str,
    declared: &[Binding],
    push_bytes: u32,
    reflected: &ShaderInterface,
) -> GpuResult<()> {
    let fail = |message: String| Err(GpuError::Interface { shader, message });
    for r in &reflected.bindings {
        if r.set != 0 {
            return fail(format!(
                "binding {} ({}) is in descriptor set {}; only set 0 is used",
                r.binding, r.name, r.set
            ));
        }
        match declared.get(r.binding as usize) {
            None => {
                return fail(format!(
                    "the shader has binding {} ({}, {}), which the pass does not declare ({} declared)",
                    r.binding,
                    r.name,
                    r.kind,
                    declared.len()
                ))
            }
            Some(d) if d.kind != r.kind || d.name != r.name => {
                return fail(format!(
                    "binding {} is {} named {:?} in the shader but {} named {:?} in the pass",
                    r.binding, r.kind, r.name, d.kind, d.name
                ))
            }
            Some(_) => {}
        }
    }
    for (i, d) in declared.iter().enumerate() {
        if !reflected.bindings.iter().any(|r| r.binding == i as u32) {
            return fail(format!(
                "the pass declares binding {i} ({}, {}), which the shader does not use",
                d.name, d.kind
            ));
        }
    }
    if push_bytes != reflected.push_constant_bytes {
        return fail(format!(
            "the push constants are {push_bytes} bytes in the pass but {} bytes in the shader",
            reflected.push_constant_bytes
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// glsl/dof/coc_edges.comp: images and buffers.
    fn coc_edges_interface() -> ShaderInterface {
        interface(shaders::spirv("coc_edges").unwrap()).unwrap()
    }

    /// The bindings of glsl/dof/coc_edges.comp as its pass declares them.
    fn coc_edges_declared() -> [Binding; 6] {
        [
            image("depth_m"),
            image("coc_px"),
            buffer("FieldCurvature"),
            image("color_in"),
            buffer("Args"),
            buffer("EdgePixels"),
        ]
    }

    #[test]
    fn a_declaration_that_matches_the_shader_passes() {
        check_interface("coc_edges", &coc_edges_declared(), 60, &coc_edges_interface()).unwrap();
    }

    #[test]
    fn a_mismatch_is_an_error_naming_the_shader_and_the_binding() {
        let error = |declared: &[Binding], push: u32| {
            check_interface("coc_edges", declared, push, &coc_edges_interface()).unwrap_err().to_string()
        };
        let all = coc_edges_declared();
        // Swapped bindings.
        let mut swapped = all;
        swapped.swap(0, 1);
        assert_eq!(
            error(&swapped, 60),
            "shader coc_edges: binding 0 is a storage image named \"depth_m\" in the shader but a storage image named \"coc_px\" in the pass"
        );
        // An image declared where the shader has a buffer.
        let mut wrong_kind = all;
        wrong_kind[2] = image("FieldCurvature");
        let kind = error(&wrong_kind, 60);
        assert!(
            kind.contains("binding 2 is a storage buffer named \"FieldCurvature\" in the shader but a storage image"),
            "{kind}"
        );
        // A binding the pass forgot, one it invented, a push-constant struct of the wrong size.
        assert!(error(&all[..5], 60).contains("the shader has binding 5 (EdgePixels"));
        let extra = error(&[&all[..], &[image("x")]].concat(), 60);
        assert!(extra.contains("declares binding 6 (x"), "{extra}");
        let push = error(&all, 56);
        assert_eq!(push, "shader coc_edges: the push constants are 56 bytes in the pass but 60 bytes in the shader");
    }

    #[test]
    fn the_twin_comparison_names_the_first_differing_texel() {
        let image = |v: f32| HostData::Image(HostImage::new(2, 2, 1, vec![1.0, 2.0, 3.0, v]));
        let declared = [super::image("out")];
        assert!(compare_with_twin("x", &declared, &[image(4.0)], &[image(4.00001)], 1e-4).is_ok());
        let e = compare_with_twin("x", &declared, &[image(4.0)], &[image(5.0)], 1e-4).unwrap_err();
        assert_eq!(e, "x binding 0 (out) texel (1, 1) channel 0: GPU 4, twin 5");
        let words = |w: u32| HostData::Buffer(vec![7, w]);
        let e = compare_with_twin("x", &[buffer("B")], &[words(3)], &[words(4)], 1e-4).unwrap_err();
        assert_eq!(e, "x binding 0 (B) word 1: GPU 3, twin 4");
    }
}
