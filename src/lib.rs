//! realcam: a realistic camera for rendered images.
//!
//! Layers, each using only those above it (docs/architecture.md):
//! - [`optics`]: plain f64 camera math on the CPU (no Vulkan), tested against the source documents.
//! - [`io`]: files: OpenEXR passes, PNG previews, lens files, film files, the lensfun database.
//! - [`model`]: the camera and the frame a render uses.
//! - [`gpu`]: the thin Vulkan runtime; knows no optics.
//! - [`passes`]: one module per compute pass, joining the model and the runtime; the pass order.
//! - [`pipeline`]: the planner (which passes a scene calls for, and why) and the renderer.
//! - [`session`]: the render session (open the GPU once; per frame load, plan, render, write;
//!   sequences and long exposures), the API the command line and the Python package share.
//! - [`flags`]: the flags of `realcam render`, turned into the session's settings.
//! - [`tools`]: benchmark, accuracy report, metrics, synthetic scenes.

pub mod flags;
pub mod gpu;
pub mod io;
pub mod model;
pub mod optics;
pub mod passes;
pub mod pipeline;
pub mod session;
pub mod tools;
