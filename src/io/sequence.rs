//! Frame sequences the way VFX tools name them: a path pattern with one frame-number token and
//! a frame range.
//!
//! Patterns ([`FramePattern`]): `####` (one digit of padding per `#`: `####` = 4 digits, `#` =
//! 1), the same with `@`, and printf's `%04d` / `%d`. Negative frames follow printf, where the
//! sign counts in the width (`%04d` and `####` of -5 give `-005`), as Nuke writes them.
//!
//! Ranges ([`FrameRange`]): comma-separated items, each a frame `1001`, a span `1001-1100`
//! (both ends included) or a stepped span `1001-1100x2` (or `1001-1100:2`, Open Job
//! Description's range expressions, which its chunks of a stepped range are written in);
//! negative frames as `-10--5` or `-3-3`. Frames are kept in the order given; a frame listed twice is refused.
//! A range of a million frames takes 8 MB (16 MB while it is checked).

use std::path::{Path, PathBuf};

/// The most frames one range may hold (a typo such as `1-100000000` is refused, not allocated).
pub const MAX_FRAMES: usize = 1_000_000;

/// The widest padding a pattern may ask for (an i64 has at most 19 digits and a sign).
const MAX_PADDING: usize = 20;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum SequenceError {
    #[error("pattern \"{pattern}\": {reason}")]
    Pattern { pattern: String, reason: String },
    #[error("frame range \"{range}\": {reason}")]
    Range { range: String, reason: String },
    #[error("chunk {index} of frame range \"{range}\" in chunks of {size}: {reason}")]
    Chunk { range: String, index: u64, size: usize, reason: String },
}

/// A path with one frame-number token; see the module docs. The text around the token is kept
/// as the path's bytes: a name that is not UTF-8 is written and read as it is (issue 34).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePattern {
    /// The bytes before the token.
    prefix: Vec<u8>,
    /// The bytes after the token.
    suffix: Vec<u8>,
    /// Width of the number including its sign (printf's `%0Nd`); 0 or 1: no padding.
    padding: usize,
}

impl FramePattern {
    /// The pattern of `path`, or None when it has no frame token (one file for every frame).
    /// A path with two tokens, a `%` that is not `%d`/`%0Nd` or a padding wider than 20 digits
    /// is an error.
    pub fn parse(path: &Path) -> Result<Option<FramePattern>, SequenceError> {
        use std::os::unix::ffi::OsStrExt;
        let bytes = path.as_os_str().as_bytes();
        // Messages show the path as text (bytes that are not UTF-8 as U+FFFD).
        let text = path.to_string_lossy().into_owned();
        let refuse = |reason: String| SequenceError::Pattern { pattern: text.clone(), reason };
        let shown = |range: std::ops::Range<usize>| String::from_utf8_lossy(&bytes[range]).into_owned();
        let mut found: Option<(usize, usize, usize)> = None; // byte start, byte end, padding
        let mut i = 0;
        while i < bytes.len() {
            let c = bytes[i];
            let token = match c {
                b'#' | b'@' => {
                    let run = bytes[i..].iter().take_while(|&&d| d == c).count();
                    i += run;
                    Some((i - run, i, run))
                }
                b'%' => {
                    let digits = shown(i + 1..i + 1 + bytes[i + 1..].iter().take_while(|d| d.is_ascii_digit()).count());
                    let after = i + 1 + digits.len();
                    if bytes.get(after) != Some(&b'd') {
                        return Err(refuse(format!(
                            "\"%\" at character {} is not a frame number (%d or %0Nd, e.g. %04d)",
                            shown(0..i).chars().count() + 1
                        )));
                    }
                    if !digits.is_empty() && !digits.starts_with('0') {
                        return Err(refuse(format!(
                            "\"%{digits}d\" pads with spaces; write \"%0{digits}d\" for a zero-padded frame number"
                        )));
                    }
                    let padding = if digits.is_empty() {
                        0
                    } else {
                        digits.parse::<usize>().map_err(|_| refuse(format!("\"%{digits}d\": width too large")))?
                    };
                    let start = i;
                    i = after + 1;
                    Some((start, i, padding))
                }
                _ => {
                    i += 1;
                    None
                }
            };
            if let Some(token) = token {
                if let Some(first) = found {
                    return Err(refuse(format!(
                        "two frame numbers (\"{}\" and \"{}\"); a pattern has one",
                        shown(first.0..first.1),
                        shown(token.0..token.1)
                    )));
                }
                found = Some(token);
            }
        }
        let Some((start, end, padding)) = found else { return Ok(None) };
        if padding > MAX_PADDING {
            return Err(refuse(format!("a padding of {padding} digits; at most {MAX_PADDING}")));
        }
        Ok(Some(FramePattern { prefix: bytes[..start].to_vec(), suffix: bytes[end..].to_vec(), padding }))
    }

