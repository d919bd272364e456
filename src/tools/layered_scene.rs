//! Ground truth you can generate: a small CPU ray tracer for layered synthetic scenes, and the
//! exact defocused image of realcam's `--lens ideal` camera (the renderers' thin lens).
//!
//! **What it models.** Fronto-parallel layers at random depths, each a textured rectangle
//! ("card"), a disc, or a card with an exact binary alpha mask (round holes, slats), a few small
//! bright discs (highlights, for bokeh), in front of a textured wall or an opaque sky at
//! infinity. Every ray is intersected with every layer's plane and the nearest hit that the
//! layer's shape and mask accept wins, so occlusion, including partial occlusion at the
//! aperture (a background seen around a defocused foreground), is exact.
//!
//! The camera is the thin lens of Cycles, Arnold and RenderMan (`--lens ideal`,
//! [`crate::optics::lens::ThinLens::coc_renderer_mm`]): a pinhole at the origin looking along
//! +z (x right, y down) with the film at the focal length f; a lens of diameter A = f/N at the
//! pinhole; a ray of film point p starts at a point L of the aperture and goes through the
//! pinhole ray's point at the focus distance S. A point at depth u then blurs into a disc of
//! diameter f^2/N |1/S - 1/u| on the film, realcam's `renderer` CoC. The aperture is a circle or
//! a regular polygon with its corners on the circle (realcam's `glsl/include/aperture.glsl`: the
//! first corner at 90 degrees + rotation, counter-clockwise in a y-up frame).
//!
//! It writes what a renderer writes: the colour (pinhole, box-filtered over the pixel by
//! supersampling), the alpha (1 everywhere: the wall and the sky are opaque), the depth (ONE
//! sample per pixel, the planar depth of the pinhole ray through the pixel's centre; 1e10 for
//! the sky, as Blender writes it), and the exact defocused image: each pixel the mean of
//! `truth_spp` rays over the pixel's area and the aperture (a 4D Halton sequence, rotated per
//! pixel), which is what realcam's depth of field of the colour pass should give.
//!
//! **Motion** ([`LayeredScene::render_motion`], issue 30): layers move rigidly in their planes
//! (a velocity and a turn, [`LayerMotion`]); a film point integrates the light over the open
//! shutter (Kyaw 2013 sec 5.2: a point moving while the shutter is open leaves a streak as long
//! as its motion over the open time), with realcam's times: frames from the frame time, the
//! shutter open over `shutter_frames` (src/optics/shutter.rs `ShutterTiming`, a box curve). It
//! writes the passes of a renderer with its motion blur off: the colour at the frame time
//! (anti-aliased), the depth and the next and previous vectors of the pixel centre's one sample,
//! and the exact motion-blurred image through the pinhole (no defocus, so the motion blur is
//! judged alone).
//!
//! **What it does not model:** tilted or curved surfaces, transparency other than binary masks,
//! lighting (the textures are the radiance), motion in depth or of the camera, a shutter curve
//! other than the box, aberrations, vignetting, diffraction, a pixel filter other than the box,
//! noise beyond the sampling's (about 1/sqrt(spp) per pixel at hard edges; tile means are far
//! better).
//!
//! Deterministic from a seed: the same seed gives bit-identical images on any thread count.

use crate::io::{write_exr_channels, write_exr_rgba, ExrWriteOptions, Image, IoError};
use std::path::{Path, PathBuf};

/// Depth written for the sky (Blender's value for nothing hit).
pub const SKY_DEPTH_M: f32 = 1.0e10;

/// The largest CoC diameter on the film of a random scene's layers, mm (48 px at 256 px wide;
/// the sky's may reach 1.19 mm at f/1.4 focused at 1.5 m).
pub const MAX_COC_SENSOR_MM: f64 = 1.2;

/// Samples per pixel of the motion-blurred truth (pixel area x open time): a 40 px streak gets
/// about 6 samples a pixel of its length.
pub const MOTION_TRUTH_SPP: u32 = 256;

/// The camera of a scene: realcam's `--lens ideal --focal-length F --fstop N --focus S
/// --sensor WxH --blades B --blade-rotation R`.
#[derive(Clone, Debug, PartialEq)]
pub struct LayeredCamera {
    pub width: u32,
    pub height: u32,
    pub focal_length_mm: f64,
    pub f_number: f64,
    pub focus_m: f64,
    /// Sensor width, mm (horizontal fit: pixel pitch = sensor width / width).
    pub sensor_width_mm: f64,
    /// 0: circular.
    pub blades: u32,
    pub rotation_deg: f64,
}

impl LayeredCamera {
    pub fn pixel_pitch_mm(&self) -> f64 {
        self.sensor_width_mm / self.width as f64
    }

    /// Sensor height, mm (the frame's aspect).
    pub fn sensor_height_mm(&self) -> f64 {
        self.pixel_pitch_mm() * self.height as f64
    }

    /// Signed CoC diameter in pixels of a point at depth `u_m` (realcam's `renderer` model).
    pub fn coc_px(&self, u_m: f64) -> f64 {
        let f = self.focal_length_mm;
        f * f / self.f_number * (1.0 / (self.focus_m * 1000.0) - 1.0 / (u_m * 1000.0)) / self.pixel_pitch_mm()
    }

    /// The `realcam` flags of this camera (`--blade-rotation` only when not 0, the ideal lens's).
    pub fn flags(&self) -> String {
        let rotation =
            if self.rotation_deg != 0.0 { format!(" --blade-rotation {}", self.rotation_deg) } else { String::new() };
        format!(
            "--lens ideal --focal-length {} --fstop {} --focus {} --sensor {}x{} --blades {}{rotation}",
            self.focal_length_mm,
            self.f_number,
            self.focus_m,
            self.sensor_width_mm,
            (self.sensor_height_mm() * 1e6).round() / 1e6,
            self.blades
        )
    }

    /// A point of the aperture (metres, x right, y down) from a uniform sample of the unit
    /// square: uniform over the disc or the polygon.
    fn aperture_point(&self, u: f64, v: f64) -> (f64, f64) {
        let radius = self.focal_length_mm / self.f_number / 2.0 / 1000.0;
        if self.blades < 3 {
            // Uniform over the disc (area-preserving polar map).
            let (r, phi) = (radius * u.sqrt(), 2.0 * std::f64::consts::PI * v);
            return (r * phi.cos(), r * phi.sin());
        }
        // Pick a triangle (centre, corner k, corner k + 1) by u, then a uniform point in it.
        let n = self.blades as f64;
        let k = (u * n).floor().min(n - 1.0);
        let u = u * n - k;
        let corner = |k: f64| {
            let a = std::f64::consts::FRAC_PI_2 + self.rotation_deg.to_radians() + k * std::f64::consts::TAU / n;
            // y up -> y down.
            (radius * a.cos(), -radius * a.sin())
        };
        let (a, b) = (corner(k), corner(k + 1.0));
        let s = u.sqrt();
        // Barycentric: centre (1 - s), a (s (1 - v)), b (s v).
        (s * ((1.0 - v) * a.0 + v * b.0), s * ((1.0 - v) * a.1 + v * b.1))
    }
}

