//! How a session tells its host what happens: messages (warnings, `--explain`, the outputs
//! written) and a sequence's progress. The command line reports on stderr, with a bar on a
//! terminal and the lines render farms read otherwise; a host passes its own [`Report`].
//!
//! A report never stops the work: a closed stderr (`realcam ... 2>&1 | head -2`) loses the
//! messages, not the frames.

use std::io::{IsTerminal, Write};

/// Where a session's messages and progress go. Called from the session's threads.
pub trait Report: Send + Sync {
    /// One message: a warning, `--explain`'s text, the outputs written.
    fn say(&self, text: &str);
    /// A sequence's frame `frame` finished (rendered, skipped or failed): `finished` of `total`.
    fn frame_finished(&self, frame: i64, finished: usize, total: usize) {
        let _ = (frame, finished, total);
    }
    /// The sequence ended.
    fn finish(&self) {}
}

/// Writes `text` and a newline to stderr, ignoring a stderr that is gone.
pub fn say_on_stderr(text: &str) {
    let mut err = std::io::stderr().lock();
    let _ = writeln!(err, "{text}");
}

/// The command line's report on stderr: a progress bar on a terminal; otherwise, after each
/// frame, the lines render-farm managers read (Open Job Description / AWS Deadline Cloud,
/// Tractor, Deadline 10 and others).
pub struct StderrReport {
    bar: Option<indicatif::ProgressBar>,
}

impl StderrReport {
    /// For a single frame, or a sequence of `total` frames (a bar on a terminal).
    pub fn new(total: Option<usize>) -> StderrReport {
        let bar = total.filter(|_| std::io::stderr().is_terminal()).map(|total| progress_bar(total as u64));
        StderrReport { bar }
    }
}

impl Report for StderrReport {
    fn say(&self, text: &str) {
        match &self.bar {
            Some(bar) => bar.suspend(|| say_on_stderr(text)),
            None => say_on_stderr(text),
        }
    }

    fn frame_finished(&self, frame: i64, finished: usize, total: usize) {
        match &self.bar {
            Some(bar) => {
                bar.set_message(format!("frame {frame}"));
                bar.inc(1);
            }
            None => {
                let percent = farm_percent(finished, total);
                say_on_stderr(&format!("openjd_progress: {percent}\nALF_PROGRESS {percent}%\nProgress: {percent}%"));
            }
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

/// A progress bar of `len` steps, showing each step's message.
pub fn progress_bar(len: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// Whole percent of `finished` of `total` frames, rounded down (100 only when all are).
pub fn farm_percent(finished: usize, total: usize) -> usize {
    (finished * 100).checked_div(total).unwrap_or(100)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn farm_percent_reaches_100_only_at_the_end() {
        assert_eq!(farm_percent(1, 3), 33);
        assert_eq!(farm_percent(2, 3), 66);
        assert_eq!(farm_percent(299, 300), 99);
        assert_eq!(farm_percent(3, 3), 100);
        assert_eq!(farm_percent(0, 0), 100);
    }
}

/// The process's peak resident memory so far (getrusage's ru_maxrss), in bytes; 0 where it cannot
/// be read. On a device that runs on the CPU (lavapipe) the GPU's memory is in it too.
pub fn host_peak_bytes() -> u64 {
    // SAFETY: getrusage only writes the struct it is given; a zeroed rusage is a valid one.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return 0;
    }
    usage.ru_maxrss.max(0) as u64 * 1024
}

/// [`host_peak_bytes`] as a line, with its bytes per pixel of a frame of `pixels`.
pub fn host_peak_line(pixels: u64) -> String {
    let bytes = host_peak_bytes();
    format!(
        "host memory peak so far: {:.1} MB, {:.0} bytes per pixel of the frame",
        bytes as f64 / 1e6,
        bytes as f64 / pixels.max(1) as f64
    )
}
