//! Deterministic synthetic scenes with known geometry, for tests and the README demo.
//!
//! A scene is a background at one depth, axis-aligned fronto-parallel planes (pixel
//! rectangles at constant depth, optionally checkered) and single-pixel highlights, painted
//! in that order. No randomness: the same scene always renders bit-identically.

use crate::io::{write_exr_channels, write_exr_rgba, ExrWriteOptions, Image, IoError};
use std::path::Path;

#[derive(Clone, Debug, PartialEq)]
pub struct SynthScene {
    /// Size, px.
    pub width: u32,
    pub height: u32,
    /// Depth of pixels no plane covers, m (1e10 = sky, as Blender writes it).
    pub background_depth_m: f64,
    /// Linear Rec.709 color of the background.
    pub background_rgb: [f32; 3],
    pub planes: Vec<SynthPlane>,
    pub highlights: Vec<SynthHighlight>,
}

/// A rectangle of pixels at one depth.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthPlane {
    /// Pixel rectangle [x0, x1) x [y0, y1), px (clipped to the image).
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
    /// Depth, m.
    pub depth_m: f64,
    /// Linear color.
    pub rgb: [f32; 3],
    /// Checker cell size, px (0 = flat); cells alternate `rgb` and `checker_rgb`, starting
    /// with `rgb` at (x0, y0).
    pub checker_px: u32,
    pub checker_rgb: [f32; 3],
}

/// One pixel of given color (energy) and depth.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthHighlight {
    /// Pixel position, px (ignored when outside the image).
    pub x: u32,
    pub y: u32,
    /// Depth, m.
    pub depth_m: f64,
    /// Linear value written into that single pixel.
    pub rgb: [f32; 3],
}

impl SynthPlane {
    pub fn flat(x0: u32, y0: u32, x1: u32, y1: u32, depth_m: f64, rgb: [f32; 3]) -> SynthPlane {
        SynthPlane { x0, y0, x1, y1, depth_m, rgb, checker_px: 0, checker_rgb: rgb }
    }

    pub fn checker(mut self, checker_px: u32, checker_rgb: [f32; 3]) -> SynthPlane {
        self.checker_px = checker_px;
        self.checker_rgb = checker_rgb;
        self
    }

    fn color_at(&self, x: u32, y: u32) -> [f32; 3] {
        let c = self.checker_px;
        if c > 0 && ((x - self.x0) / c + (y - self.y0) / c) % 2 == 1 {
            self.checker_rgb
        } else {
            self.rgb
        }
    }
}

fn paint(color: &mut Image, depth: &mut Image, x: u32, y: u32, rgb: [f32; 3], depth_m: f64) {
    for (c, v) in rgb.into_iter().enumerate() {
        color.set(x, y, c as u32, v);
    }
    depth.set(x, y, 0, depth_m as f32);
}

impl SynthScene {
    /// Renders (RGBA color with A = 1, depth in metres): background, planes in list order,
    /// highlights last (a highlight sets its pixel's color and depth).
    pub fn render(&self) -> (Image, Image) {
        let (w, h) = (self.width, self.height);
        let mut color = Image::new(w, h, 4);
        let mut depth = Image::new(w, h, 1);
        for y in 0..h {
            for x in 0..w {
                paint(&mut color, &mut depth, x, y, self.background_rgb, self.background_depth_m);
                color.set(x, y, 3, 1.0);
            }
        }
        for p in &self.planes {
            for y in p.y0..p.y1.min(h) {
                for x in p.x0..p.x1.min(w) {
                    paint(&mut color, &mut depth, x, y, p.color_at(x, y), p.depth_m);
                }
            }
        }
        for hl in self.highlights.iter().filter(|hl| hl.x < w && hl.y < h) {
            paint(&mut color, &mut depth, hl.x, hl.y, hl.rgb, hl.depth_m);
        }
        (color, depth)
    }

