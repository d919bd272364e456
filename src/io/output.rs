//! Output files, so that a run never loses a file:
//!
//! - [`Outputs::new`] checks every output of a run before any work: the folder exists and takes
//!   a new file, the target is absent or a regular file (never a device, FIFO, symlink or
//!   folder), no target is an input of the run (same file, whatever the path says) or another
//!   output. It reserves a temporary file beside each target at once, which proves the folder
//!   writable.
//! - [`Outputs::write`] fills a temporary; [`Outputs::commit`] renames them all onto their
//!   targets only when every one was written. Dropped uncommitted (a failed run), the
//!   temporaries are removed and the targets stay as they were.
//! - [`remove_temporaries_on_signals`]: SIGINT, SIGTERM and SIGHUP remove the temporaries
//!   before the process ends. A process killed outright (SIGKILL) leaves its temporaries; the
//!   next run into the same folder removes those of dead processes of this host (the name
//!   carries host and process id, so a folder shared by a render farm is safe).

use super::sequence::FramePattern;
use super::IoError;
use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// Temporaries of this process not yet renamed or removed (for the signal handler).
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The part of a temporary's name between the target's name and the owner.
const TMP_TAG: &str = ".realcam-";
const TMP_SUFFIX: &str = ".tmp";

/// This host's name, as temporaries carry it (characters other than ASCII letters, digits
/// and `.` replaced by `_`).
fn host_name() -> String {
    let raw = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "host".into());
    raw.trim().chars().map(|c| if c.is_ascii_alphanumeric() || c == '.' { c } else { '_' }).collect()
}

/// The longest file name Linux's file systems take, in bytes.
const NAME_MAX_BYTES: usize = 255;

/// `.NAME.realcam-HOST-PID-N.tmp` beside `target`, NAME cut short (at a character) so that the
/// whole stays within [`NAME_MAX_BYTES`]: the process id and counter keep it unique.
fn temporary_name(name: &OsStr) -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let owner = format!(
        "{TMP_TAG}{}-{}-{}{TMP_SUFFIX}",
        host_name(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    );
    let name = name.to_string_lossy();
    let mut keep = NAME_MAX_BYTES.saturating_sub(1 + owner.len()).min(name.len());
    while !name.is_char_boundary(keep) {
        keep -= 1;
    }
    format!(".{}{owner}", &name[..keep])
}

/// The host and process id of a temporary's name, if it is one of realcam's.
fn temporary_owner(name: &str) -> Option<(&str, u32)> {
    let rest = name.strip_prefix('.')?.strip_suffix(TMP_SUFFIX)?;
    let (rest, _counter) = rest.rsplit_once('-')?;
    let (rest, pid) = rest.rsplit_once('-')?;
    let (_, host) = rest.rsplit_once(TMP_TAG)?;
    Some((host, pid.parse().ok()?))
}

/// Whether process `pid` of this host exists.
fn process_alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else { return false };
    // SAFETY: kill with signal 0 only checks that the process exists and may be signalled.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

/// Removes the temporaries that processes of this host which no longer exist left in `dir`;
/// returns how many.
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let host = host_name();
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some((owner, pid)) = name.to_str().and_then(temporary_owner) else { continue };
        let stale = owner == host && !process_alive(pid) && entry.file_type().is_ok_and(|t| t.is_file());
        if stale && std::fs::remove_file(entry.path()).is_ok() {
            log::info!("removed {}, left by process {pid} which no longer runs", entry.path().display());
            removed += 1;
        }
    }
    removed
}

fn forget(tmp: &Path) {
    let mut live = LIVE.lock().unwrap_or_else(|p| p.into_inner());
    live.retain(|p| p != tmp);
}

