//! realcam: a realistic camera for rendered images.
//!
//! Layers (see README.md, "Architecture"):
//! - [`optics`]: plain f64 camera math on the CPU (no Vulkan), tested against the source documents.
//! - [`io`]: OpenEXR and PNG input/output.
//! - [`gpu`]: the thin Vulkan runtime; knows no optics.
//! - [`passes`]: one module per compute pass, joining optics and the runtime.
//! - [`planner`]: decides which passes a scene and camera call for.

pub mod accuracy;
pub mod aperture_mask;
pub mod bench;
pub mod camera;
pub mod film_file;
pub mod focus_processor;
pub mod gpu;
pub mod io;
pub mod lens_file;
pub mod lensfun;
pub mod metrics;
pub mod optics;
pub mod passes;
pub mod planner;
pub mod render;
pub mod scene;
pub mod synth;