/// A layer's outline, in metres on its plane (x right, y down).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// The whole plane (the back wall).
    Everywhere,
    Rect {
        x0: f64,
        y0: f64,
        x1: f64,
        y1: f64,
    },
    Disc {
        cx: f64,
        cy: f64,
        r: f64,
    },
}

/// An exact binary alpha mask on a layer: where it is 0 rays pass through.
#[derive(Clone, Debug, PartialEq)]
pub enum Mask {
    Opaque,
    /// Round holes of radius `r` on a square grid of pitch `pitch` (metres).
    Holes {
        pitch: f64,
        r: f64,
    },
    /// Vertical slats `pitch` apart, each `width` wide (a fence).
    Slats {
        pitch: f64,
        width: f64,
    },
}

/// The radiance on a layer (linear RGB), in its plane's metres.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Flat([f32; 3]),
    Checker {
        cell: f64,
        a: [f32; 3],
        b: [f32; 3],
    },
    /// Stripes at 45 degrees, `period` apart, half a and half b.
    Stripes {
        period: f64,
        a: [f32; 3],
        b: [f32; 3],
    },
    /// A smooth ramp from a (left) to b (right) over `width`, with rings of period `period`.
    Rings {
        period: f64,
        a: [f32; 3],
        b: [f32; 3],
    },
}

/// How a layer moves over time t (frames from the frame time, the instant the colour, depth and
/// velocity passes describe): rigidly in its own plane, turning `spin_rad_per_frame` about
/// `centre_m` (clockwise on screen, x right and y down) while that centre moves `velocity_m_per_frame` per
/// frame. A fronto-parallel plane keeps its depth, so its image moves by `velocity_m_per_frame` over the
/// metres per pixel of its depth ([`LayeredScene::m_per_px`]).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct LayerMotion {
    /// Metres per frame on the layer's plane (x right, y down).
    pub velocity_m_per_frame: [f64; 2],
    pub spin_rad_per_frame: f64,
    /// The centre of the turn at the frame time (metres on the plane).
    pub centre_m: [f64; 2],
}

impl LayerMotion {
    /// Not moving.
    pub const STILL: LayerMotion =
        LayerMotion { velocity_m_per_frame: [0.0; 2], spin_rad_per_frame: 0.0, centre_m: [0.0; 2] };

    fn is_still(&self) -> bool {
        self.velocity_m_per_frame == [0.0; 2] && self.spin_rad_per_frame == 0.0
    }

    /// Where the layer's point that is at `q` at the frame time is at time `t`:
    /// c + v t + R(spin t) (q - c).
    pub fn position_at(&self, q: [f64; 2], t: f64) -> [f64; 2] {
        if t == 0.0 || self.is_still() {
            return q;
        }
        let (s, c) = (self.spin_rad_per_frame * t).sin_cos();
        let [cx, cy] = self.centre_m;
        let (dx, dy) = (q[0] - cx, q[1] - cy);
        [
            cx + self.velocity_m_per_frame[0] * t + c * dx - s * dy,
            cy + self.velocity_m_per_frame[1] * t + s * dx + c * dy,
        ]
    }

    /// The inverse: which of the layer's points (at their frame-time positions) is at `p` at
    /// time `t`: c + R(-spin t) (p - c - v t). Exactly `p` at t = 0 and for a still layer, so the
    /// depth of field's scenes trace bit for bit as before.
    fn material_point(&self, p: [f64; 2], t: f64) -> [f64; 2] {
        if t == 0.0 || self.is_still() {
            return p;
        }
        let (s, c) = (self.spin_rad_per_frame * t).sin_cos();
        let [cx, cy] = self.centre_m;
        let (dx, dy) = (p[0] - cx - self.velocity_m_per_frame[0] * t, p[1] - cy - self.velocity_m_per_frame[1] * t);
        [cx + c * dx + s * dy, cy - s * dx + c * dy]
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    pub depth_m: f64,
    pub shape: Shape,
    pub mask: Mask,
    pub texture: Texture,
    /// [`LayerMotion::STILL`] in the depth of field's scenes.
    pub motion: LayerMotion,
}

impl Layer {
    /// The radiance at (x, y) on the layer's plane, or None where the ray passes.
    fn hit(&self, x: f64, y: f64) -> Option<[f32; 3]> {
        let inside = match self.shape {
            Shape::Everywhere => true,
            Shape::Rect { x0, y0, x1, y1 } => x >= x0 && x < x1 && y >= y0 && y < y1,
            Shape::Disc { cx, cy, r } => (x - cx).powi(2) + (y - cy).powi(2) < r * r,
        };
        if !inside {
            return None;
        }
        let open = match self.mask {
            Mask::Opaque => false,
            Mask::Holes { pitch, r } => {
                let (fx, fy) = ((x / pitch).rem_euclid(1.0) - 0.5, (y / pitch).rem_euclid(1.0) - 0.5);
                (fx * fx + fy * fy) * pitch * pitch < r * r
            }
            Mask::Slats { pitch, width } => (x / pitch).rem_euclid(1.0) * pitch >= width,
        };
        if open {
            return None;
        }
        Some(match self.texture {
            Texture::Flat(c) => c,
            Texture::Checker { cell, a, b } => {
                if ((x / cell).floor() + (y / cell).floor()).rem_euclid(2.0) < 1.0 {
                    a
                } else {
                    b
                }
            }
            Texture::Stripes { period, a, b } => {
                if ((x + y) / period).rem_euclid(1.0) < 0.5 {
                    a
                } else {
                    b
                }
            }
            Texture::Rings { period, a, b } => {
                let t = (0.5 + 0.5 * ((x * x + y * y).sqrt() / period * std::f64::consts::TAU).cos()) as f32;
                [0, 1, 2].map(|c| a[c] + t * (b[c] - a[c]))
            }
        })
    }
}

/// A layered scene: layers sorted nearest first, and the sky for rays that hit none.
#[derive(Clone, Debug, PartialEq)]
pub struct LayeredScene {
    pub seed: u64,
    pub camera: LayeredCamera,
    /// Nearest first.
    pub layers: Vec<Layer>,
    /// The sky's colour at the top and at the bottom of the frame (a vertical gradient by
    /// direction, at infinity).
    pub sky: [[f32; 3]; 2],
    /// Samples per pixel of the colour pass (pinhole, box filter).
    pub color_spp: u32,
    /// Samples per pixel of the defocused truth (pixel area x aperture), and of the motion-blurred
    /// truth (pixel area x open time).
    pub truth_spp: u32,
    /// When the shutter opens and closes (frames from the frame time; realcam's
    /// [`crate::optics::shutter::ShutterTiming`] `open_frames`, `close_frames`, a box curve):
    /// (0, 0) in the depth of field's scenes.
    pub shutter_frames: [f64; 2],
}

/// The passes of a scene, RGBA row-major top row first (depth: one value per pixel).
#[derive(Clone, Debug)]
pub struct LayeredPasses {
    pub width: u32,
    pub height: u32,
    /// Pinhole colour, anti-aliased; alpha 1.
    pub color: Vec<f32>,
    /// Planar depth of the pixel centre's pinhole ray, m.
    pub depth_m: Vec<f32>,
    /// The exact defocused image of the scene's thin lens.
    pub truth: Vec<f32>,
}

/// The passes of a scene with movers ([`LayeredScene::render_motion`]), as a renderer writes them
/// with its motion blur off, and the exact motion-blurred image; RGBA or xy per pixel, row-major,
/// top row first.
#[derive(Clone, Debug)]
pub struct MotionPasses {
    pub width: u32,
    pub height: u32,
    /// The pinhole colour at the frame time (the centred shutter's middle), anti-aliased; alpha 1.
    pub color: Vec<f32>,
    /// Planar depth of the pixel centre's pinhole ray at the frame time, m.
    pub depth_m: Vec<f32>,
    /// Px per frame (x right, y down) from where the point of the layer the pixel centre's ray
    /// hits at the frame time is to where it is one frame later (the chord, as renderers write
    /// it); 0 on the sky. Two values per pixel.
    pub velocity_next_px: Vec<f32>,
    /// The same toward one frame earlier.
    pub velocity_prev_px: Vec<f32>,
    /// The exact image with the shutter open over `shutter_frames` (box), through the pinhole:
    /// the mean over the pixel's area and the open time; no defocus.
    pub truth: Vec<f32>,
}

/// SplitMix64: the scene's random numbers.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }
    fn pick(&mut self, n: usize) -> usize {
        (self.unit() * n as f64) as usize % n
    }
    fn colour(&mut self, lo: f64, hi: f64) -> [f32; 3] {
        [0; 3].map(|_| self.range(lo, hi) as f32)
    }
}

