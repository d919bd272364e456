//! Decides which passes a frame and camera call for, and says why (`--explain`): walks the pass
//! order and asks every pass to plan itself. A pass whose effect would be invisible is not
//! recorded and its pipeline is never created.

use crate::model::camera::{Camera, FilmMode};
use crate::model::frame::Frame;
use crate::passes::{Input, Pass, PlanInput, PlannedPass, SceneFacts, PASS_ORDER};

pub use crate::passes::scene::{VISIBLE_COC_PX, VISIBLE_FALLOFF};

/// The plan's name for the tiled depth-of-field path.
pub const BOKEH_TILED: &str = crate::passes::dof::tiled::NAME;

/// The passes of [`PASS_ORDER`], each planned: run (with each run's parameters) or skip, and why.
#[derive(Debug)]
pub struct Plan {
    /// One per entry of the pass order, in order.
    pub passes: Vec<PlannedPass>,
    /// What the passes planned from.
    pub facts: SceneFacts,
    /// Effects the frame asks for that no pass renders yet (listed by `--explain`).
    pub notes: Vec<PlannedPass>,
    /// The CoC clamp, when it changes the picture (also in the coc pass's reason).
    pub coc_clamp_warning: Option<String>,
}

pub fn plan(frame: &Frame, camera: &Camera) -> Plan {
    plan_of(PlanInput::new(frame, camera))
}

/// [`plan`] for a render that does not print it (`--explain` off): the same passes and
/// decisions, without the counts only `--explain` prints.
pub fn plan_unexplained(frame: &Frame, camera: &Camera) -> Plan {
    plan_of(PlanInput::unexplained(frame, camera))
}

fn plan_of(input: PlanInput) -> Plan {
    let camera = input.camera;
    let passes = PASS_ORDER.iter().map(|entry| entry.plan(&input)).collect();
    let coc_clamp_warning = if input.facts.dof_visible() { input.facts.coc_clamp_note(camera) } else { None };
    Plan { passes, facts: input.facts, notes: Vec::new(), coc_clamp_warning }
}

/// The plan of `band`, a band of a frame whose plan is `whole`: the passes plan from the band's
/// pixels, size and optical centre but from the whole frame's facts (its CoC range and clamp).
pub fn plan_band(band: &Frame, camera: &Camera, whole: &Plan) -> Plan {
    let input = PlanInput::with_facts(band, camera, whole.facts.clone());
    let passes = PASS_ORDER.iter().map(|entry| entry.plan(&input)).collect();
    Plan { passes, facts: input.facts, notes: Vec::new(), coc_clamp_warning: None }
}

/// The camera of a long exposure's frames (Kyaw 2013 sec. 7.4): `camera` up to the sensor. The
/// frames' light is averaged as sensor values (after the exposure gain, before the grain and
/// the film curve, which only the film pass applies), and [`film_plan`] then exposes the average
/// on the film once, as a real long exposure is read out once.
pub fn sensor_camera(camera: &Camera) -> Camera {
    Camera { film: FilmMode::Linear, grain: 0.0, ..camera.clone() }
}

/// Whether `camera`'s film changes sensor values (a curve or grain): a long exposure through it
/// needs [`film_plan`] after the average.
pub fn film_changes_sensor_values(camera: &Camera) -> bool {
    !matches!(camera.film, FilmMode::Linear) || camera.noise_sigma() > 0.0
}

/// The plan that exposes `average`, a long exposure's average of sensor values from
/// [`sensor_camera`], on `camera`'s film: only the film pass runs, with its grain and curve and
/// without the exposure gain or the vignette's falloff, which the film applies where the
/// vignette runs (the frames had both).
pub fn film_plan(average: &Frame, camera: &Camera) -> Plan {
    let film_camera = Camera { exposure: false, vignetting: false, ..camera.clone() };
    let input = PlanInput::new(average, &film_camera);
    let passes = PASS_ORDER
        .iter()
        .map(|entry| match entry.name == crate::passes::film::NAME {
            true => entry.plan(&input),
            false => PlannedPass::not_built(entry.name, "the frames of the long exposure had it".into()),
        })
        .collect();
    Plan { passes, facts: input.facts, notes: Vec::new(), coc_clamp_warning: None }
}