/// What a non-regular file is, in words.
fn file_kind(t: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_symlink() {
        "a symbolic link"
    } else if t.is_dir() {
        "a folder"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

/// One output of a run.
struct Output {
    field: &'static str,
    path: PathBuf,
    tmp: PathBuf,
    written: bool,
}

/// The outputs of one run, checked and reserved; see the module docs.
pub struct Outputs {
    files: Vec<Output>,
}

/// A path made absolute through its folder's real path (the file itself need not exist).
fn resolved(path: &Path, dir: &Path, name: &OsStr) -> PathBuf {
    std::fs::canonicalize(dir).map(|d| d.join(name)).unwrap_or_else(|_| path.to_path_buf())
}

/// The files a run reads, each with what it is (`color pass`, `lens file`, ...), indexed so that
/// an output can be looked up among the thousands of files of a sequence: by real path (the
/// folder's real path and the name, or the whole real path of a symbolic link) and, for the
/// files that exist, by device and inode (hard links). A sequence's numbered files are kept as
/// their pattern and the frames, and each file as two 32-bit hashes (8 bytes a file, 8 MB for
/// a million frames); a hash that matches is confirmed on the file itself.
#[derive(Default)]
pub struct InputFiles {
    /// The files added one by one: what each is, its path.
    files: Vec<(&'static str, PathBuf)>,
    /// The numbered files: what they are and their pattern, each for every frame of `frames`.
    sequences: Vec<(&'static str, FramePattern)>,
    frames: Vec<i64>,
    /// (hash of the real path, file) and (hash of device and inode, file); a file is an index
    /// of `files`, or [`SEQUENCE_BIT`] and a position among the numbered files.
    by_path: Vec<(u32, u32)>,
    by_inode: Vec<(u32, u32)>,
    /// Whether the two lists are sorted (they are, from the first look-up).
    sorted: bool,
    /// Real paths of the folders seen (None: the folder does not resolve); at most
    /// [`MAX_FOLDERS`] at once.
    folders: std::collections::HashMap<PathBuf, Option<PathBuf>>,
}

/// The bit of an [`InputFiles`] file number that marks a numbered file.
const SEQUENCE_BIT: u32 = 1 << 31;

/// How many folders' real paths [`InputFiles`] keeps (a frame number in the folder's name
/// would otherwise keep one per frame).
const MAX_FOLDERS: usize = 4096;

/// A 32-bit hash of `value` (the same in every run).
fn hash32(value: &impl std::hash::Hash) -> u32 {
    use std::hash::Hasher;
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    value.hash(&mut hasher);
    hasher.finish() as u32
}

impl InputFiles {
    /// The files of `inputs`, (what each is, its path).
    pub fn new(inputs: impl IntoIterator<Item = (&'static str, PathBuf)>) -> InputFiles {
        let mut set = InputFiles::default();
        for (what, path) in inputs {
            set.add(what, path);
        }
        set
    }

    /// Adds the file `path`, which is `what`.
    pub fn add(&mut self, what: &'static str, path: PathBuf) {
        let index = self.files.len() as u32;
        self.index(&path, index);
        self.files.push((what, path));
    }

    /// Adds the file of each of `frames` that `pattern` names, which are `what`. Every
    /// sequence of a set has the same frames (one copy of them is kept); other frames are
    /// added file by file.
    pub fn add_frames(&mut self, what: &'static str, pattern: &FramePattern, frames: &[i64]) {
        if self.sequences.is_empty() {
            self.frames = frames.to_vec();
        } else if self.frames != frames {
            frames.iter().for_each(|&f| self.add(what, pattern.path(f)));
            return;
        }
        let first = self.sequences.len() * self.frames.len();
        self.sequences.push((what, pattern.clone()));
        for (k, &frame) in frames.iter().enumerate() {
            self.index(&pattern.path(frame), SEQUENCE_BIT | (first + k) as u32);
        }
    }

    /// Indexes the file `path` as `file`.
    fn index(&mut self, path: &Path, file: u32) {
        let (real, id) = self.identify(path);
        self.by_path.push((hash32(&real), file));
        if let Some(id) = id {
            self.by_inode.push((hash32(&id), file));
        }
        self.sorted = false;
    }

    /// What `file` (a number of [`InputFiles::index`]) is, and its path.
    fn file(&self, file: u32) -> (&'static str, PathBuf) {
        if file & SEQUENCE_BIT == 0 {
            return self.files[file as usize].clone();
        }
        let position = (file & !SEQUENCE_BIT) as usize;
        let (what, pattern) = &self.sequences[position / self.frames.len()];
        (what, pattern.path(self.frames[position % self.frames.len()]))
    }

    /// How many files.
    pub fn len(&self) -> usize {
        self.files.len() + self.sequences.len() * self.frames.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The real path of `path` (which need not exist: its folder's real path and its name; a
    /// symbolic link: the real path of what it points to; the path as it is when neither
    /// resolves) and, when it exists, its device and inode. One lstat for a file that is not
    /// a link, so that a sequence's thousands of frames are quick.
    fn identify(&mut self, path: &Path) -> (PathBuf, Option<(u64, u64)>) {
        use std::os::unix::fs::MetadataExt;
        match std::fs::symlink_metadata(path) {
            Ok(m) if m.file_type().is_symlink() => {
                let real = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
                (real, std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino())))
            }
            found => {
                let real = self.in_real_folder(path).unwrap_or_else(|| path.to_path_buf());
                (real, found.ok().map(|m| (m.dev(), m.ino())))
            }
        }
    }

    /// `path`'s name in its folder's real path (each folder resolved once).
    fn in_real_folder(&mut self, path: &Path) -> Option<PathBuf> {
        let name = path.file_name()?;
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        if let Some(real) = self.folders.get(dir) {
            return real.as_ref().map(|d| d.join(name));
        }
        let real = std::fs::canonicalize(dir).ok();
        if self.folders.len() >= MAX_FOLDERS {
            self.folders.clear();
        }
        self.folders.insert(dir.to_path_buf(), real.clone());
        real.map(|d| d.join(name))
    }

    /// The first file (in the order added) whose hash in `list` is `hash` and that `same`
    /// confirms.
    fn find(
        &mut self,
        by_inode: bool,
        hash: u32,
        same: impl Fn(&(PathBuf, Option<(u64, u64)>)) -> bool,
    ) -> Option<u32> {
        let list = if by_inode { &self.by_inode } else { &self.by_path };
        let start = list.partition_point(|e| e.0 < hash);
        let candidates: Vec<u32> = list[start..].iter().take_while(|e| e.0 == hash).map(|e| e.1).collect();
        candidates.into_iter().find(|&file| {
            let path = self.file(file).1;
            same(&self.identify(&path))
        })
    }

    /// Refuses `path` as the output named by `field` when it is one of these files; else its
    /// real path.
    pub fn check_output(&mut self, field: &'static str, path: &Path) -> Result<PathBuf, IoError> {
        if !self.sorted {
            self.by_path.sort_unstable();
            self.by_inode.sort_unstable();
            self.sorted = true;
        }
        let (real, id) = self.identify(path);
        let found = self
            .find(false, hash32(&real), |(other, _)| *other == real)
            .or_else(|| id.and_then(|id| self.find(true, hash32(&id), |(_, other)| *other == Some(id))));
        match found.map(|file| self.file(file)) {
            Some((what, input)) => Err(IoError::Output {
                field,
                path: path.to_path_buf(),
                reason: format!("it is the input {what} \"{}\"; realcam never writes over its inputs", input.display()),
            }),
            None => Ok(real),
        }
    }
}

impl Outputs {
    /// Checks `outputs` (the field that named each, and its path) against each other and
    /// against `inputs` (field, path), removes stale temporaries from their folders and
    /// reserves a temporary beside each. Nothing existing is touched.
    pub fn new(outputs: &[(&'static str, &Path)], inputs: &[(&'static str, &Path)]) -> Result<Outputs, IoError> {
        let mut inputs = InputFiles::new(inputs.iter().map(|&(what, p)| (what, p.to_path_buf())));
        Self::new_beside(outputs, &mut inputs)
    }

    /// [`Outputs::new`] with the inputs already gathered (a sequence's every frame).
    pub fn new_beside(outputs: &[(&'static str, &Path)], inputs: &mut InputFiles) -> Result<Outputs, IoError> {
        let mut checked: Vec<(&'static str, &Path, PathBuf, PathBuf)> = Vec::new();
        for &(field, path) in outputs {
            let refuse = |reason: String| IoError::Output { field, path: path.to_path_buf(), reason };
            if path.as_os_str().as_encoded_bytes().ends_with(b"/") {
                return Err(refuse("the path ends with \"/\": it names a folder, not a file".into()));
            }
            let name = path.file_name().ok_or_else(|| refuse("the path does not name a file".into()))?;
            let dir = match path.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            match std::fs::metadata(dir) {
                Ok(m) if m.is_dir() => {}
                Ok(_) => return Err(refuse(format!("\"{}\" is not a folder", dir.display()))),
                Err(_) => return Err(refuse(format!("the folder \"{}\" does not exist", dir.display()))),
            }
            if let Ok(m) = std::fs::symlink_metadata(path) {
                if !m.file_type().is_file() {
                    return Err(refuse(format!(
                        "it is {}; realcam writes only new files or replaces regular ones",
                        file_kind(m.file_type())
                    )));
                }
            }
            let real = resolved(path, dir, name);
            inputs.check_output(field, path)?;
            if let Some((other, other_path, ..)) = checked.iter().find(|c| c.2 == real) {
                return Err(refuse(format!("the {other} \"{}\" is the same file", other_path.display())));
            }
            checked.push((field, path, real, dir.to_path_buf()));
        }
        for (.., dir) in &checked {
            remove_stale_temporaries(dir);
        }
        let mut reserved = Outputs { files: Vec::new() };
        for (field, path, _, dir) in checked {
            let name = path.file_name().unwrap_or_default();
            let tmp = dir.join(temporary_name(name));
            // Registered before it exists, so that a signal between the two still removes it.
            LIVE.lock().unwrap_or_else(|p| p.into_inner()).push(tmp.clone());
            if let Err(source) = std::fs::OpenOptions::new().write(true).create_new(true).open(&tmp) {
                forget(&tmp);
                return Err(IoError::Output {
                    field,
                    path: path.to_path_buf(),
                    reason: format!("cannot create a file in \"{}\": {source}", dir.display()),
                });
            }
            reserved.files.push(Output { field, path: path.to_path_buf(), tmp, written: false });
        }
        Ok(reserved)
    }

    /// Writes `bytes` into the temporary of the output named by `field`.
    pub fn write(&mut self, field: &str, bytes: &[u8]) -> Result<(), IoError> {
        self.write_with(field, |file, path| file.write_all(bytes).map_err(|source| IoError::Write { path, source }))
    }

    /// Lets `fill` write the temporary of the output named by `field` (an empty file, and the
    /// output's target path for its errors), then makes it durable: for content written as it
    /// is made, with no copy of the whole file in memory first.
    pub fn write_with(
        &mut self,
        field: &str,
        fill: impl FnOnce(&mut std::fs::File, PathBuf) -> Result<(), IoError>,
    ) -> Result<(), IoError> {
        let Some(out) = self.files.iter_mut().find(|o| o.field == field) else {
            return Err(IoError::Output {
                field: "output",
                path: PathBuf::from(field),
                reason: "no such output was reserved".into(),
            });
        };
        let write_error = |source| IoError::Write { path: out.path.clone(), source };
        let mut file =
            std::fs::OpenOptions::new().read(true).write(true).truncate(true).open(&out.tmp).map_err(write_error)?;
        fill(&mut file, out.path.clone())?;
        file.sync_all().map_err(write_error)?;
        out.written = true;
        Ok(())
    }

    /// The path of the output named by `field`.
    pub fn path(&self, field: &str) -> Option<&Path> {
        self.files.iter().find(|o| o.field == field).map(|o| o.path.as_path())
    }

    /// Renames every temporary onto its target, once all were written; otherwise (or when a
    /// rename fails) an error and no target that was not already renamed is touched.
    pub fn commit(mut self) -> Result<(), IoError> {
        if let Some(out) = self.files.iter().find(|o| !o.written) {
            return Err(IoError::Output {
                field: out.field,
                path: out.path.clone(),
                reason: "it was never written".into(),
            });
        }
        for out in std::mem::take(&mut self.files) {
            let renamed = std::fs::rename(&out.tmp, &out.path);
            forget(&out.tmp);
            if let Err(source) = renamed {
                let _ = std::fs::remove_file(&out.tmp);
                return Err(IoError::Write { path: out.path, source });
            }
        }
        Ok(())
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        for out in &self.files {
            let _ = std::fs::remove_file(&out.tmp);
            forget(&out.tmp);
        }
    }
}

/// Why the existing output `path`, named by `field`, is not complete (what `--skip-existing`
/// may keep); None when it is: a regular file that reads back whole as what `field` writes (the
/// EXR's header, offset tables and every chunk; the PNG decoded; the trace parsed as JSON).
pub fn incomplete_output(field: &str, path: &Path) -> Option<String> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) => return Some(format!("it cannot be read: {e}")),
    };
    if !meta.file_type().is_file() {
        return Some(format!("it is {}", file_kind(meta.file_type())));
    }
    if meta.len() == 0 {
        return Some("it is empty (0 bytes)".into());
    }
    let whole = || -> Result<(), String> {
        match field {
            "output" => {
                let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
                let reader = exr::block::reader::Reader::read_from_buffered(std::io::BufReader::new(file), true)
                    .map_err(|e| e.to_string())?;
                for chunk in reader.all_chunks(true).map_err(|e| e.to_string())? {
                    chunk.map_err(|e| e.to_string())?;
                }
                Ok(())
            }
            "png" => image::open(path).map(|_| ()).map_err(|e| e.to_string()),
            _ => {
                let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
                serde_json::from_slice::<serde::de::IgnoredAny>(&bytes).map(|_| ()).map_err(|e| e.to_string())
            }
        }
    };
    whole().err().map(|e| format!("it does not read back whole ({} bytes): {e}", meta.len()))
}

/// Writes `bytes` to `path` through a temporary (the checks of [`Outputs::new`], `field`
/// naming the setting that chose the path).
pub fn write_file(field: &'static str, path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let mut outputs = Outputs::new(&[(field, path)], &[])?;
    outputs.write(field, bytes)?;
    outputs.commit()
}

/// Removes this process's temporaries on SIGINT, SIGTERM and SIGHUP, then ends the process
/// by that signal as it would have without this: signal-hook's handler wakes a thread of its
/// own, which removes them and then acts as the signal's default. Call it first thing in
/// `main`; it returns once the signals are taken (or left as they were, if no thread starts).
pub fn remove_temporaries_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let (taken, wait) = std::sync::mpsc::sync_channel(1);
    let spawned = std::thread::Builder::new().name("realcam-signals".into()).spawn(move || {
        // Taken on this thread, so that no handler is ever left without the thread it wakes.
        let signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]);
        let _ = taken.send(());
        let Ok(mut signals) = signals else { return };
        for signal in signals.forever() {
            for tmp in std::mem::take(&mut *LIVE.lock().unwrap_or_else(|p| p.into_inner())) {
                let _ = std::fs::remove_file(tmp);
            }
            let _ = signal_hook::low_level::emulate_default_handler(signal);
        }
    });
    if spawned.is_ok() {
        let _ = wait.recv();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_dir;

    #[test]
    fn temporary_names_carry_host_and_process() {
        let name = temporary_name(OsStr::new("out-1.exr"));
        assert!(name.starts_with(".out-1.exr.realcam-") && name.ends_with(".tmp"), "{name}");
        assert_eq!(temporary_owner(&name), Some((host_name().as_str(), std::process::id())));
        assert_eq!(temporary_owner(".a.exr.realcam-my-host.lan-123-7.tmp"), Some(("my-host.lan", 123)));
        // A 255-byte name: the temporary's name stays within 255 bytes and is still one of realcam's.
        let long = format!("{}.exr", "é".repeat(125));
        let name = temporary_name(OsStr::new(&long));
        assert!(name.len() <= NAME_MAX_BYTES && name.starts_with(".éé"), "{} bytes: {name}", name.len());
        assert_eq!(temporary_owner(&name), Some((host_name().as_str(), std::process::id())));
        for other in ["a.exr", ".a.exr.tmp", ".a.realcam-h-x-1.tmp", "realcam-h-1-2.tmp"] {
            assert_eq!(temporary_owner(other), None, "{other}");
        }
    }

    #[test]
    fn outputs_are_renamed_together_or_not_at_all() {
        let dir = test_dir("outputs");
        let (a, b) = (dir.join("a.exr"), dir.join("b.png"));
        std::fs::write(&a, b"old a").unwrap();
        let listing = || {
            let mut v: Vec<String> =
                std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
            v.sort();
            v
        };
        // One written, the other not: nothing is renamed, the temporaries go.
        let mut outs = Outputs::new(&[("output", &a), ("png", &b)], &[]).unwrap();
        assert_eq!(listing().len(), 3, "{:?}", listing());
        outs.write("output", b"new a").unwrap();
        let err = outs.commit().unwrap_err().to_string();
        assert_eq!(err, format!("png \"{}\": it was never written", b.display()));
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        assert_eq!(listing(), ["a.exr"]);
        // Dropped (a failed run): the same.
        let mut outs = Outputs::new(&[("output", &a), ("png", &b)], &[]).unwrap();
        outs.write("output", b"new a").unwrap();
        drop(outs);
        assert_eq!(listing(), ["a.exr"]);
        // Both written: both renamed.
        let mut outs = Outputs::new(&[("output", &a), ("png", &b)], &[]).unwrap();
        outs.write("output", b"new a").unwrap();
        outs.write("png", b"new b").unwrap();
        outs.commit().unwrap();
        assert_eq!((std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap()), (b"new a".to_vec(), b"new b".to_vec()));
        assert_eq!(listing(), ["a.exr", "b.png"]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn stale_temporaries_of_dead_processes_go_and_live_ones_stay() {
        let dir = test_dir("stale");
        let host = host_name();
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale = dir.join(format!(".o.exr.realcam-{host}-{dead}-0.tmp"));
        let live = dir.join(format!(".o.exr.realcam-{host}-{}-0.tmp", std::process::id()));
        let other_host = dir.join(format!(".o.exr.realcam-{host}x-{dead}-0.tmp"));
        for p in [&stale, &live, &other_host] {
            std::fs::write(p, b"x").unwrap();
        }
        assert_eq!(remove_stale_temporaries(&dir), 1);
        assert!(!stale.exists() && live.exists() && other_host.exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