/// Radical inverse of `i` in base `b` (the Halton sequence).
fn halton(mut i: u32, b: u32) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    let inv = 1.0 / b as f64;
    while i > 0 {
        f *= inv;
        r += f * (i % b) as f64;
        i /= b;
    }
    r
}

/// A per-pixel offset in [0, 1) (Cranley-Patterson rotation), from a hash.
fn hash_unit(mut x: u64) -> f64 {
    x ^= x >> 33;
    x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    x ^= x >> 33;
    x = x.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
    x ^= x >> 33;
    (x >> 11) as f64 / (1u64 << 53) as f64
}

impl LayeredScene {
    /// A random scene from `seed` at `width x height` px: a 50 mm lens at f/1.4..f/5.6 on a
    /// 6.4 mm wide sensor (0.025 mm pixels at 256 px wide), focused at 1.5..4 m, circular or
    /// with 5, 6 or 8 blades; a textured wall at 6..30 m or the sky; 4..7 cards, discs and
    /// masked cards at 0.6..12 m (log-uniform; redrawn where the CoC would pass
    /// [`MAX_COC_SENSOR_MM`]); 0..4 small highlights (values 4..20).
    pub fn random(seed: u64, width: u32, height: u32) -> LayeredScene {
        let mut rng = Rng(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x5851_F42D_4C95_7F2D);
        let f_numbers = [1.4, 2.0, 2.8, 4.0, 5.6];
        let blades = [0, 5, 6, 6, 8];
        let camera = LayeredCamera {
            width,
            height,
            focal_length_mm: 50.0,
            f_number: f_numbers[rng.pick(f_numbers.len())],
            focus_m: (rng.range(1.5, 4.0) * 100.0).round() / 100.0,
            sensor_width_mm: 6.4,
            blades: blades[rng.pick(blades.len())],
            rotation_deg: 0.0,
        };
        // Metres on a plane at depth d per pixel of the image.
        let m_per_px = |d: f64| camera.pixel_pitch_mm() * d / camera.focal_length_mm;
        // The image point (px) at depth d, in the plane's metres.
        let at = |px: f64, py: f64, d: f64| {
            ((px - width as f64 / 2.0) * m_per_px(d), (py - height as f64 / 2.0) * m_per_px(d))
        };
        let texture = |rng: &mut Rng, d: f64| {
            let (a, b) = (rng.colour(0.05, 0.9), rng.colour(0.02, 0.6));
            let cell = m_per_px(d) * rng.range(2.0, 14.0);
            match rng.pick(4) {
                0 => Texture::Flat(a),
                1 => Texture::Checker { cell, a, b },
                2 => Texture::Stripes { period: 2.0 * cell, a, b },
                _ => Texture::Rings { period: 3.0 * cell, a, b },
            }
        };
        let mut layers = Vec::new();
        let sky = [rng.colour(0.3, 0.9), rng.colour(0.1, 0.5)];
        if rng.unit() < 0.5 {
            let d = rng.range(6.0, 30.0);
            let t = texture(&mut rng, d);
            layers.push(Layer {
                depth_m: d,
                shape: Shape::Everywhere,
                mask: Mask::Opaque,
                texture: t,
                motion: LayerMotion::STILL,
            });
        }
        let depth = |rng: &mut Rng| loop {
            let d = (0.6f64.ln() + rng.unit() * (12.0f64.ln() - 0.6f64.ln())).exp();
            if camera.coc_px(d).abs() * camera.pixel_pitch_mm() <= MAX_COC_SENSOR_MM {
                break d;
            }
        };
        for _ in 0..4 + rng.pick(4) {
            let d = depth(&mut rng);
            let (cx, cy) = (rng.range(0.0, width as f64), rng.range(0.0, height as f64));
            let size = rng.range(0.12, 0.5) * width as f64;
            let (w, h) = (size * rng.range(0.5, 1.5), size * rng.range(0.5, 1.5));
            let kind = rng.pick(3);
            let shape = if kind == 1 {
                let (x, y) = at(cx, cy, d);
                Shape::Disc { cx: x, cy: y, r: 0.5 * size * m_per_px(d) }
            } else {
                let (x0, y0) = at(cx - w / 2.0, cy - h / 2.0, d);
                let (x1, y1) = at(cx + w / 2.0, cy + h / 2.0, d);
                Shape::Rect { x0, y0, x1, y1 }
            };
            let mask = if kind == 2 {
                let pitch = m_per_px(d) * rng.range(6.0, 20.0);
                if rng.unit() < 0.5 {
                    Mask::Holes { pitch, r: pitch * rng.range(0.2, 0.45) }
                } else {
                    Mask::Slats { pitch, width: pitch * rng.range(0.3, 0.7) }
                }
            } else {
                Mask::Opaque
            };
            let t = texture(&mut rng, d);
            layers.push(Layer { depth_m: d, shape, mask, texture: t, motion: LayerMotion::STILL });
        }
        for _ in 0..rng.pick(5) {
            let d = depth(&mut rng);
            let (x, y) = at(rng.range(0.0, width as f64), rng.range(0.0, height as f64), d);
            let v = rng.range(4.0, 20.0) as f32;
            let tint = rng.colour(0.6, 1.0);
            layers.push(Layer {
                depth_m: d,
                shape: Shape::Disc { cx: x, cy: y, r: rng.range(0.5, 1.2) * m_per_px(d) },
                mask: Mask::Opaque,
                texture: Texture::Flat(tint.map(|c| c * v)),
                motion: LayerMotion::STILL,
            });
        }
        layers.sort_by(|a, b| a.depth_m.total_cmp(&b.depth_m));
        LayeredScene { seed, camera, layers, sky, color_spp: 16, truth_spp: 128, shutter_frames: [0.0; 2] }
    }