impl Plan {
    /// Whether the pass called `name` runs.
    pub fn runs(&self, name: &str) -> bool {
        self.passes.iter().any(|p| p.name == name && p.runs())
    }

    /// Whether any pass runs.
    pub fn runs_any(&self) -> bool {
        self.passes.iter().any(|p| p.runs())
    }

    /// Whether a running pass reads this frame input.
    pub fn needs(&self, input: Input) -> bool {
        PASS_ORDER.iter().zip(&self.passes).any(|(entry, planned)| planned.runs() && entry.inputs.contains(&input))
    }

    /// Signed CoC range over the frame in pixels (after the user clamp).
    pub fn coc_range_px(&self) -> (f64, f64) {
        self.facts.coc_range_px
    }

    /// The parameters of the first run of pass `P`, if it runs.
    pub fn params<P: Pass>(&self) -> Option<&P::Params> {
        self.planned::<P>().and_then(|p| p.params::<P>().next())
    }

    /// The parameters of every run of pass `P`, to change a setting (e.g. a quality knob).
    pub fn params_mut<P: Pass>(&mut self) -> impl Iterator<Item = &mut P::Params> {
        self.passes.iter_mut().filter(|p| p.name == P::NAME).flat_map(|p| p.params_mut::<P>())
    }

    /// The planned entry of pass `P`.
    pub fn planned<P: Pass>(&self) -> Option<&PlannedPass> {
        self.passes.iter().find(|p| p.name == P::NAME)
    }

    /// Make pass `P` run once with these parameters, whatever it planned (tests that force a
    /// pass on a scene where it would be invisible).
    pub fn force<P: Pass>(&mut self, params: P::Params) {
        if let Some(p) = self.passes.iter_mut().find(|p| p.name == P::NAME) {
            p.set_runs::<P>(vec![params], "forced");
        }
    }

    /// Make pass `P` run with these parameters, and why.
    pub fn set_runs<P: Pass>(&mut self, runs: Vec<P::Params>, why: impl Into<String>) {
        if let Some(p) = self.passes.iter_mut().find(|p| p.name == P::NAME) {
            p.set_runs::<P>(runs, why);
        }
    }

    /// Keep only the runs of the passes at `range` of the pass order (banded rendering's rounds).
    pub fn keep_only(&mut self, range: std::ops::Range<usize>) {
        for (i, p) in self.passes.iter_mut().enumerate() {
            if !range.contains(&i) && p.runs() {
                p.clear_runs(format!("{} (in another round of bands)", p.why));
            }
        }
    }

    /// Skip pass `P` whatever it planned.
    pub fn skip<P: Pass>(&mut self) {
        if let Some(p) = self.passes.iter_mut().find(|p| p.name == P::NAME) {
            p.set_runs::<P>(Vec::new(), "skipped");
        }
    }

    /// The plan as text: one line per pass, run or skipped, and why (methods the user did not
    /// choose are left out).
    pub fn explain(&self) -> String {
        let mut out = String::from("pass plan:\n");
        for p in self.passes.iter().chain(&self.notes).filter(|p| p.listed) {
            let runs = p.run_params().count();
            let times = if runs > 1 { format!(" (x{runs})") } else { String::new() };
            out += &format!("  [{}] {:<13} {}{times}\n", if p.runs() { "run " } else { "skip" }, p.name, p.why);
        }
        out
    }
}

/// The pass order as text, one pass per line (for the README and `realcam passes`).
pub fn pass_order() -> String {
    PASS_ORDER.iter().enumerate().map(|(i, e)| format!("{}. {}\n", i + 1, e.name)).collect()
}

#[cfg(test)]
mod tests {
    use crate::io::lens_file::LensFile;
    use crate::model::camera::{Camera, CameraRequest, CocLimit};
    use crate::model::frame::Frame;

