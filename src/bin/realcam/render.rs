//! `realcam render`: the flags turned into the session's settings, and the session run.

use anyhow::Result;
use realcam::flags::RenderArgs;
use realcam::session::{self, Session, StderrReport};
use std::sync::Arc;

/// Renders what `args` asks; a single frame's session comes back still open, every output
/// written and renamed, for `main` to end the process without closing its GPU.
pub fn run(args: &RenderArgs) -> Result<Option<Session>> {
    let settings = args.settings();
    let sequence = args.sequence.settings()?;
    let shot = args.shot_camera()?;
    args.check_single_frame(&shot)?;
    if let Some(sequence) = sequence {
        let report = Arc::new(StderrReport::new(Some(sequence.range.frames.len())));
        return session::render_sequence(&settings, &sequence, &shot, report).map(|()| None);
    }
    let report = Arc::new(StderrReport::new(None));
    let (session, paths) = session::render_single(&settings, &shot, args.frame(), report)?;
    for path in paths {
        session.report().say(&format!("wrote {}", path.display()));
    }
    Ok(Some(session))
}