    /// Metres on a plane at depth `depth_m` per pixel of the image (pinhole).
    pub fn m_per_px(&self, depth_m: f64) -> f64 {
        self.camera.pixel_pitch_mm() * depth_m / self.camera.focal_length_mm
    }

    /// The scene of [`Self::random`] for `seed` (the same layers, textures and masks), set in
    /// motion from a second random stream of the seed: each layer (the wall and the highlights
    /// too) is still with probability 0.3, else moves 2..40 px per frame in a uniform direction;
    /// the sky is still; the shutter is centred on the frame time and open 90, 180, 270 or 360
    /// degrees (0.25..1 frame), a box. No layer turns. Its truth ([`Self::render_motion`]) is
    /// through the pinhole: motion blur alone.
    pub fn random_moving(seed: u64, width: u32, height: u32) -> LayeredScene {
        let mut scene = LayeredScene::random(seed, width, height);
        let mut rng = Rng(seed.wrapping_mul(0x9FB2_1C65_1E98_DF25) ^ 0x3C6E_F372_FE94_F82B);
        let open = [0.25, 0.5, 0.75, 1.0][rng.pick(4)];
        scene.shutter_frames = [-0.5 * open, 0.5 * open];
        scene.truth_spp = MOTION_TRUTH_SPP;
        for k in 0..scene.layers.len() {
            let (still, speed_px, angle) =
                (rng.unit() < 0.3, rng.range(2.0, 40.0), rng.range(0.0, std::f64::consts::TAU));
            if !still {
                let m = scene.m_per_px(scene.layers[k].depth_m);
                scene.layers[k].motion.velocity_m_per_frame = [speed_px * angle.cos() * m, speed_px * angle.sin() * m];
            }
        }
        scene
    }

    /// A turning textured disc: a wheel of radius 36 px with a checker of 11 px cells in front of a still striped wall, turning `spin_rad_per_frame`
    /// about its centre, its centre still; the shutter centred, open `open_frames`. Its points
    /// move along arcs: the chords to the previous and next frame bend, so a blur along one
    /// straight line through the pixel (the next vector and its negation) misses the arc, the
    /// two segments (next and previous vectors) follow it.
    pub fn turning_wheel(width: u32, height: u32, spin_rad_per_frame: f64, open_frames: f64) -> LayeredScene {
        let mut scene = LayeredScene::random(0, width, height);
        let (wheel_m, wall_m) = (2.0, 8.0);
        let r = 36.0 * scene.m_per_px(wheel_m);
        let cell = 6.0 * scene.m_per_px(wall_m);
        scene.layers = vec![
            Layer {
                depth_m: wheel_m,
                shape: Shape::Disc { cx: 0.0, cy: 0.0, r },
                mask: Mask::Opaque,
                texture: Texture::Checker { cell: 0.3 * r, a: [0.9, 0.8, 0.3], b: [0.05, 0.1, 0.3] },
                motion: LayerMotion { velocity_m_per_frame: [0.0; 2], spin_rad_per_frame, centre_m: [0.0; 2] },
            },
            Layer {
                depth_m: wall_m,
                shape: Shape::Everywhere,
                mask: Mask::Opaque,
                texture: Texture::Stripes { period: cell, a: [0.4, 0.4, 0.45], b: [0.1, 0.12, 0.1] },
                motion: LayerMotion::STILL,
            },
        ];
        scene.shutter_frames = [-0.5 * open_frames, 0.5 * open_frames];
        scene.truth_spp = MOTION_TRUTH_SPP;
        scene
    }

    /// The radiance and depth along the ray from aperture point (lx, ly) (metres) through the
    /// film point (fx, fy) (mm, x right, y down) at time `t` (frames): the nearest layer that takes
    /// it, else the sky; and the index of that layer (None: the sky).
    fn trace(&self, lx: f64, ly: f64, fx: f64, fy: f64, t: f64) -> ([f32; 3], f32, Option<usize>) {
        let c = &self.camera;
        // The pinhole ray's point at the focus distance.
        let s = c.focus_m;
        let (px, py) = (fx / c.focal_length_mm * s, fy / c.focal_length_mm * s);
        for (k, layer) in self.layers.iter().enumerate() {
            let d = layer.depth_m / s;
            let [x, y] = layer.motion.material_point([lx + d * (px - lx), ly + d * (py - ly)], t);
            if let Some(rgb) = layer.hit(x, y) {
                return (rgb, layer.depth_m as f32, Some(k));
            }
        }
        // The sky by the ray's vertical direction, -0.5..0.5 of the frame's height at the top and
        // bottom edges.
        let dir_y = (py - ly) / s * c.focal_length_mm / c.sensor_height_mm();
        let t = (dir_y + 0.5).clamp(0.0, 1.0) as f32;
        let [top, bottom] = self.sky;
        ([0, 1, 2].map(|k| top[k] + t * (bottom[k] - top[k])), SKY_DEPTH_M, None)
    }