    /// A frame `width` px wide (16:9, the data window two pixels of it): a plane at 0.3 m and
    /// the sky.
    fn near_and_sky(width: u32) -> Frame {
        let height = width * 9 / 16;
        Frame {
            display_window: (0, 0, width, height),
            centre_px: [width as f64 / 2.0, height as f64 / 2.0],
            // One row of the frame (the clamp is at most twice the data window's diagonal).
            ..Frame::new(
                width,
                1,
                vec![0.5; 4 * width as usize],
                [0.3].into_iter().chain(vec![1.0e10; width as usize - 1]).collect(),
            )
        }
    }

    #[test]
    fn no_clamp_by_default_but_the_frame_cover() {
        // 50 mm f/1.4 focused at 0.5 m on full frame: at 1280 px the plane at 0.3 m has a CoC
        // of -89 px, drawn as it is; only the safety limit (twice the frame's diagonal) holds.
        let request = CameraRequest { force: true, ..CameraRequest::default().with_lens(50.0, 1.4, 0.5) };
        let camera = Camera::new(&LensFile::default_lens(), &request).unwrap();
        assert_eq!(camera.max_coc, CocLimit::None);
        let plan = super::plan(&near_and_sky(1280), &camera);
        assert_eq!(plan.facts.coc_range_px, plan.facts.unclamped_coc_range_px);
        assert!(plan.facts.coc_range_px.0 < -88.0, "{:?}", plan.facts.coc_range_px);
        assert!(plan.facts.clamp_is_frame_cover);
        assert_eq!(plan.facts.max_coc_px, 2.0 * 1280f64.hypot(1.0));
        assert_eq!(plan.coc_clamp_warning, None);
    }

