//! Motion blur: the fast tiled gather (`blur`, its kernels `tiles`, `neighbor`, `gather`, `still`) and the
//! splat-and-resolve reference (`reference`, its kernels `ref_splat`, `ref_resolve`), both on the
//! shutter and paths of `path`. README.md says what they simulate.

pub mod blur;
pub mod edges;
pub mod gather;
pub mod neighbor;
pub mod path;
pub mod ref_resolve;
pub mod ref_splat;
pub mod reference;
pub mod still;
pub mod tiles;
