//! The camera model a render uses, independent of the GPU: the [`camera::Camera`] (lens,
//! aperture, sensor, shutter, ISO, film) built from a lens file and the user's settings, the
//! [`aperture`] (iris or aperture image), the [`frame::Frame`] of passes ready to render, and
//! the [`settings`] written as text (shutter times, image sizes).

pub mod aperture;
pub mod camera;
pub mod flare;
pub mod frame;
pub mod long_exposure;
pub mod settings;
