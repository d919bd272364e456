//! A frame ready for the GPU: RGBA color, planar depth in metres, optional velocity, and where
//! the optical centre is.

use crate::io::{DepthKind, ScenePasses};
use crate::model::camera::Camera;

#[derive(Clone, Debug)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// RGBA, row-major, top row first.
    pub color: Vec<f32>,
    /// Planar depth (distance along the view axis) in metres.
    pub depth_m: Vec<f32>,
    /// Motion toward the next frame in pixels (x right, y down), 2 values per pixel.
    pub velocity_px: Option<Vec<f32>>,
    /// Motion toward the previous frame in pixels (x right, y down), 2 values per pixel, when the
    /// pass has it; None: constant velocity (the negated `velocity_px`).
    pub velocity_prev_px: Option<Vec<f32>>,
    /// The convention the velocity was read in.
    pub velocity_format: Option<crate::io::VelocityFormat>,
    /// Optical centre (the display window's centre) in this frame's pixel coordinates.
    pub centre_px: [f64; 2],
    pub display_window: (i32, i32, u32, u32),
    pub data_origin: (i32, i32),
    /// The colour space of `color` (and of the output): the colour file's `chromaticities`,
    /// else Rec.709 (OpenEXR's default); the caller may set another (`--colorspace`).
    pub working_space: crate::optics::colour::Chromaticities,
    /// When this frame is a band of a larger one (banded rendering): where it lies in it.
    pub band: Option<BandPlace>,
}

/// Where a band lies in the frame it was cut from: what a pass whose result depends on the
/// absolute pixel (the film's grain) or on the whole frame (the CoC's safety clamp) reads
/// instead of the band's own rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BandPlace {
    /// The band's first row in the whole frame.
    pub top_px: u32,
    /// The whole frame's height.
    pub full_height_px: u32,
}

impl Frame {
    /// The wavelengths (nm) the red, green and blue channels stand for in the chromatic
    /// effects: the working space's dominant wavelengths
    /// ([`crate::optics::wavelengths::channel_wavelengths_nm`]).
    pub fn channel_wavelengths_nm(&self) -> [f64; 3] {
        crate::optics::wavelengths::channel_wavelengths_nm(&self.working_space)
    }

    /// From loaded passes. Ray-length depth becomes planar depth using the camera's focal length
    /// and pixel pitch (the renderer's pinhole): z = d / sqrt(1 + (r_px * pitch / f)^2).
    pub fn from_passes(passes: ScenePasses, camera: &Camera, depth_kind: DepthKind) -> Frame {
        let (w, h) = (passes.color.width, passes.color.height);
        let (dx, dy, dw, dh) = passes.display_window;
        let centre_px = [
            dx as f64 + dw as f64 / 2.0 - passes.data_origin.0 as f64,
            dy as f64 + dh as f64 / 2.0 - passes.data_origin.1 as f64,
        ];
        let mut depth_m = passes.depth_m.data;
        if depth_kind == DepthKind::Ray {
            let pitch_over_f = camera.pixel_pitch_mm(dw, dh) / camera.lens.focal_length_mm;
            for (i, d) in depth_m.iter_mut().enumerate() {
                let x = (i as u32 % w) as f64 + 0.5 - centre_px[0];
                let y = (i as u32 / w) as f64 + 0.5 - centre_px[1];
                let t2 = (x * x + y * y) * pitch_over_f * pitch_over_f;
                *d = (*d as f64 / (1.0 + t2).sqrt()) as f32;
            }
        }
        Frame {
            width: w,
            height: h,
            color: passes.color.data,
            depth_m,
            velocity_px: passes.velocity_px.map(|v| v.data),
            velocity_prev_px: passes.velocity_prev_px.map(|v| v.data),
            velocity_format: passes.velocity_format,
            centre_px,
            display_window: passes.display_window,
            data_origin: passes.data_origin,
            working_space: passes.chromaticities.unwrap_or(crate::optics::colour::Chromaticities::REC709),
            band: None,
        }
    }

