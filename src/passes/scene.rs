//! What every pass plans from: the frame, the camera, and the facts several passes share,
//! computed once (the pixel pitch, the depth range, the signed CoC range, longitudinal colour).

use super::dof::coc_push;
use crate::model::camera::{BokehMode, Camera};
use crate::model::frame::Frame;

/// A CoC whose diameter is at most this many pixels is invisible.
pub const VISIBLE_COC_PX: f64 = 1.0;
/// Vignetting weaker than this relative falloff at the corners is invisible.
pub const VISIBLE_FALLOFF: f64 = 1.0e-4;

/// A colour channel with a depth of field of its own (longitudinal colour).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    Red,
    Green,
    Blue,
}

/// The clamp on |CoC| (px) for `camera` on `frame` of pixel pitch `pixel_pitch_mm`: the
/// camera's (`--max-coc`, none by default), and at most twice the frame's diagonal, where a
/// disk centred on any pixel covers the whole frame; larger disks would only size tables and
/// images (the aperture shape, the diffraction kernels) beyond any offset the frame has. That
/// safety limit is the only clamp by default; where it binds the plan says so, with a warning.
pub fn coc_clamp_px(camera: &Camera, pixel_pitch_mm: f64, frame: &Frame) -> f64 {
    camera.max_coc.px(pixel_pitch_mm).min(frame_cover_px(frame))
}

/// Twice the diagonal of the frame's data window (px); of the whole frame for a band, so that
/// every band clamps as the whole frame does.
fn frame_cover_px(frame: &Frame) -> f64 {
    let (w, h) = frame.full_size();
    2.0 * (w as f64).hypot(h as f64)
}

/// The input of every pass's plan.
pub struct PlanInput<'a> {
    pub frame: &'a Frame,
    pub camera: &'a Camera,
    pub facts: SceneFacts,
    /// Whether the plan will be explained (`--explain`): counts that only `--explain` prints
    /// are made then only (the motion blur's edge resolve counts its pixels on the CPU).
    pub explained: bool,
}

/// Facts about the frame under the camera that several passes plan from.
#[derive(Clone, Debug)]
pub struct SceneFacts {
    /// Pixel pitch on the film (mm) for the frame's display window.
    pub pixel_pitch_mm: f64,
    /// Nearest and farthest depth in the frame (m).
    pub depth_range_m: (f32, f32),
    /// Signed CoC range over the frame in pixels: after the user's clamp, with field curvature
    /// (every pixel evaluated) and the longitudinal colour offsets when those are visible.
    pub coc_range_px: (f64, f64),
    /// The same before the clamp (infinite for depth 0).
    pub unclamped_coc_range_px: (f64, f64),
    /// The clamp on |CoC| in pixels of this frame ([`coc_clamp_px`]).
    pub max_coc_px: f64,
    /// The clamp is twice the frame's diagonal, not the camera's (smaller) one.
    pub clamp_is_frame_cover: bool,
    /// The CoC diameter (px) at which the amount model of spherical aberration reaches its
    /// full strength ([`crate::optics::spherical::FULL_STRENGTH_COC_MM`] on the film).
    pub sa_full_strength_coc_px: f64,
    /// Longitudinal colour: the red and blue channels' CoC offsets (px), when the lens has it.
    pub channel_offsets_px: Option<[f64; 2]>,
    /// How far the pixels move while the shutter is open, when the frame has velocities and
    /// motion blur is on.
    pub motion: Option<super::motion::blur::MotionExtent>,
}