    /// The 640x360 README demo: sky at 1e10 m, a checkered far wall at 8 m over a floor
    /// band at 3 m, a checker card (the subject) at 2.0 m, a near pillar at 0.8 m on the
    /// left, and 10 highlights of energy 20-500 at 8 m and 1.2 m.
    pub fn demo() -> SynthScene {
        let hl = |x, y, depth_m, rgb| SynthHighlight { x, y, depth_m, rgb };
        let s = |k: f32, rgb: [f32; 3]| rgb.map(|c| c * k);
        let (warm, cool, white) = ([1.0, 0.8, 0.55], [0.55, 0.75, 1.0], [1.0, 1.0, 1.0]);
        SynthScene {
            width: 640,
            height: 360,
            background_depth_m: 1.0e10,
            background_rgb: [0.45, 0.62, 0.9],
            planes: vec![
                SynthPlane::flat(0, 70, 640, 290, 8.0, [0.42, 0.36, 0.3]).checker(20, [0.2, 0.24, 0.3]),
                SynthPlane::flat(0, 290, 640, 360, 3.0, [0.25, 0.18, 0.1]).checker(32, [0.32, 0.24, 0.14]),
                SynthPlane::flat(250, 100, 430, 260, 2.0, [0.85, 0.82, 0.75]).checker(12, [0.06, 0.08, 0.12]),
                SynthPlane::flat(40, 0, 130, 360, 0.8, [0.6, 0.12, 0.08]).checker(30, [0.7, 0.55, 0.15]),
            ],
            highlights: vec![
                hl(170, 95, 8.0, s(50.0, warm)),
                hl(205, 240, 8.0, s(200.0, cool)),
                hl(470, 85, 8.0, s(500.0, white)),
                hl(520, 200, 8.0, s(20.0, [1.0, 0.4, 0.3])),
                hl(600, 140, 8.0, s(100.0, [0.6, 1.0, 0.6])),
                hl(560, 270, 8.0, s(300.0, warm)),
                hl(300, 60, 1.2, s(80.0, cool)),
                hl(460, 230, 1.2, s(150.0, [1.0, 0.6, 1.0])),
                hl(340, 310, 1.2, s(400.0, warm)),
                hl(190, 330, 1.2, s(30.0, white)),
            ],
        }
    }

    /// A uniform grey (0.1) plane filling the frame at `plane_depth_m`, with one highlight
    /// at the centre pixel (width/2, height/2) at the same depth.
    pub fn point_on_plane(width: u32, height: u32, plane_depth_m: f64, highlight_rgb: [f32; 3]) -> SynthScene {
        let grey = [0.1; 3];
        SynthScene {
            width,
            height,
            background_depth_m: plane_depth_m,
            background_rgb: grey,
            planes: vec![SynthPlane::flat(0, 0, width, height, plane_depth_m, grey)],
            highlights: vec![SynthHighlight {
                x: width / 2,
                y: height / 2,
                depth_m: plane_depth_m,
                rgb: highlight_rgb,
            }],
        }
    }

    /// Left half (x < width/2): near plane with an 8 px checker; right half: far plane with a
    /// 12 px checker in other colors.
    pub fn two_planes(width: u32, height: u32, near_depth_m: f64, far_depth_m: f64) -> SynthScene {
        let mid = width / 2;
        SynthScene {
            width,
            height,
            background_depth_m: far_depth_m,
            background_rgb: [0.5; 3],
            planes: vec![
                SynthPlane::flat(0, 0, mid, height, near_depth_m, [0.8, 0.35, 0.2]).checker(8, [0.15, 0.08, 0.05]),
                SynthPlane::flat(mid, 0, width, height, far_depth_m, [0.2, 0.45, 0.8]).checker(12, [0.05, 0.1, 0.2]),
            ],
            highlights: Vec::new(),
        }
    }
}