    /// The path of `frame`.
    pub fn path(&self, frame: i64) -> PathBuf {
        use std::os::unix::ffi::OsStringExt;
        let number = format!("{:0width$}", frame, width = self.padding);
        let bytes = [self.prefix.as_slice(), number.as_bytes(), self.suffix.as_slice()].concat();
        PathBuf::from(std::ffi::OsString::from_vec(bytes))
    }
}

/// The frames of a range, in the order given; see the module docs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameRange {
    /// The range as written.
    pub text: String,
    pub frames: Vec<i64>,
}

impl FrameRange {
    pub fn parse(text: &str) -> Result<FrameRange, SequenceError> {
        let refuse = |reason: String| SequenceError::Range { range: text.to_string(), reason };
        let mut frames: Vec<i64> = Vec::new();
        for item in text.split(',') {
            let item = item.trim();
            if item.is_empty() {
                return Err(refuse("an empty item; write frames as 1001, 1001-1100 or 1001-1100x2".into()));
            }
            let (span, step) = match item.split_once(['x', ':']) {
                Some((span, step)) => {
                    let step: i64 = step
                        .trim()
                        .parse()
                        .map_err(|_| refuse(format!("\"{item}\": the step \"{step}\" is not a whole number")))?;
                    if step < 1 {
                        return Err(refuse(format!("\"{item}\": the step must be at least 1, got {step}")));
                    }
                    (span, Some(step))
                }
                None => (item, None),
            };
            let (first, last) = split_span(span)
                .ok_or_else(|| refuse(format!("\"{item}\" is not a frame, a span A-B or a stepped span A-BxN")))?;
            if step.is_some() && split_dash(span).is_none() {
                return Err(refuse(format!("\"{item}\": a step needs a span A-B")));
            }
            if last < first {
                return Err(refuse(format!("\"{item}\": the span ends before it starts ({last} < {first})")));
            }
            let step = step.unwrap_or(1);
            let count = ((last as i128 - first as i128) / step as i128 + 1) as u128;
            if count + frames.len() as u128 > MAX_FRAMES as u128 {
                return Err(refuse(format!("more than {MAX_FRAMES} frames")));
            }
            frames.reserve_exact(count as usize);
            let mut frame = first;
            while frame <= last {
                frames.push(frame);
                match frame.checked_add(step) {
                    Some(next) => frame = next,
                    None => break,
                }
            }
        }
        // A frame listed twice (the smallest such), found in a sorted copy: 8 bytes a frame.
        let mut sorted = frames.clone();
        sorted.sort_unstable();
        if let Some(pair) = sorted.windows(2).find(|pair| pair[0] == pair[1]) {
            return Err(refuse(format!("frame {} is listed twice", pair[0])));
        }
        Ok(FrameRange { text: text.to_string(), frames })
    }

    /// The `index`-th (from 0) group of `size` consecutive frames of this range: a render-farm
    /// array task's chunk.
    pub fn chunk(&self, index: u64, size: usize) -> Result<FrameRange, SequenceError> {
        let refuse = |reason: String| SequenceError::Chunk { range: self.text.clone(), index, size, reason };
        if size == 0 {
            return Err(refuse("the chunk size must be at least 1".into()));
        }
        let chunks = self.frames.len().div_ceil(size);
        let start = usize::try_from(index).ok().and_then(|i| i.checked_mul(size)).filter(|&s| s < self.frames.len());
        let Some(start) = start else {
            return Err(refuse(format!(
                "the range has {} frames, {chunks} chunk(s) (indices 0 to {})",
                self.frames.len(),
                chunks.saturating_sub(1)
            )));
        };
        let frames = self.frames[start..(start + size).min(self.frames.len())].to_vec();
        Ok(FrameRange { text: format!("{} (chunk {index} of {chunks})", self.text), frames })
    }
}

