//! Decides which passes a frame and camera call for, and says why (`--explain`): walks the pass
//! order and asks every pass to plan itself. A pass whose effect would be invisible is not
//! recorded and its pipeline is never created.

use crate::model::camera::Camera;
use crate::model::frame::Frame;
use crate::passes::{Input, Pass, PlanInput, PlannedPass, SceneFacts, PASS_ORDER};

pub use crate::passes::scene::{VISIBLE_COC_PX, VISIBLE_FALLOFF};

/// The plan's name for the tiled depth-of-field path.
pub const BOKEH_TILED: &str = crate::passes::tiled_dof::NAME;

/// The passes of [`PASS_ORDER`], each planned: run (with each run's parameters) or skip, and why.
#[derive(Debug)]
pub struct Plan {
    /// One per entry of the pass order, in order.
    pub passes: Vec<PlannedPass>,
    /// What the passes planned from.
    pub facts: SceneFacts,
    /// Effects the frame asks for that no pass renders yet (listed by `--explain`).
    pub notes: Vec<PlannedPass>,
}

pub fn plan(frame: &Frame, camera: &Camera) -> Plan {
    let input = PlanInput::new(frame, camera);
    let passes = PASS_ORDER.iter().map(|entry| entry.plan(&input)).collect();
    Plan { passes, facts: input.facts, notes: Vec::new() }
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