    /// A frame whose display window is the image itself (synthetic scenes, tests).
    pub fn new(width: u32, height: u32, color: Vec<f32>, depth_m: Vec<f32>) -> Frame {
        Frame {
            width,
            height,
            color,
            depth_m,
            velocity_px: None,
            velocity_prev_px: None,
            velocity_format: None,
            centre_px: [width as f64 / 2.0, height as f64 / 2.0],
            display_window: (0, 0, width, height),
            data_origin: (0, 0),
            working_space: crate::optics::colour::Chromaticities::REC709,
            band: None,
        }
    }

    /// This frame with a velocity toward the next frame (px, x right, y down) and, when given,
    /// toward the previous one (synthetic scenes, tests).
    pub fn with_velocity(mut self, next_px: Vec<f32>, prev_px: Option<Vec<f32>>) -> Frame {
        self.velocity_px = Some(next_px);
        self.velocity_prev_px = prev_px;
        self
    }

    /// The velocity as the GPU reads it: per pixel (next x, next y, previous x, previous y), px
    /// per frame, x right, y down; the previous vector is the negated next one when the pass has
    /// none (constant velocity).
    pub fn velocity_rgba(&self) -> Option<Vec<f32>> {
        let next = self.velocity_px.as_ref()?;
        let prev = self.velocity_prev_px.as_ref();
        Some(
            (0..next.len() / 2)
                .flat_map(|i| {
                    let (nx, ny) = (next[2 * i], next[2 * i + 1]);
                    let (px, py) = prev.map_or((-nx + 0.0, -ny + 0.0), |p| (p[2 * i], p[2 * i + 1]));
                    [nx, ny, px, py]
                })
                .collect(),
        )
    }

    /// Distance (px) from the optical centre to the frame's farthest corner (the whole frame's,
    /// for a band).
    pub fn farthest_corner_px(&self) -> f64 {
        let (cx, cy) = (self.centre_px[0], self.centre_px[1] + self.band_top_px() as f64);
        let (w, h) = self.full_size();
        let dx = cx.max(w as f64 - cx);
        let dy = cy.max(h as f64 - cy);
        (dx * dx + dy * dy).sqrt()
    }

    /// Width and height of the display window (what the sensor maps to).
    pub fn display_size(&self) -> (u32, u32) {
        (self.display_window.2, self.display_window.3)
    }

    /// The whole frame's size (px): this frame's, or the frame it is a band of.
    pub fn full_size(&self) -> (u32, u32) {
        (self.width, self.band.map_or(self.height, |b| b.full_height_px))
    }

    /// The band's first row in the whole frame (0 for a whole frame).
    pub fn band_top_px(&self) -> u32 {
        self.band.map_or(0, |b| b.top_px)
    }

    /// This frame's size and settings with `color` and no depth or velocity (banded rendering's
    /// second round, which reads only the colour).
    pub fn with_colour_only(&self, color: Vec<f32>) -> Frame {
        Frame {
            width: self.width,
            height: self.height,
            color,
            depth_m: Vec::new(),
            velocity_px: None,
            velocity_prev_px: None,
            velocity_format: self.velocity_format,
            centre_px: self.centre_px,
            display_window: self.display_window,
            data_origin: self.data_origin,
            working_space: self.working_space,
            band: self.band,
        }
    }

    /// Rows `top..bottom` of this (whole) frame as a frame of their own: the same display window
    /// and optical centre (moved up by `top` rows), the data window's origin moved down.
    pub fn band_rows(&self, top: u32, bottom: u32) -> Frame {
        let (w, full_h) = self.full_size();
        let bottom = bottom.min(self.height);
        let rows =
            |data: &[f32], per_px: usize| data[(top * w) as usize * per_px..(bottom * w) as usize * per_px].to_vec();
        Frame {
            width: w,
            height: bottom - top,
            color: rows(&self.color, 4),
            depth_m: if self.depth_m.is_empty() { Vec::new() } else { rows(&self.depth_m, 1) },
            velocity_px: self.velocity_px.as_deref().map(|v| rows(v, 2)),
            velocity_prev_px: self.velocity_prev_px.as_deref().map(|v| rows(v, 2)),
            velocity_format: self.velocity_format,
            centre_px: [self.centre_px[0], self.centre_px[1] - top as f64],
            display_window: self.display_window,
            data_origin: (self.data_origin.0, self.data_origin.1 + top as i32),
            working_space: self.working_space,
            band: Some(BandPlace { top_px: self.band_top_px() + top, full_height_px: full_h }),
        }
    }
}