/// A span `A-B` (either end may be negative) or a single frame `A`, as (first, last).
fn split_span(span: &str) -> Option<(i64, i64)> {
    let span = span.trim();
    if let Ok(frame) = span.parse::<i64>() {
        return Some((frame, frame));
    }
    let (a, b) = split_dash(span)?;
    Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
}

/// `A-B` split at the dash between the two numbers (not a sign), if there is one.
fn split_dash(span: &str) -> Option<(&str, &str)> {
    let span = span.trim();
    // The separating dash follows a digit; a leading '-' is A's sign.
    let bytes = span.as_bytes();
    (1..bytes.len()).find(|&i| bytes[i] == b'-' && bytes[i - 1].is_ascii_digit()).map(|i| (&span[..i], &span[i + 1..]))
}

/// How much lower a sequence's reading and writing threads run than the thread that starts
/// them, in nice steps ([`yield_to_the_gpu`]; 19 is the lowest priority).
pub const IO_NICE_STEPS: i32 = 10;

/// When a sequence's reading and writing threads yield to the GPU: only where the device runs on
/// the CPU's own cores (a CPU Vulkan driver such as lavapipe), which is known once the device
/// has opened (beside the first frame's read). On a real GPU, or a farm node whose cores other
/// jobs share, they keep the render thread's priority.
#[derive(Debug, Default)]
pub struct IoPriority {
    device_on_cpu: std::sync::OnceLock<bool>,
}

impl IoPriority {
    /// The render thread, once the device has opened: whether it runs on the CPU.
    pub fn device_opened(&self, on_cpu: bool) {
        let _ = self.device_on_cpu.set(on_cpu);
    }

    /// A reading or writing thread, before each frame: its priority lowered once the device is
    /// known to run on the CPU (`lowered`: this thread's own record of having done it).
    pub fn before_frame(&self, lowered: &mut bool) {
        if !*lowered && self.device_on_cpu.get() == Some(&true) {
            yield_to_the_gpu();
            *lowered = true;
        }
    }
}