    #[test]
    fn a_clamp_on_the_film_is_the_same_part_of_the_frame_at_every_resolution() {
        // 50 mm f/1.4 focused at 0.5 m on full frame: at 1280 px the plane at 0.3 m has a CoC
        // of -89 px; 1.2 mm on the film is 42.67 px there and 128 px at 3840.
        let request = CameraRequest {
            force: true,
            max_coc: CocLimit::FilmMm(1.2),
            ..CameraRequest::default().with_lens(50.0, 1.4, 0.5)
        };
        let camera = Camera::new(&LensFile::default_lens(), &request).unwrap();
        let (low, high) = (super::plan(&near_and_sky(1280), &camera), super::plan(&near_and_sky(3840), &camera));
        let relative = |p: &super::Plan, width: f64| {
            let f = &p.facts;
            [f.max_coc_px, f.coc_range_px.0, f.coc_range_px.1, f.sa_full_strength_coc_px].map(|v| v / width)
        };
        let (a, b) = (relative(&low, 1280.0), relative(&high, 3840.0));
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-12, "{a:?} at 1280 px, {b:?} at 3840 px");
        }
        assert!((low.facts.max_coc_px - 1280.0 / 30.0).abs() < 1e-9, "{}", low.facts.max_coc_px);
        assert_eq!(low.facts.coc_range_px.0, -low.facts.max_coc_px);
        // The clamp changes the picture: said in the plan and as a warning, with the true range.
        let (lo, hi) = low.facts.unclamped_coc_range_px;
        let warning = low.coc_clamp_warning.clone().expect("a warning");
        assert_eq!(
            warning,
            format!("the CoC is clamped to +-42.67 px (1.2 mm on the film): the lens gives {lo:.2} to {hi:.2} px in this frame, so the clamp changes the picture")
        );
        assert!(low.explain().contains(&warning), "{}", low.explain());
        assert!(high.coc_clamp_warning.as_deref().is_some_and(|w| w.starts_with("the CoC is clamped to +-128.00 px")));
        // A clamp in pixels is the user's: the same 64 px is a third of the part at 3840.
        let px = Camera { max_coc: CocLimit::Px(64.0), ..camera.clone() };
        assert_eq!(super::plan(&near_and_sky(3840), &px).facts.max_coc_px, 64.0);
        // A clamp that does not bind says nothing.
        let wide = Camera { max_coc: CocLimit::FilmMm(5.0), ..camera };
        let plan = super::plan(&near_and_sky(1280), &wide);
        assert_eq!((plan.coc_clamp_warning, plan.facts.coc_range_px), (None, plan.facts.unclamped_coc_range_px));
    }

    #[test]
    fn depth_0_1e30_and_infinity_give_finite_cocs() {
        // 50 mm f/2 focused at 2 m on full frame, 1920 px wide: depth 0 is clamped to the near
        // limit, 1e30 m and +inf both give the CoC at infinity, v^2 / (N' P S) (Kyaw eq 5.3).
        let request = CameraRequest::default().with_lens(50.0, 2.0, 2.0);
        let camera = Camera::new(&LensFile::default_lens(), &request).unwrap();
        // 64 px of the row (the clamp's frame cover, twice the diagonal, is 128 px).
        let mut depth_m = vec![2.0f32; 64];
        depth_m[..4].copy_from_slice(&[0.0, 2.0, 1.0e30, f32::INFINITY]);
        let frame = Frame {
            display_window: (0, 0, 1920, 1080),
            centre_px: [960.0, 540.0],
            ..Frame::new(64, 1, vec![0.5; 256], depth_m)
        };
        let facts = &super::plan(&frame, &camera).facts;
        let pitch = 36.0 / 1920.0;
        let l = &camera.lens;
        let v = l.image_distance_mm();
        let at_infinity_px = v * v / (l.effective_f_number() * l.pupil_magnification * 2000.0) / pitch;
        assert_eq!(facts.coc_range_px.0, -facts.max_coc_px);
        assert!((facts.coc_range_px.1 - at_infinity_px).abs() < 1e-9, "{:?} vs {at_infinity_px}", facts.coc_range_px);
        // The CoC pass's twin, per pixel, in f32.
        let push = crate::passes::dof::coc_push::CocPush::for_frame(&camera, pitch, &frame);
        let cocs: Vec<f32> = frame.depth_m.iter().map(|&d| push.coc_px(d)).collect();
        assert!(cocs.iter().all(|c| c.is_finite()), "{cocs:?}");
        assert_eq!(cocs[0], -facts.max_coc_px as f32);
        assert_eq!(cocs[1], 0.0);
        assert_eq!(cocs[2], cocs[3]);
        assert!((cocs[3] as f64 - at_infinity_px).abs() < 1e-3 * at_infinity_px);
    }

    #[test]
    fn the_clamp_is_at_most_twice_the_frame_diagonal() {
        // A 4x3 px data window in a 100000 px wide display window (a hostile header): 1.2 mm on
        // the film would be 3333 px, but no offset in the frame exceeds its 5 px diagonal. The
        // CoC pass clamps the same; the warning names the frame, not --max-coc.
        let request = CameraRequest { force: true, ..CameraRequest::default().with_lens(50.0, 1.4, 0.5) };
        let camera = Camera::new(&LensFile::default_lens(), &request).unwrap();
        let frame = Frame {
            display_window: (0, 0, 100_000, 75_000),
            centre_px: [50_000.0, 37_500.0],
            ..Frame::new(4, 3, vec![0.5; 48], vec![0.3; 12])
        };
        let plan = super::plan(&frame, &camera);
        assert_eq!(plan.facts.max_coc_px, 10.0);
        assert!(plan.facts.clamp_is_frame_cover);
        assert_eq!(plan.facts.coc_range_px, (-10.0, -10.0));
        let warning = plan.coc_clamp_warning.expect("a warning");
        assert!(
            warning.starts_with("the CoC is clamped to +-10.00 px (twice the frame's diagonal, the safety limit"),
            "{warning}"
        );
        let push = crate::passes::dof::coc_push::CocPush::for_frame(&camera, plan.facts.pixel_pitch_mm, &frame);
        assert_eq!(push.coc_px(0.3), -10.0);
    }

    #[test]
    fn the_readme_quotes_the_pass_order() {
        let readme = include_str!("../../README.md");
        let quoted = readme
            .split("<!-- pass-order -->\n")
            .nth(1)
            .and_then(|rest| rest.split("<!-- /pass-order -->").next())
            .expect("README.md has a pass-order block");
        assert_eq!(quoted, super::pass_order(), "README.md's pass order differs from PASS_ORDER");
    }
}