/// Writes `<dir>/<name>_color.exr` (R,G,B,A float32, exact values) and
/// `<dir>/<name>_depth.exr` (channel Z, float32, metres).
pub fn write_scene(dir: &Path, name: &str, scene: &SynthScene) -> Result<(), IoError> {
    let (color, depth) = scene.render();
    let opts = ExrWriteOptions { float32: true, ..ExrWriteOptions::default() };
    write_exr_rgba(&dir.join(format!("{name}_color.exr")), &color, &opts)?;
    let depth_path = dir.join(format!("{name}_depth.exr"));
    write_exr_channels(&depth_path, scene.width, scene.height, &[("Z", &depth.data)], &opts)
}

/// The README demo `k` times as large (every length times `k`; each highlight still one pixel of
/// the same value) with a velocity pass: the subject card moves 4k px per frame to the right,
/// the near pillar 2k px per frame to the left, the rest stands still. For benchmarks at 1080p
/// (k = 3), 4K (6) and 8K (12): `realcam synth --demo-scale K` writes
/// `<dir>/demo_WxH_color.exr`, `_depth.exr` and `_vector.exr` (Blender's X,Y,Z,W); returns their
/// paths.
pub fn write_scaled_demo(dir: &Path, k: u32) -> Result<[std::path::PathBuf; 3], IoError> {
    let demo = SynthScene::demo();
    let scale = |p: &SynthPlane| SynthPlane {
        x0: p.x0 * k,
        y0: p.y0 * k,
        x1: p.x1 * k,
        y1: p.y1 * k,
        checker_px: p.checker_px * k,
        ..p.clone()
    };
    let scene = SynthScene {
        width: demo.width * k,
        height: demo.height * k,
        planes: demo.planes.iter().map(scale).collect(),
        highlights: demo.highlights.iter().map(|h| SynthHighlight { x: h.x * k, y: h.y * k, ..h.clone() }).collect(),
        ..demo.clone()
    };
    let (w, h) = (scene.width, scene.height);
    // Blender's vector pass, y up: X,Y the previous chord p[f-1] - p[f], Z,W the next chord
    // negated, for a constant velocity v (px per frame, y down): (-vx, vy, -vx, vy).
    let mut vector = [vec![0.0f32; (w * h) as usize], vec![0.0; (w * h) as usize]];
    let movers = [(&demo.planes[2], 4.0 * k as f32), (&demo.planes[3], -2.0 * k as f32)];
    for (plane, vx) in movers {
        for y in plane.y0 * k..plane.y1 * k {
            for x in plane.x0 * k..plane.x1 * k {
                vector[0][(y * w + x) as usize] = -vx;
            }
        }
    }
    let name = format!("demo_{w}x{h}");
    write_scene(dir, &name, &scene)?;
    let opts = ExrWriteOptions { float32: true, ..ExrWriteOptions::default() };
    let vector_path = dir.join(format!("{name}_vector.exr"));
    let channels = [("X", &vector[0][..]), ("Y", &vector[1][..]), ("Z", &vector[0][..]), ("W", &vector[1][..])];
    write_exr_channels(&vector_path, w, h, &channels, &opts)?;
    Ok(["color", "depth", "vector"].map(|p| dir.join(format!("{name}_{p}.exr"))))
}

