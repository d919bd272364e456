//! The thin Vulkan runtime: instance and device, memory through gpu-allocator, compute pipelines
//! with a persistent pipeline cache, a command recorder with debug labels and per-pass timestamp
//! queries. It knows nothing about optics; `src/passes/` builds on it.

mod context;
pub mod kernel;
mod pipeline;
mod pool;
mod profiler;
mod recorder;
pub mod reflect;
mod resources;
pub mod shaders;

pub use context::{DeviceInfo, Gpu, GpuOptions};
pub use kernel::{
    buffer, declaration, image, Binding, HostData, HostImage, Kernel, Shader, ShaderBindings, SpecializedKernel, Twin,
};
pub use pipeline::ComputePipeline;
pub use pool::POOL_MAX_BYTES;
pub use profiler::{PassTiming, Profile};
pub use recorder::{Bind, Download, Recorder, TwinCheck};
pub use resources::{color_range, GpuBuffer, GpuImage};

use ash::vk;

/// Errors of the Vulkan runtime.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("cannot load the Vulkan loader (libvulkan.so.1): {0}; install libvulkan1 and a driver such as mesa-vulkan-drivers")]
    Loader(String),
    #[error("no Vulkan device found; install a driver (lavapipe: mesa-vulkan-drivers)")]
    NoDevice,
    #[error("no Vulkan device matches {wanted:?}; devices found: {found}")]
    DeviceNotFound { wanted: String, found: String },
    #[error("device {name:?} is unsuitable: {why}")]
    Unsuitable { name: String, why: String },
    #[error("the Khronos validation layer was requested but is not installed (Debian: vulkan-validationlayers)")]
    NoValidationLayer,
    #[error("Vulkan call {call} failed: {result}")]
    Vk { call: &'static str, result: vk::Result },
    #[error("GPU memory allocation for {name:?} failed: {source}")]
    Alloc {
        name: String,
        #[source]
        source: gpu_allocator::AllocationError,
    },
    #[error("invalid SPIR-V for shader {0}")]
    Spirv(&'static str),
    #[error("the GPU memory allocator was already shut down")]
    AllocatorGone,
    #[error("the shader {0} is not in this build")]
    NoShader(String),
    /// A pass's declaration of a shader's bindings or push constants does not match the SPIR-V.
    #[error("shader {shader}: {message}")]
    Interface { shader: &'static str, message: String },
    /// A dispatch bound resources that do not fit the shader's declared bindings.
    #[error("dispatch of shader {shader}: {message}")]
    Binding { shader: &'static str, message: String },
    /// A frame this device cannot hold.
    #[error("a frame of {width}x{height} px does not fit the device {device:?}: {}", too_large(*.width, *.height, *.max_px, *.bytes, *.heap))]
    TooLarge { device: String, width: u32, height: u32, max_px: u32, bytes: u64, heap: u64 },
    /// An image beyond the device's largest (maxImageDimension2D), refused before Vulkan sees it.
    #[error("the image {name:?} of {width}x{height} px does not fit the device {device:?}: its images may be at most {max_px} px on a side")]
    ImageTooLarge { name: String, device: String, width: u32, height: u32, max_px: u32 },
    /// A recording asked for something no earlier step provided (a bug, not bad input).
    #[error("internal error: {0}")]
    Internal(String),
}

pub type GpuResult<T> = Result<T, GpuError>;

/// Why a frame does not fit: the side beyond the device's image size, or the memory.
fn too_large(width: u32, height: u32, max_px: u32, bytes: u64, heap: u64) -> String {
    if width.max(height) > max_px {
        format!("its images may be at most {max_px} px on a side")
    } else {
        format!(
            "it needs about {:.1} GB of GPU memory and the device has {:.1} GB",
            bytes as f64 / 1e9,
            heap as f64 / 1e9
        )
    }
}

/// Attach the name of the failing call to a raw Vulkan result.
pub(crate) trait VkContext<T> {
    fn vk(self, call: &'static str) -> GpuResult<T>;
}

impl<T> VkContext<T> for Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> GpuResult<T> {
        self.map_err(|result| GpuError::Vk { call, result })
    }
}
