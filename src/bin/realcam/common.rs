//! What several subcommands share: the lens and GPU flags (from the library's `flags`),
//! writing text files, progress bars.

use anyhow::Result;
pub use realcam::flags::{GpuArgs, LensArgs};
pub use realcam::session::report::progress_bar;
use std::path::Path;

/// Writes `text` to `path` through a temporary beside it (`realcam::io::output`): a failed
/// write leaves an existing `path` as it was; a path that is not a regular file is refused.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    Ok(realcam::io::output::write_file("output", path, text.as_bytes())?)
}

/// The command line as typed, for the reports that record it.
pub fn command_line() -> String {
    std::env::args().collect::<Vec<_>>().join(" ")
}
