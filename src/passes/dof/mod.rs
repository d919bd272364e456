//! Depth of field: the signed CoC, then one of the bokeh methods (`--bokeh`): the plain gather,
//! the tiled path and its kernels, or the diffraction focus processor. README.md says what each
//! simulates and where its equations come from.

pub mod aperture;
pub mod bin;
pub mod bin_order;
pub mod bokeh_gather;
pub mod classify;
pub mod coc;
pub mod coc_edges;
pub mod coc_push;
pub mod composite;
pub mod diffraction;
pub mod downsample;
pub mod highlights;
pub mod level_gather;
pub mod level_lists;
pub mod pyramid;
pub mod sprite_excess;
pub mod sprites;
pub mod tile_gather;
pub mod tiled;
pub mod tiles;