    /// The film point (mm) of pixel position (x, y) (px, continuous).
    fn film(&self, x: f64, y: f64) -> (f64, f64) {
        let c = &self.camera;
        let p = c.pixel_pitch_mm();
        ((x - c.width as f64 / 2.0) * p, (y - c.height as f64 / 2.0) * p)
    }

    /// Every pass. Rows are shared among the machine's threads; the result does not depend on
    /// their number.
    pub fn render(&self) -> LayeredPasses {
        let (w, h) = (self.camera.width as usize, self.camera.height as usize);
        let mut color = vec![0.0f32; w * h * 4];
        let mut truth = vec![0.0f32; w * h * 4];
        let mut depth_m = vec![0.0f32; w * h];
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, 16);
        let rows_per = h.div_ceil(threads).max(1);
        std::thread::scope(|scope| {
            let chunks = color
                .chunks_mut(rows_per * w * 4)
                .zip(truth.chunks_mut(rows_per * w * 4))
                .zip(depth_m.chunks_mut(rows_per * w));
            for (k, ((c, t), d)) in chunks.enumerate() {
                scope.spawn(move || self.render_rows(k * rows_per, c, t, d));
            }
        });
        LayeredPasses { width: self.camera.width, height: self.camera.height, color, depth_m, truth }
    }

    fn render_rows(&self, y0: usize, color: &mut [f32], truth: &mut [f32], depth: &mut [f32]) {
        let w = self.camera.width as usize;
        for (i, d) in depth.iter_mut().enumerate() {
            let (x, y) = (i % w, y0 + i / w);
            let key = self.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ ((y * w + x) as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93);
            let rot = [0u64, 1, 2, 3].map(|k| hash_unit(key.wrapping_add(k.wrapping_mul(0x632B_E59B_D9B4_E019))));
            // Depth: the pixel centre's pinhole ray.
            let (fx, fy) = self.film(x as f64 + 0.5, y as f64 + 0.5);
            *d = self.trace(0.0, 0.0, fx, fy, 0.0).1;
            // Colour: the pinhole, box-filtered over the pixel.
            color[i * 4..i * 4 + 4].copy_from_slice(&self.pixel_mean(x, y, self.color_spp, rot, Sampling::Pinhole));
            // Truth: the pixel's area x the aperture.
            truth[i * 4..i * 4 + 4].copy_from_slice(&self.pixel_mean(x, y, self.truth_spp, rot, Sampling::Lens));
        }
    }

    /// The opaque RGBA mean of `spp` rays through pixel (x, y), over the pixel's area (Halton
    /// bases 2, 3) and, by `sampling`, the aperture (bases 5, 7) or the open time (base 5);
    /// `rot` shifts the sequences per pixel (Cranley-Patterson rotation).
    fn pixel_mean(&self, x: usize, y: usize, spp: u32, rot: [f64; 4], sampling: Sampling) -> [f32; 4] {
        let wrap = |v: f64| v - v.floor();
        let mut sum = [0.0f64; 3];
        let [open, close] = self.shutter_frames;
        for s in 0..spp {
            let (jx, jy) = (wrap(halton(s + 1, 2) + rot[0]), wrap(halton(s + 1, 3) + rot[1]));
            let ((lx, ly), t) = match sampling {
                Sampling::Pinhole => ((0.0, 0.0), 0.0),
                Sampling::Lens => {
                    let (u, v) = (wrap(halton(s + 1, 5) + rot[2]), wrap(halton(s + 1, 7) + rot[3]));
                    (self.camera.aperture_point(u, v), 0.0)
                }
                // A box shutter: time uniform over the open interval.
                Sampling::Shutter => ((0.0, 0.0), open + (close - open) * wrap(halton(s + 1, 5) + rot[2])),
            };
            let (fx, fy) = self.film(x as f64 + jx, y as f64 + jy);
            let rgb = self.trace(lx, ly, fx, fy, t).0;
            for k in 0..3 {
                sum[k] += rgb[k] as f64;
            }
        }
        let n = spp.max(1) as f64;
        [(sum[0] / n) as f32, (sum[1] / n) as f32, (sum[2] / n) as f32, 1.0]
    }

    /// The passes of a scene with movers and its exact motion-blurred image. Rows are shared
    /// among the machine's threads; the result does not depend on their number.
    pub fn render_motion(&self) -> MotionPasses {
        let (w, h) = (self.camera.width as usize, self.camera.height as usize);
        let mut p = MotionPasses {
            width: self.camera.width,
            height: self.camera.height,
            color: vec![0.0; w * h * 4],
            depth_m: vec![0.0; w * h],
            velocity_next_px: vec![0.0; w * h * 2],
            velocity_prev_px: vec![0.0; w * h * 2],
            truth: vec![0.0; w * h * 4],
        };
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, 16);
        let rows = h.div_ceil(threads).max(1);
        std::thread::scope(|scope| {
            let chunks = p
                .color
                .chunks_mut(rows * w * 4)
                .zip(p.truth.chunks_mut(rows * w * 4))
                .zip(p.depth_m.chunks_mut(rows * w))
                .zip(p.velocity_next_px.chunks_mut(rows * w * 2).zip(p.velocity_prev_px.chunks_mut(rows * w * 2)));
            for (k, (((c, t), d), (n, b))) in chunks.enumerate() {
                scope.spawn(move || self.render_motion_rows(k * rows, c, t, d, [n, b]));
            }
        });
        p
    }

    fn render_motion_rows(
        &self,
        y0: usize,
        color: &mut [f32],
        truth: &mut [f32],
        depth: &mut [f32],
        [next, prev]: [&mut [f32]; 2],
    ) {
        let w = self.camera.width as usize;
        for (i, d) in depth.iter_mut().enumerate() {
            let (x, y) = (i % w, y0 + i / w);
            let key = self.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ ((y * w + x) as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93);
            let rot = [0u64, 1, 2, 3].map(|k| hash_unit(key.wrapping_add(k.wrapping_mul(0x632B_E59B_D9B4_E019))));
            // Depth and vectors: one sample, the pixel centre's pinhole ray at the frame time.
            let (fx, fy) = self.film(x as f64 + 0.5, y as f64 + 0.5);
            let (_, z, hit) = self.trace(0.0, 0.0, fx, fy, 0.0);
            *d = z;
            let (n, b) = hit.map_or(([0.0; 2], [0.0; 2]), |k| self.chords_px(k, fx, fy));
            next[i * 2..i * 2 + 2].copy_from_slice(&n.map(|v| v as f32));
            prev[i * 2..i * 2 + 2].copy_from_slice(&b.map(|v| v as f32));
            color[i * 4..i * 4 + 4].copy_from_slice(&self.pixel_mean(x, y, self.color_spp, rot, Sampling::Pinhole));
            truth[i * 4..i * 4 + 4].copy_from_slice(&self.pixel_mean(x, y, self.truth_spp, rot, Sampling::Shutter));
        }
    }

    /// The image motion (px, x right, y down) of layer `k`'s point seen through the pinhole at
    /// film point (fx, fy) (mm) at the frame time, to where it is one frame later and one frame
    /// earlier: what a renderer's vector pass holds (Blender's Z,W and X,Y before its sign and
    /// y-up conventions).
    fn chords_px(&self, k: usize, fx: f64, fy: f64) -> ([f64; 2], [f64; 2]) {
        let layer = &self.layers[k];
        let m = self.m_per_px(layer.depth_m);
        let q = [fx / self.camera.focal_length_mm * layer.depth_m, fy / self.camera.focal_length_mm * layer.depth_m];
        let chord = |t: f64| {
            let p = layer.motion.position_at(q, t);
            [(p[0] - q[0]) / m, (p[1] - q[1]) / m]
        };
        (chord(1.0), chord(-1.0))
    }
}

