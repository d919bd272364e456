//! `--frames` and the other flags of a sequence.

use crate::io::sequence::FrameRange;
use crate::session::SequenceSettings;
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Clone, Default)]
pub struct SequenceArgs {
    /// Render a frame sequence: 1001-1100, 1001-1100x2 (every 2nd; 1001-1100:2 alike),
    /// 1001,1005,1010-1020, -5--1.
    /// The paths of --color, --depth, --velocity, --output, --png and --trace carry the frame
    /// number as #### (one digit per #; @ alike) or %04d; an input without one is every frame's.
    #[arg(long, value_name = "RANGE", allow_hyphen_values = true)]
    pub frames: Option<String>,
    /// Render one chunk of --frames: the environment variable VAR holds the chunk's index from 0
    /// (a farm array task: SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX, ...).
    #[arg(long = "frames-from-env", value_name = "VAR", requires = "frames")]
    pub frames_from_env: Option<String>,
    /// Frames per chunk of --frames-from-env.
    #[arg(long = "chunk-size", value_name = "N", default_value_t = 1)]
    pub chunk_size: usize,
    /// Skip a frame whose outputs all exist (to resume an interrupted sequence).
    #[arg(long = "skip-existing", requires = "frames")]
    pub skip_existing: bool,
    /// Stop at the first frame that fails (by default it is reported and the others go on).
    #[arg(long = "fail-fast", requires = "frames")]
    pub fail_fast: bool,
    /// Accumulate the frames of --frames into one exposure, the average of their light (Kyaw
    /// 2013 sec. 7.4) as sensor values, then exposed on the film once (its grain and curve),
    /// written to --output (a path without a frame number).
    #[arg(long = "long-exposure", requires = "frames", conflicts_with = "skip_existing")]
    pub long_exposure: bool,
    /// The long exposure's state: written (atomically) after every frame, read at the start,
    /// so that a stopped exposure resumes where it was (the frames in it are not rendered again).
    #[arg(long, value_name = "FILE", requires = "long_exposure")]
    pub state: Option<PathBuf>,
}

/// The frames to render: --frames, or its chunk that --frames-from-env names.
fn frames(args: &SequenceArgs) -> Result<FrameRange> {
    let text = args.frames.as_deref().unwrap_or_default();
    let range = FrameRange::parse(text).context("--frames")?;
    let Some(var) = &args.frames_from_env else { return Ok(range) };
    let value = std::env::var(var)
        .map_err(|_| anyhow::anyhow!("--frames-from-env: the environment variable {var} is not set"))?;
    let index: u64 = value.trim().parse().map_err(|_| {
        anyhow::anyhow!("--frames-from-env: {var}={value:?} is not a chunk index (a whole number from 0)")
    })?;
    range.chunk(index, args.chunk_size).context("--frames-from-env")
}

impl SequenceArgs {
    /// The sequence these flags ask for; None without --frames.
    pub fn settings(&self) -> Result<Option<SequenceSettings>> {
        if self.frames.is_none() {
            return Ok(None);
        }
        Ok(Some(SequenceSettings {
            range: frames(self)?,
            skip_existing: self.skip_existing,
            fail_fast: self.fail_fast,
            long_exposure: self.long_exposure,
            state: self.state.clone(),
        }))
    }
}