impl SceneFacts {
    pub fn new(frame: &Frame, camera: &Camera) -> SceneFacts {
        let (dw, dh) = frame.display_size();
        let pitch_mm = camera.pixel_pitch_mm(dw, dh);
        // The CoC is monotonic in depth, so the nearest and farthest depths bound it.
        let depth_range_m = frame.depth_m.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &d| (lo.min(d), hi.max(d)));
        let max_coc_px = coc_clamp_px(camera, pitch_mm, frame);
        let coc_px = |d_m: f32| camera.coc_mm(d_m as f64 * 1000.0) / pitch_mm;
        let mut coc_range_px =
            if frame.depth_m.is_empty() { (0.0, 0.0) } else { (coc_px(depth_range_m.0), coc_px(depth_range_m.1)) };
        // With field curvature the CoC also depends on the image height: evaluate every pixel
        // with the CoC pass's CPU twin, unclamped.
        if let Some(field_curvature) = &camera.field_curvature {
            let push = coc_push::CocPush {
                max_coc_px: f32::INFINITY,
                ..coc_push::CocPush::for_frame(camera, pitch_mm, frame)
            };
            let table = coc_push::table_data(Some(field_curvature));
            coc_range_px = coc_push::coc_cpu(&frame.depth_m, &push, &table)
                .iter()
                .fold((f64::MAX, f64::MIN), |(lo, hi), &c| (lo.min(c as f64), hi.max(c as f64)));
        }
        // Longitudinal colour shifts the red and blue CoC by constants: an in-focus point gets
        // red and blue disks of those diameters. Visible when one exceeds a pixel.
        let channel_offsets_px = camera.longitudinal_color_coc_px(pitch_mm, frame.channel_wavelengths_nm());
        if let Some([r, b]) = channel_offsets_px.filter(|o| offsets_visible(*o)) {
            coc_range_px = (coc_range_px.0 + r.min(b).min(0.0), coc_range_px.1 + r.max(b).max(0.0));
        }
        let clamp = |c: f64| c.clamp(-max_coc_px, max_coc_px);
        SceneFacts {
            pixel_pitch_mm: pitch_mm,
            depth_range_m,
            coc_range_px: (clamp(coc_range_px.0), clamp(coc_range_px.1)),
            unclamped_coc_range_px: coc_range_px,
            max_coc_px,
            clamp_is_frame_cover: max_coc_px < camera.max_coc.px(pitch_mm),
            sa_full_strength_coc_px: crate::optics::spherical::FULL_STRENGTH_COC_MM / pitch_mm,
            channel_offsets_px,
            motion: match camera.motion.mode {
                crate::model::camera::MotionBlurMode::Off => None,
                _ => super::motion::blur::motion_extent(frame, &camera.motion),
            },
        }
    }

    /// When the clamp changes the picture (some |CoC| beyond it by more than a hundredth of a
    /// pixel), what it does, in words.
    pub fn coc_clamp_note(&self, camera: &Camera) -> Option<String> {
        let (lo, hi) = self.unclamped_coc_range_px;
        if lo.abs().max(hi.abs()) <= self.max_coc_px + 0.01 {
            return None;
        }
        let clamp = if self.clamp_is_frame_cover {
            "twice the frame's diagonal, the safety limit: a disc centred on any pixel covers the frame".to_string()
        } else {
            camera.max_coc.to_string()
        };
        Some(format!(
            "the CoC is clamped to +-{:.2} px ({clamp}): the lens gives {lo:.2} to {hi:.2} px in this frame, so the clamp changes the picture",
            self.max_coc_px
        ))
    }

    /// The largest |CoC| diameter in the frame (px).
    pub fn max_abs_coc_px(&self) -> f64 {
        self.coc_range_px.0.abs().max(self.coc_range_px.1.abs())
    }

    /// Some pixel is defocused by more than a pixel.
    pub fn dof_visible(&self) -> bool {
        self.max_abs_coc_px() > VISIBLE_COC_PX
    }

    /// Longitudinal colour offsets exceed a pixel.
    pub fn channel_offsets_visible(&self) -> bool {
        self.channel_offsets_px.is_some_and(offsets_visible)
    }
}

fn offsets_visible([r, b]: [f64; 2]) -> bool {
    r.abs().max(b.abs()) > VISIBLE_COC_PX
}

impl<'a> PlanInput<'a> {
    pub fn new(frame: &'a Frame, camera: &'a Camera) -> PlanInput<'a> {
        PlanInput { frame, camera, facts: SceneFacts::new(frame, camera), explained: true }
    }

    /// [`PlanInput::new`] for a plan that `--explain` will not print.
    pub fn unexplained(frame: &'a Frame, camera: &'a Camera) -> PlanInput<'a> {
        PlanInput { explained: false, ..PlanInput::new(frame, camera) }
    }

    /// A band of a frame with the whole frame's facts (banded rendering: every band plans from
    /// the whole frame's CoC range and clamp).
    pub fn with_facts(frame: &'a Frame, camera: &'a Camera, facts: SceneFacts) -> PlanInput<'a> {
        PlanInput { frame, camera, facts, explained: false }
    }

    /// The runs of the depth of field: one for all channels, or, when longitudinal colour is
    /// visible (and the method models it), one per channel with its CoC offset (px).
    pub fn dof_runs(&self) -> Vec<(Option<Channel>, f32)> {
        let per_channel = self.facts.dof_visible()
            && self.facts.channel_offsets_visible()
            && self.camera.bokeh != BokehMode::Diffraction;
        match self.facts.channel_offsets_px {
            Some([r, b]) if per_channel => {
                vec![(Some(Channel::Red), r as f32), (Some(Channel::Green), 0.0), (Some(Channel::Blue), b as f32)]
            }
            _ => vec![(None, 0.0)],
        }
    }

    /// The gate of the depth-of-field methods: `None` when `mode` is the method the user chose
    /// and some pixel is defocused by more than a pixel; otherwise the method's decision.
    pub fn dof_method_gate<P>(&self, mode: BokehMode) -> Option<super::Decision<P>> {
        if self.camera.bokeh != mode {
            Some(super::Decision::not_chosen())
        } else if !self.facts.dof_visible() {
            Some(super::Decision::skip("no pixel is defocused by more than a pixel"))
        } else {
            None
        }
    }

    /// The aperture's description in `--explain`.
    pub fn aperture_text(&self) -> String {
        let camera = self.camera;
        if camera.aperture_mask.is_some() {
            "the user's aperture image".to_string()
        } else if camera.aperture.blades >= 3 {
            format!("{}-bladed aperture", camera.aperture.blades)
        } else {
            "circular aperture".into()
        }
    }

    /// The frame's size in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.frame.width, self.frame.height)
    }
}