/// What a pixel's samples range over besides its area.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Sampling {
    /// The pinhole at the frame time (the colour pass).
    Pinhole,
    /// The aperture (the defocused truth).
    Lens,
    /// The open time (the motion-blurred truth).
    Shutter,
}

impl LayeredPasses {
    fn image(&self, data: &[f32]) -> Image {
        Image { width: self.width, height: self.height, channels: 4, data: data.to_vec() }
    }

    /// Writes `<dir>/<name>_color.exr` (RGBA, float32), `<dir>/<name>_depth.exr` (Z, metres)
    /// and `<dir>/<name>_truth.exr` (RGBA, the exact defocused image); returns their paths.
    pub fn write(&self, dir: &Path, name: &str) -> Result<[PathBuf; 3], IoError> {
        let opts = ExrWriteOptions { float32: true, ..ExrWriteOptions::default() };
        let paths = ["color", "depth", "truth"].map(|p| dir.join(format!("{name}_{p}.exr")));
        write_exr_rgba(&paths[0], &self.image(&self.color), &opts)?;
        write_exr_channels(&paths[1], self.width, self.height, &[("Z", &self.depth_m)], &opts)?;
        write_exr_rgba(&paths[2], &self.image(&self.truth), &opts)?;
        Ok(paths)
    }
}

impl MotionPasses {
    /// The velocity as Blender's `Vector` pass holds it, X,Y,Z,W: px per frame, y up;
    /// X,Y = p[f-1] - p[f] (the previous chord), Z,W = p[f] - p[f+1] (the next chord negated), as
    /// src/io/exr_read/velocity.rs reads it back.
    pub fn blender_vector(&self) -> [Vec<f32>; 4] {
        let (n, p) = (&self.velocity_next_px, &self.velocity_prev_px);
        let each = |f: &dyn Fn(usize) -> f32| (0..n.len() / 2).map(f).collect::<Vec<f32>>();
        [each(&|i| p[2 * i]), each(&|i| -p[2 * i + 1]), each(&|i| -n[2 * i]), each(&|i| n[2 * i + 1])]
    }