/// Every scene committed in testdata/, by file-name stem. `realcam synth` writes them; a test
/// checks that the committed files are exactly what this generator makes.
pub fn testdata_scenes() -> Vec<(&'static str, SynthScene)> {
    vec![
        ("demo", SynthScene::demo()),
        // A highlight of known energy (400 per channel) on a grey plane behind the focus plane
        // (6 m) and in front of it (1.2 m), for disk diameters and energy.
        ("point_bg", SynthScene::point_on_plane(256, 144, 6.0, [400.0; 3])),
        ("point_fg", SynthScene::point_on_plane(256, 144, 1.2, [400.0; 3])),
        // The same at the focus distance used by the tests (2 m).
        ("point_focus", SynthScene::point_on_plane(256, 144, 2.0, [400.0; 3])),
        // Left half at 2 m, right half at 8 m: depth edges.
        ("edges", SynthScene::two_planes(256, 144, 2.0, 8.0)),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scaled_demo_is_the_demo_k_times_as_large_and_its_subject_moves_4k_px_right() {
        let dir = std::env::temp_dir().join(format!("realcam_scaled_demo_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let [color, depth, vector] = write_scaled_demo(&dir, 2).expect("written");
        let sources = crate::io::PassSources {
            depth_path: Some(depth),
            velocity_path: Some(vector),
            velocity_format: crate::io::VelocityFormat::Blender,
            ..crate::io::PassSources::new(color)
        };
        let passes = crate::io::load_passes(&sources).expect("read back");
        assert_eq!((passes.color.width, passes.color.height), (1280, 720));
        let at = |x: u32, y: u32| (y * 1280 + x) as usize;
        // The subject card (250..430 x 100..260 at 640x360) at 2 m moves 8 px per frame right,
        // the pillar (40..130) at 0.8 m 4 px left, the far wall stands still.
        let v = passes.velocity_px.as_ref().expect("a velocity pass").data.clone();
        assert_eq!((passes.depth_m.data[at(680, 360)], v[2 * at(680, 360)], v[2 * at(680, 360) + 1]), (2.0, 8.0, 0.0));
        assert_eq!((passes.depth_m.data[at(170, 360)], v[2 * at(170, 360)]), (0.8, -4.0));
        assert_eq!((passes.depth_m.data[at(1000, 300)], v[2 * at(1000, 300)]), (8.0, 0.0));
        // Each highlight is still one pixel of the demo's value: (470, 85) is 500 x white.
        assert_eq!(passes.color.data[4 * at(940, 170)], 500.0);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn render_is_deterministic() {
        for scene in [SynthScene::demo(), SynthScene::two_planes(64, 32, 0.5, 5.0)] {
            let (c1, d1) = scene.render();
            let (c2, d2) = scene.render();
            let bits = |im: &Image| im.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&c1), bits(&c2));
            assert_eq!(bits(&d1), bits(&d2));
        }
    }

    #[test]
    fn point_on_plane_has_one_highlight_pixel() {
        let rgb = [100.0, 50.0, 25.0];
        let (color, depth) = SynthScene::point_on_plane(31, 20, 3.0, rgb).render();
        let hits: Vec<(u32, u32)> = (0..20)
            .flat_map(|y| (0..31).map(move |x| (x, y)))
            .filter(|&(x, y)| (0..3).all(|c| color.get(x, y, c) == rgb[c as usize]))
            .collect();
        assert_eq!(hits, vec![(15, 10)]);
        assert_eq!(color.get(0, 0, 0), 0.1);
        assert_eq!(color.get(15, 10, 3), 1.0);
        assert!(depth.data.iter().all(|&d| d == 3.0));
    }

    #[test]
    fn demo_and_two_planes_geometry() {
        let scene = SynthScene::demo();
        let (color, depth) = scene.render();
        assert_eq!((color.width, color.height, color.channels), (640, 360, 4));
        assert_eq!(depth.get(5, 5, 0), 1.0e10);
        assert_eq!(depth.get(340, 180, 0), 2.0);
        assert_eq!(depth.get(80, 180, 0), 0.8);
        assert_eq!(depth.get(600, 180, 0), 8.0);
        assert_eq!(depth.get(300, 60, 0), 1.2);
        assert_eq!(color.get(470, 85, 0), 500.0);
        let (_, d) = SynthScene::two_planes(16, 4, 1.0, 4.0).render();
        assert_eq!((d.get(7, 0, 0), d.get(8, 0, 0)), (1.0, 4.0));
    }

    #[test]
    fn write_scene_round_trips_exactly() {
        let dir = crate::io::test_dir("synth-write");
        let scene = SynthScene::two_planes(20, 10, 0.7, 6.0);
        write_scene(&dir, "tp", &scene).unwrap();
        let (color, depth) = scene.render();
        assert_eq!(crate::io::read_exr_rgba(&dir.join("tp_color.exr")).unwrap(), color);
        assert_eq!(crate::io::read_exr_channel(&dir.join("tp_depth.exr"), "Z").unwrap(), depth);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