/// Lowers the calling thread's CPU priority by [`IO_NICE_STEPS`] (a process run at nice 0 gets
/// reading and writing threads at nice 10): a sequence's reading and writing threads
/// then fill the time the GPU leaves the cores instead of stretching its work. On a CPU Vulkan
/// driver (lavapipe) the "GPU" is threads on the same cores, and a dispatch split over them waits
/// for its slowest part, so a reader or writer taking a core mid-dispatch delays the frame more
/// than the time it takes ([`IoPriority`] calls it only for such a device). Best effort: a
/// failure only leaves the priority as it was.
pub fn yield_to_the_gpu() {
    #[cfg(target_os = "linux")]
    unsafe {
        // On Linux the nice value is per thread: `who` is the thread id. getpriority returns
        // the nice value itself (-1 is also its error value, which would give nice 9: harmless).
        let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
        let nice = libc::getpriority(libc::PRIO_PROCESS, tid);
        libc::setpriority(libc::PRIO_PROCESS, tid, (nice + IO_NICE_STEPS).min(19));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(text: &str) -> FramePattern {
        FramePattern::parse(Path::new(text)).unwrap().unwrap_or_else(|| panic!("{text}: no token"))
    }

    fn pattern_error(text: &str) -> String {
        FramePattern::parse(Path::new(text)).unwrap_err().to_string()
    }

    fn frames(text: &str) -> Vec<i64> {
        FrameRange::parse(text).unwrap_or_else(|e| panic!("{e}")).frames
    }

    fn range_error(text: &str) -> String {
        FrameRange::parse(text).unwrap_err().to_string()
    }

    #[test]
    fn hashes_pad_one_digit_each() {
        assert_eq!(pattern("shot/beauty.####.exr").path(1001), Path::new("shot/beauty.1001.exr"));
        assert_eq!(pattern("beauty.####.exr").path(7), Path::new("beauty.0007.exr"));
        assert_eq!(pattern("beauty.#.exr").path(7), Path::new("beauty.7.exr"));
        assert_eq!(pattern("beauty.######.exr").path(1001), Path::new("beauty.001001.exr"));
        // More digits than the padding: the number is not cut.
        assert_eq!(pattern("b.##.exr").path(12345), Path::new("b.12345.exr"));
    }

    #[test]
    fn at_signs_pad_like_hashes() {
        assert_eq!(pattern("beauty.@@@@.exr").path(42), Path::new("beauty.0042.exr"));
        assert_eq!(pattern("beauty.@.exr").path(42), Path::new("beauty.42.exr"));
    }

    #[test]
    fn printf_patterns() {
        assert_eq!(pattern("beauty.%04d.exr").path(12), Path::new("beauty.0012.exr"));
        assert_eq!(pattern("beauty.%d.exr").path(12), Path::new("beauty.12.exr"));
        assert_eq!(pattern("%03d_beauty.exr").path(5), Path::new("005_beauty.exr"));
        assert_eq!(pattern("beauty.%08d").path(1), Path::new("beauty.00000001"));
    }

    #[test]
    fn negative_frames_count_the_sign_in_the_width_as_printf() {
        assert_eq!(pattern("b.####.exr").path(-5), Path::new("b.-005.exr"));
        assert_eq!(pattern("b.%04d.exr").path(-5), Path::new("b.-005.exr"));
        assert_eq!(pattern("b.%d.exr").path(-12), Path::new("b.-12.exr"));
        assert_eq!(pattern("b.####.exr").path(-1234), Path::new("b.-1234.exr"));
        assert_eq!(pattern("b.####.exr").path(0), Path::new("b.0000.exr"));
    }

    #[test]
    fn bytes_that_are_not_utf8_are_kept() {
        use std::os::unix::ffi::OsStrExt;
        let raw = Path::new(std::ffi::OsStr::from_bytes(b"q\xfe.####.exr"));
        let p = FramePattern::parse(raw).unwrap().unwrap();
        assert_eq!(p.path(1).as_os_str().as_bytes(), b"q\xfe.0001.exr");
    }

    #[test]
    fn a_path_without_a_token_is_one_file_for_all_frames() {
        assert_eq!(FramePattern::parse(Path::new("depth/still.exr")), Ok(None));
    }

    #[test]
    fn bad_patterns_are_named() {
        assert_eq!(
            pattern_error("b.####.%04d.exr"),
            "pattern \"b.####.%04d.exr\": two frame numbers (\"####\" and \"%04d\"); a pattern has one"
        );
        assert_eq!(
            pattern_error("a#/b.#.exr"),
            "pattern \"a#/b.#.exr\": two frame numbers (\"#\" and \"#\"); a pattern has one"
        );
        assert_eq!(
            pattern_error("b.%s.exr"),
            "pattern \"b.%s.exr\": \"%\" at character 3 is not a frame number (%d or %0Nd, e.g. %04d)"
        );
        assert_eq!(
            pattern_error("b.%4d.exr"),
            "pattern \"b.%4d.exr\": \"%4d\" pads with spaces; write \"%04d\" for a zero-padded frame number"
        );
        assert_eq!(pattern_error("b.%030d.exr"), "pattern \"b.%030d.exr\": a padding of 30 digits; at most 20");
        // '#' and '@' touching are two tokens.
        assert!(pattern_error("b.##@@.exr").contains("two frame numbers (\"##\" and \"@@\")"));
    }

    #[test]
    fn ranges_in_each_syntax() {
        assert_eq!(frames("1001"), [1001]);
        assert_eq!(frames("1001-1005"), [1001, 1002, 1003, 1004, 1005]);
        assert_eq!(frames("1001-1010x3"), [1001, 1004, 1007, 1010]);
        assert_eq!(frames("1001-1011x3"), [1001, 1004, 1007, 1010]);
        assert_eq!(frames("1001,1005,1010-1012"), [1001, 1005, 1010, 1011, 1012]);
        assert_eq!(frames(" 1, 3-4 "), [1, 3, 4]);
        assert_eq!(frames("1001-1100").len(), 100);
        assert_eq!(frames("1-1"), [1]);
        // Open Job Description's step: its chunks of a stepped range come as "1003-1009:2".
        assert_eq!(frames("1003-1009:2"), [1003, 1005, 1007, 1009]);
        assert_eq!(frames("-3--1,1001"), [-3, -2, -1, 1001]);
    }

    #[test]
    fn negative_frames_in_ranges() {
        assert_eq!(frames("-3"), [-3]);
        assert_eq!(frames("-2-2"), [-2, -1, 0, 1, 2]);
        assert_eq!(frames("-10--8"), [-10, -9, -8]);
        assert_eq!(frames("-10--4x3"), [-10, -7, -4]);
        assert_eq!(frames("-5,5"), [-5, 5]);
    }

    #[test]
    fn bad_ranges_are_named() {
        assert_eq!(range_error(""), "frame range \"\": an empty item; write frames as 1001, 1001-1100 or 1001-1100x2");
        assert_eq!(
            range_error("1001,,1003"),
            "frame range \"1001,,1003\": an empty item; write frames as 1001, 1001-1100 or 1001-1100x2"
        );
        assert_eq!(
            range_error("1100-1001"),
            "frame range \"1100-1001\": \"1100-1001\": the span ends before it starts (1001 < 1100)"
        );
        assert_eq!(range_error("1-10x0"), "frame range \"1-10x0\": \"1-10x0\": the step must be at least 1, got 0");
        assert_eq!(range_error("1-10x-2"), "frame range \"1-10x-2\": \"1-10x-2\": the step must be at least 1, got -2");
        assert_eq!(range_error("1-10xa"), "frame range \"1-10xa\": \"1-10xa\": the step \"a\" is not a whole number");
        assert_eq!(
            range_error("a-b"),
            "frame range \"a-b\": \"a-b\" is not a frame, a span A-B or a stepped span A-BxN"
        );
        assert_eq!(range_error("1:10"), "frame range \"1:10\": \"1:10\": a step needs a span A-B");
        assert_eq!(
            range_error("1-9:2x2"),
            "frame range \"1-9:2x2\": \"1-9:2x2\": the step \"2x2\" is not a whole number"
        );
        assert_eq!(range_error("5x2"), "frame range \"5x2\": \"5x2\": a step needs a span A-B");
        assert_eq!(range_error("1-5,3"), "frame range \"1-5,3\": frame 3 is listed twice");
        assert_eq!(range_error("1-100000000"), "frame range \"1-100000000\": more than 1000000 frames");
        assert_eq!(
            range_error("-9223372036854775808-9223372036854775807"),
            "frame range \"-9223372036854775808-9223372036854775807\": more than 1000000 frames"
        );
    }

    #[test]
    fn chunks_split_the_range_for_array_tasks() {
        let range = FrameRange::parse("1001-1006,1010").unwrap();
        assert_eq!(range.chunk(0, 2).unwrap().frames, [1001, 1002]);
        assert_eq!(range.chunk(2, 2).unwrap().frames, [1005, 1006]);
        assert_eq!(range.chunk(3, 2).unwrap().frames, [1010]);
        assert_eq!(range.chunk(0, 100).unwrap().frames.len(), 7);
        assert_eq!(
            range.chunk(4, 2).unwrap_err().to_string(),
            "chunk 4 of frame range \"1001-1006,1010\" in chunks of 2: the range has 7 frames, 4 chunk(s) (indices 0 to 3)"
        );
        assert_eq!(
            range.chunk(0, 0).unwrap_err().to_string(),
            "chunk 0 of frame range \"1001-1006,1010\" in chunks of 0: the chunk size must be at least 1"
        );
        assert!(range.chunk(u64::MAX, 2).is_err());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn the_io_threads_yield_only_to_a_device_on_the_cpu_and_only_themselves() {
        let nice_of = |tid: libc::id_t| unsafe { libc::getpriority(libc::PRIO_PROCESS, tid) };
        let tid = || unsafe { libc::syscall(libc::SYS_gettid) as libc::id_t };
        let main = tid();
        let before = nice_of(main);
        // A thread's nice value after each step: device unknown, then opened (on_cpu).
        let io_thread = |on_cpu: bool| {
            std::thread::spawn(move || {
                let priority = IoPriority::default();
                let mut lowered = false;
                priority.before_frame(&mut lowered);
                let unknown = nice_of(tid());
                priority.device_opened(on_cpu);
                priority.before_frame(&mut lowered);
                priority.before_frame(&mut lowered);
                (tid(), unknown, nice_of(tid()))
            })
            .join()
            .unwrap()
        };
        let (io, unknown, lowered) = io_thread(true);
        assert_ne!(io, main);
        // A thread starts at its creator's nice value; on a CPU device it drops IO_NICE_STEPS
        // once (not once per frame), and only that thread does.
        assert_eq!((unknown, lowered), (before, (before + IO_NICE_STEPS).min(19)), "on the CPU");
        assert_eq!(nice_of(main), before, "the calling thread only");
        let (_, unknown, kept) = io_thread(false);
        assert_eq!((unknown, kept), (before, before), "on a GPU");
    }
}
