//! The camera model a render uses, independent of the GPU: the [`camera::Camera`] (lens,
//! aperture, sensor, shutter, ISO, film) built from a lens file and the user's settings, the
//! [`aperture`] (iris or aperture image), and the [`frame::Frame`] of passes ready to render.

pub mod aperture;
pub mod camera;
pub mod frame;
