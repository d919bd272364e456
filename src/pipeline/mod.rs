//! From a frame and a camera to an image: the [`planner`] walks the pass order and asks every
//! pass whether the scene calls for it (and why); the [`render::Renderer`] records the passes that
//! run, in order, into one command buffer; a frame larger than the device holds is rendered in
//! [`bands`].

pub mod bands;
pub mod planner;
pub mod render;
