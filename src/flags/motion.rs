//! The motion-blur flags of `render` (and `accuracy`, `compare`'s renders): how the velocity pass
//! is read, the frame rate, and the shutter in time.

use crate::io::{PassSources, VelocityFormat};
use crate::model::camera::{CameraRequest, MotionBlurMode};
use crate::optics::shutter::{RollingDirection, ShutterCurve, ShutterPosition};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};

#[derive(Clone, Copy, ValueEnum)]
pub enum VelocityFormatArg {
    /// From the channel names (an error when several formats' names are present).
    Auto,
    /// Blender/Cycles Vector X,Y,Z,W: px per frame, y up; X,Y toward the previous frame, Z,W from the next.
    Blender,
    /// Nuke forward.u,v (+ backward.u,v) or motion.u,v: px toward the next (previous) frame, y up.
    Nuke,
    /// Arnold raw motion_vector R,G: px over the renderer's shutter interval (--velocity-interval), y up.
    Arnold,
    /// V-Ray velocity: px from the current to the next frame, y up.
    Vray,
    /// RE:Vision-style single vector: px per frame, forward, +y up.
    Revision,
    /// Normalised device coordinates: a frame width of 2 per frame, forward, y up.
    Ndc,
}

impl From<VelocityFormatArg> for VelocityFormat {
    fn from(f: VelocityFormatArg) -> VelocityFormat {
        match f {
            VelocityFormatArg::Auto => VelocityFormat::Auto,
            VelocityFormatArg::Blender => VelocityFormat::Blender,
            VelocityFormatArg::Nuke => VelocityFormat::Nuke,
            VelocityFormatArg::Arnold => VelocityFormat::Arnold,
            VelocityFormatArg::Vray => VelocityFormat::Vray,
            VelocityFormatArg::Revision => VelocityFormat::Revision,
            VelocityFormatArg::Ndc => VelocityFormat::Ndc,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum ShutterPositionArg {
    /// Open from half the shutter before the frame time to half after.
    Centred,
    /// Open at the frame time.
    Start,
    /// Closes at the frame time.
    End,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum RollingDirectionArg {
    /// Rows top to bottom.
    Down,
    Up,
    /// Columns left to right.
    Right,
    Left,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum MotionBlurArg {
    /// Tiled reconstruction gather: fixed sample count, cost flat in the blur length.
    Fast,
    /// Every pixel scattered along its path at many sub-frame times (slow accuracy reference).
    Reference,
    /// No motion blur.
    Off,
}

#[derive(Args, Clone)]
pub struct MotionArgs {
    /// How to read the velocity pass.
    #[arg(long = "velocity-format", value_enum, default_value = "auto")]
    velocity_format: VelocityFormatArg,
    /// Multiply the velocity by this after its format's conversion.
    #[arg(long = "velocity-scale", default_value_t = 1.0, allow_negative_numbers = true)]
    velocity_scale: f64,
    /// Flip the velocity's y after its format's conversion.
    #[arg(long = "velocity-flip-y")]
    velocity_flip_y: bool,
    /// Frames the vectors span, for Arnold's raw motion vectors (the renderer's shutter length).
    #[arg(long = "velocity-interval", value_name = "FRAMES")]
    velocity_interval_frames: Option<f64>,
    /// Frames per second of the sequence (turns px per frame into px while the shutter is open); default 24.
    #[arg(long)]
    fps: Option<f64>,
    /// The shutter as an angle in degrees (180 = half a frame) instead of --shutter; the exposure
    /// uses the time it makes.
    #[arg(long = "shutter-angle", value_name = "DEG", conflicts_with = "shutter")]
    shutter_angle_deg: Option<f64>,
    /// When the shutter is open relative to the frame the passes describe.
    #[arg(long = "shutter-position", value_enum, default_value = "centred")]
    shutter_position: ShutterPositionArg,
    /// Shutter curve: `box`, or `trapezoid[:RAMP]` opening and closing linearly over RAMP of the
    /// open time each (default 0.25).
    #[arg(long = "shutter-curve", default_value = "box")]
    shutter_curve: String,
    /// A rolling (focal-plane) shutter reading out in this many seconds from the first line to the last.
    #[arg(long = "rolling-shutter", value_name = "READOUT_S")]
    rolling_shutter: Option<String>,
    /// The rolling shutter's direction.
    #[arg(long = "rolling-direction", value_enum, default_value = "down")]
    rolling_direction: RollingDirectionArg,
    /// Motion-blur method.
    #[arg(long = "motion-blur", value_enum, default_value = "fast")]
    motion_blur: MotionBlurArg,
    /// Clamp on the motion blur length in pixels.
    #[arg(long = "max-blur", default_value_t = CameraRequest::default().max_blur_px)]
    max_blur_px: f64,
}

impl MotionArgs {
    /// Whether --shutter-angle was given.
    pub fn shutter_angle_given(&self) -> bool {
        self.shutter_angle_deg.is_some()
    }

    /// `request` with the shutter and motion-blur settings of these flags.
    pub fn request(&self, request: CameraRequest) -> Result<CameraRequest> {
        let shutter_curve = parse_curve(&self.shutter_curve).context("--shutter-curve")?;
        let rolling_shutter_s = match &self.rolling_shutter {
            Some(text) => Some(
                crate::model::settings::parse_shutter_s(text).with_context(|| format!("--rolling-shutter {text:?}"))?,
            ),
            None => None,
        };
        Ok(CameraRequest {
            fps: self.fps,
            shutter_angle_deg: self.shutter_angle_deg,
            shutter_position: match self.shutter_position {
                ShutterPositionArg::Centred => ShutterPosition::Centred,
                ShutterPositionArg::Start => ShutterPosition::Start,
                ShutterPositionArg::End => ShutterPosition::End,
            },
            shutter_curve,
            rolling_shutter_s,
            rolling_direction: match self.rolling_direction {
                RollingDirectionArg::Down => RollingDirection::Down,
                RollingDirectionArg::Up => RollingDirection::Up,
                RollingDirectionArg::Right => RollingDirection::Right,
                RollingDirectionArg::Left => RollingDirection::Left,
            },
            motion_blur: match self.motion_blur {
                MotionBlurArg::Fast => MotionBlurMode::Fast,
                MotionBlurArg::Reference => MotionBlurMode::Reference,
                MotionBlurArg::Off => MotionBlurMode::Off,
            },
            max_blur_px: self.max_blur_px,
            ..request
        })
    }

    /// `sources` with how to read the velocity.
    pub fn sources(&self, sources: PassSources) -> PassSources {
        PassSources {
            velocity_format: self.velocity_format.into(),
            velocity_scale: self.velocity_scale,
            velocity_flip_y: self.velocity_flip_y,
            velocity_interval_frames: self.velocity_interval_frames,
            ..sources
        }
    }
}

/// `box`, `trapezoid` or `trapezoid:RAMP`.
fn parse_curve(text: &str) -> Result<ShutterCurve> {
    match text.split_once(':') {
        None if text == "box" => Ok(ShutterCurve::Box),
        None if text == "trapezoid" => Ok(ShutterCurve::Trapezoid { ramp: 0.25 }),
        Some(("trapezoid", ramp)) => {
            let ramp = ramp.trim().parse::<f64>().with_context(|| format!("{ramp:?} is not a number"))?;
            Ok(ShutterCurve::Trapezoid { ramp })
        }
        _ => bail!("{text:?} is not box, trapezoid or trapezoid:RAMP"),
    }
}