    /// Writes `<dir>/<name>_color.exr` (RGBA, float32), `<dir>/<name>_depth.exr` (Z, metres),
    /// `<dir>/<name>_vector.exr` (Blender's X,Y,Z,W) and `<dir>/<name>_truth.exr` (RGBA, the
    /// exact motion-blurred image); returns their paths.
    pub fn write(&self, dir: &Path, name: &str) -> Result<[PathBuf; 4], IoError> {
        let opts = ExrWriteOptions { float32: true, ..ExrWriteOptions::default() };
        let paths = ["color", "depth", "vector", "truth"].map(|p| dir.join(format!("{name}_{p}.exr")));
        let image = |data: &[f32]| Image { width: self.width, height: self.height, channels: 4, data: data.to_vec() };
        write_exr_rgba(&paths[0], &image(&self.color), &opts)?;
        write_exr_channels(&paths[1], self.width, self.height, &[("Z", &self.depth_m)], &opts)?;
        let [x, y, z, w] = self.blender_vector();
        write_exr_channels(&paths[2], self.width, self.height, &[("X", &x), ("Y", &y), ("Z", &z), ("W", &w)], &opts)?;
        write_exr_rgba(&paths[3], &image(&self.truth), &opts)?;
        Ok(paths)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(seed: u64) -> LayeredScene {
        let mut s = LayeredScene::random(seed, 48, 32);
        s.color_spp = 4;
        s.truth_spp = 16;
        s
    }

    #[test]
    fn the_same_seed_gives_the_same_images() {
        let (a, b) = (small(3).render(), small(3).render());
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.color), bits(&b.color));
        assert_eq!(bits(&a.truth), bits(&b.truth));
        assert_eq!(bits(&a.depth_m), bits(&b.depth_m));
        assert_ne!(small(3).layers, small(4).layers);
    }

    #[test]
    fn the_aperture_samples_are_uniform_over_the_iris() {
        // The mean of the samples is the centre; their extent is the radius f/(2N); for the
        // polygon every sample lies inside it (corners on the circle, the first straight up).
        for blades in [0, 5, 6] {
            let c = LayeredCamera {
                width: 10,
                height: 10,
                focal_length_mm: 50.0,
                f_number: 2.0,
                focus_m: 2.0,
                sensor_width_mm: 10.0,
                blades,
                rotation_deg: 0.0,
            };
            let n = 4096;
            let points: Vec<_> = (0..n).map(|i| c.aperture_point(halton(i + 1, 5), halton(i + 1, 7))).collect();
            let (mx, my) = points.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0 / n as f64, a.1 + p.1 / n as f64));
            assert!(mx.abs() < 2e-4 && my.abs() < 2e-4, "{blades}: mean ({mx}, {my})");
            let r = points.iter().map(|p| p.0.hypot(p.1)).fold(0.0, f64::max);
            assert!(r <= 0.0125 + 1e-12 && r > 0.0124, "{blades}: {r}");
            // Uniform over the disc: the mean squared radius is r^2 / 2.
            if blades == 0 {
                let m2 = points.iter().map(|p| p.0 * p.0 + p.1 * p.1).sum::<f64>() / n as f64;
                assert!((m2 / (0.0125f64.powi(2) / 2.0) - 1.0).abs() < 0.01, "{m2}");
            }
            // The top of the pentagon is a corner (y up = -y here): the highest sample reaches r.
            if blades == 5 {
                let top = points.iter().map(|p| -p.1).fold(f64::MIN, f64::max);
                let bottom = points.iter().map(|p| p.1).fold(f64::MIN, f64::max);
                assert!(top > 0.0120 && bottom < 0.0125 * 0.81 + 1e-4, "{top} {bottom}");
            }
        }
    }

    #[test]
    fn a_point_blurs_into_the_renderers_coc() {
        // A small bright disc at 6 m on a black wall at 6 m, focused at 2 m: the truth spreads
        // its light, all of it, over a disc of the renderer's CoC (f^2/N (1/S - 1/u)); the depth
        // is the wall's.
        let camera = LayeredCamera {
            width: 64,
            height: 64,
            focal_length_mm: 50.0,
            f_number: 2.0,
            focus_m: 2.0,
            sensor_width_mm: 1.6,
            blades: 0,
            rotation_deg: 0.0,
        };
        let m_per_px = camera.pixel_pitch_mm() * 6.0 / 50.0;
        let scene = LayeredScene {
            seed: 1,
            camera: camera.clone(),
            layers: vec![
                Layer {
                    depth_m: 6.0,
                    shape: Shape::Disc { cx: 0.0, cy: 0.0, r: 2.0 * m_per_px },
                    mask: Mask::Opaque,
                    texture: Texture::Flat([100.0; 3]),
                    motion: LayerMotion::STILL,
                },
                Layer {
                    depth_m: 6.0 + 1e-9,
                    shape: Shape::Everywhere,
                    mask: Mask::Opaque,
                    texture: Texture::Flat([0.0; 3]),
                    motion: LayerMotion::STILL,
                },
            ],
            sky: [[0.0; 3]; 2],
            color_spp: 64,
            truth_spp: 256,
            shutter_frames: [0.0; 2],
        };
        let p = scene.render();
        let energy = |v: &[f32]| v.chunks_exact(4).map(|q| q[1] as f64).sum::<f64>();
        let (e_color, e_truth) = (energy(&p.color), energy(&p.truth));
        // The disc (radius 2 px) brings 400 pi.
        assert!((e_color / (400.0 * std::f64::consts::PI) - 1.0).abs() < 0.01, "{e_color}");
        assert!((e_truth / e_color - 1.0).abs() < 0.01, "{e_truth} vs {e_color}");
        // Variances add under convolution: the truth's horizontal variance is the colour pass's
        // (the source disc and the pixel box) plus the CoC disc's, D^2 / 16.
        let variance = |v: &[f32], e: f64| {
            v.chunks_exact(4)
                .enumerate()
                .map(|(i, q)| q[1] as f64 * ((i % 64) as f64 + 0.5 - 32.0).powi(2))
                .sum::<f64>()
                / e
        };
        let diameter = 4.0 * (variance(&p.truth, e_truth) - variance(&p.color, e_color)).sqrt();
        let expected = camera.coc_px(6.0);
        assert!((diameter / expected - 1.0).abs() < 0.02, "{diameter} px, CoC {expected} px");
        assert!(p.depth_m.iter().all(|&d| (d - 6.0).abs() < 1e-6));
    }

    #[test]
    fn a_near_card_hides_what_is_behind_it_and_the_lens_sees_around_it() {
        // An opaque black card covering the left half at 1 m in front of a white wall at 10 m,
        // focused on the wall: the pinhole sees black left, white right; through the lens a pixel
        // just left of the card's edge still sees part of the wall (partial occlusion).
        let camera = LayeredCamera {
            width: 64,
            height: 16,
            focal_length_mm: 50.0,
            f_number: 2.0,
            focus_m: 10.0,
            sensor_width_mm: 1.6,
            blades: 0,
            rotation_deg: 0.0,
        };
        let scene = LayeredScene {
            seed: 2,
            camera,
            layers: vec![
                Layer {
                    depth_m: 1.0,
                    shape: Shape::Rect { x0: -1.0, y0: -1.0, x1: 0.0, y1: 1.0 },
                    mask: Mask::Opaque,
                    texture: Texture::Flat([0.0; 3]),
                    motion: LayerMotion::STILL,
                },
                Layer {
                    depth_m: 10.0,
                    shape: Shape::Everywhere,
                    mask: Mask::Opaque,
                    texture: Texture::Flat([1.0; 3]),
                    motion: LayerMotion::STILL,
                },
            ],
            sky: [[0.0; 3]; 2],
            color_spp: 16,
            truth_spp: 256,
            shutter_frames: [0.0; 2],
        };
        let p = scene.render();
        let at = |v: &[f32], x: usize| v[(8 * 64 + x) * 4];
        assert_eq!((at(&p.color, 30), at(&p.color, 33)), (0.0, 1.0));
        assert_eq!((p.depth_m[8 * 64 + 30], p.depth_m[8 * 64 + 33]), (1.0, 10.0));
        assert!(at(&p.truth, 30) > 0.2 && at(&p.truth, 33) < 0.8, "{} {}", at(&p.truth, 30), at(&p.truth, 33));
        assert!(at(&p.truth, 0) < 0.01 && at(&p.truth, 63) > 0.99);
    }

    /// A bright square of `side_m` on a black wall, both at 5 m, the square moving
    /// `velocity_px` per frame; the shutter centred, open `open` frames.
    fn moving_square(velocity_px: [f64; 2], open: f64, spin: f64) -> LayeredScene {
        let camera = LayeredCamera {
            width: 96,
            height: 48,
            focal_length_mm: 50.0,
            f_number: 2.0,
            focus_m: 5.0,
            sensor_width_mm: 2.4,
            blades: 0,
            rotation_deg: 0.0,
        };
        let mut scene = LayeredScene {
            seed: 5,
            camera,
            layers: Vec::new(),
            sky: [[0.0; 3]; 2],
            color_spp: 64,
            truth_spp: 256,
            shutter_frames: [-0.5 * open, 0.5 * open],
        };
        let m = scene.m_per_px(5.0);
        scene.layers = vec![
            Layer {
                depth_m: 5.0,
                shape: Shape::Rect { x0: -4.0 * m, y0: -4.0 * m, x1: 4.0 * m, y1: 4.0 * m },
                mask: Mask::Opaque,
                texture: Texture::Flat([10.0; 3]),
                motion: LayerMotion {
                    velocity_m_per_frame: velocity_px.map(|v| v * m),
                    spin_rad_per_frame: spin,
                    centre_m: [0.0; 2],
                },
            },
            Layer {
                depth_m: 5.0 + 1e-9,
                shape: Shape::Everywhere,
                mask: Mask::Opaque,
                texture: Texture::Flat([0.0; 3]),
                motion: LayerMotion::STILL,
            },
        ];
        scene
    }

    #[test]
    fn a_mover_streaks_by_its_velocity_times_the_open_time_and_keeps_its_light() {
        // 24 px per frame to the right, open half a frame centred: the truth is the 8 px square
        // convolved with a 12 px box along x centred on it and with the pixel: the same light,
        // the same mean position, the horizontal variance (8^2 + 12^2 + 1) / 12 (variances add
        // under convolution; the smooth result's pixel samples keep it, where the colour's 8 equal
        // pixels have (8^2 - 1) / 12); nothing moves vertically.
        let p = moving_square([24.0, 0.0], 0.5, 0.0).render_motion();
        let moments = |v: &[f32], axis: usize| {
            let (mut e, mut m1, mut m2) = (0.0f64, 0.0f64, 0.0f64);
            for (i, q) in v.chunks_exact(4).enumerate() {
                let c = [(i % 96) as f64 + 0.5 - 48.0, (i / 96) as f64 + 0.5 - 24.0][axis];
                e += q[0] as f64;
                m1 += q[0] as f64 * c;
                m2 += q[0] as f64 * c * c;
            }
            (e, m1 / e, m2 / e - (m1 / e).powi(2))
        };
        let ((e_c, x_c, vx_c), (e_t, x_t, vx_t)) = (moments(&p.color, 0), moments(&p.truth, 0));
        assert!((e_c / 640.0 - 1.0).abs() < 1e-3 && (e_t / e_c - 1.0).abs() < 2e-3, "{e_c} {e_t}");
        assert!(x_c.abs() < 1e-3 && x_t.abs() < 0.02, "{x_c} {x_t}");
        assert!((vx_c - 63.0 / 12.0).abs() < 1e-3, "{vx_c}");
        assert!((vx_t - 209.0 / 12.0).abs() < 0.1, "variance {vx_t}, expected {}", 209.0 / 12.0);
        let (vy_c, vy_t) = (moments(&p.color, 1).2, moments(&p.truth, 1).2);
        assert!((vy_t - vy_c).abs() < 0.02, "{vy_c} {vy_t}");
        // The vectors: (24, 0) and (-24, 0) on the square's pixels (centres within it), 0 on the
        // wall; the depth the square's.
        let at = |v: &[f32], x: usize, y: usize| [v[(y * 96 + x) * 2], v[(y * 96 + x) * 2 + 1]];
        assert_eq!((at(&p.velocity_next_px, 48, 24), at(&p.velocity_prev_px, 48, 24)), ([24.0, 0.0], [-24.0, 0.0]));
        assert_eq!((at(&p.velocity_next_px, 52, 24), at(&p.velocity_next_px, 44, 24)), ([0.0; 2], [24.0, 0.0]));
        assert_eq!(p.depth_m[24 * 96 + 48], 5.0);
    }

    #[test]
    fn a_turning_layers_vectors_are_the_chords_of_its_arcs() {
        // 20 degrees per frame about the centre: a point at radius r moves along a chord of
        // 2 r sin(10 deg) to each neighbouring frame, the two chords bending inward (next + prev
        // = -2 r (1 - cos 20 deg) toward the centre), and through the pinhole at the frame time the
        // square sits where it was built.
        let spin = 20f64.to_radians();
        let scene = moving_square([0.0; 2], 0.5, spin);
        let p = scene.render_motion();
        let i = 24 * 96 + 51; // pixel centre (3.5, 0.5) px from the centre
        let (n, b) = (
            [p.velocity_next_px[2 * i], p.velocity_next_px[2 * i + 1]],
            [p.velocity_prev_px[2 * i], p.velocity_prev_px[2 * i + 1]],
        );
        let r = 3.5f64.hypot(0.5);
        for c in [n, b] {
            assert!(((c[0] as f64).hypot(c[1] as f64) - 2.0 * r * (spin / 2.0).sin()).abs() < 1e-4, "{c:?}");
        }
        let bend = [(n[0] + b[0]) as f64, (n[1] + b[1]) as f64];
        let inward = 2.0 * r * (1.0 - spin.cos());
        assert!((bend[0] + inward * 3.5 / r).abs() < 1e-4 && (bend[1] + inward * 0.5 / r).abs() < 1e-4, "{bend:?}");
        // Clockwise on screen (y down): the point right of the centre moves down.
        assert!(n[1] > 0.0 && b[1] < 0.0);
        let unturned = moving_square([0.0; 2], 0.5, 0.0).render_motion();
        assert_eq!(p.color, unturned.color);
        // A turn keeps the light.
        let e = |v: &[f32]| v.chunks_exact(4).map(|q| q[0] as f64).sum::<f64>();
        assert!((e(&p.truth) / e(&p.color) - 1.0).abs() < 2e-3);
    }

    #[test]
    fn the_moving_scenes_are_the_still_ones_set_in_motion() {
        // The same layers as the depth of field's scene of the seed, some still and some moving
        // at most 40 px per frame; a centred shutter.
        for seed in 0..8 {
            let (still, moving) = (LayeredScene::random(seed, 160, 96), LayeredScene::random_moving(seed, 160, 96));
            assert_eq!(still.layers.len(), moving.layers.len());
            for (a, b) in still.layers.iter().zip(&moving.layers) {
                assert_eq!((&a.shape, &a.mask, &a.texture, a.depth_m), (&b.shape, &b.mask, &b.texture, b.depth_m));
                let speed_px = b.motion.velocity_m_per_frame[0].hypot(b.motion.velocity_m_per_frame[1])
                    / moving.m_per_px(b.depth_m);
                assert!(speed_px == 0.0 || (2.0 - 1e-9..=40.0 + 1e-9).contains(&speed_px), "{speed_px}");
                assert_eq!(b.motion.spin_rad_per_frame, 0.0);
            }
            let [o, c] = moving.shutter_frames;
            assert!(o == -c && (0.25..=1.0).contains(&(c - o)));
        }
    }

    #[test]
    fn the_vector_pass_reads_back_as_written() {
        // Blender's X,Y,Z,W through realcam's reader: the same next and previous vectors.
        let p = moving_square([6.0, -3.0], 0.5, 0.3).render_motion();
        let dir = std::env::temp_dir().join(format!("realcam_layered_vector_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let [color, depth, vector, _] = p.write(&dir, "square").unwrap();
        let sources = crate::io::PassSources {
            depth_path: Some(depth),
            velocity_path: Some(vector),
            ..crate::io::PassSources::new(color)
        };
        let passes = crate::io::load_passes(&sources).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(passes.velocity_format, Some(crate::io::VelocityFormat::Blender));
        assert_eq!(passes.velocity_px.unwrap().data, p.velocity_next_px);
        assert_eq!(passes.velocity_prev_px.unwrap().data, p.velocity_prev_px);
    }
}
