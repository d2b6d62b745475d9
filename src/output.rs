//! Atomic output: every file is written next to its destination under a
//! temporary name and renamed into place only once complete, so an error or
//! an interrupted run never leaves a partial file that looks whole.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file being written; it appears at `path` only after [`AtomicFile::commit`].
/// Dropping it without committing removes the temporary file.
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    file: Option<std::io::BufWriter<std::fs::File>>,
}

/// Checks, before any work, that the folder `path` is to be written in
/// exists, so that a long encode does not end in an error about it.
pub fn check_output_folder(path: &Path) -> Result<()> {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if parent.is_dir() {
        Ok(())
    } else {
        Err(Error::Argument(format!("{}: the folder {} does not exist", path.display(), parent.display())))
    }
}

impl AtomicFile {
    pub fn create(path: &Path) -> Result<Self> {
        let name = path.file_name().ok_or_else(|| Error::Argument(format!("{} is not a file path", path.display())))?;
        check_output_folder(path)?;
        // One name per file being written, so that an encode's budget passes
        // (two files for one path at a time) and threads do not share one.
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".{}-{k}.partial", std::process::id()));
        let tmp = path.with_file_name(tmp_name);
        remove_orphans(path, name);
        // Errors name the file asked for, not the temporary one.
        let file = std::fs::File::create(&tmp).map_err(|e| Error::io(path, e))?;
        Ok(Self { path: path.to_path_buf(), tmp, file: Some(std::io::BufWriter::new(file)) })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn write_all(&mut self, bytes: &[u8]) -> Result<()> {
        let file = self.file.as_mut().ok_or_else(|| Error::Argument("AtomicFile used after commit".into()))?;
        file.write_all(bytes).map_err(|e| Error::io(&self.path, e))
    }

    /// Flushes, syncs and renames the file into place.
    pub fn commit(mut self) -> Result<()> {
        let file = self.file.take().ok_or_else(|| Error::Argument("AtomicFile committed twice".into()))?;
        // Closed at the end of this block, before the rename.
        {
            let file = file.into_inner().map_err(|e| Error::io(&self.path, e.into_error()))?;
            file.sync_all().map_err(|e| Error::io(&self.path, e))?;
        }
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Removes temporary files of `path` (`.NAME.PID-K.partial`) that a killed
/// process left: a signal skips [`AtomicFile`]'s `Drop`, and a long encode
/// keeps its temporaries open for minutes. Only where a process's liveness
/// can be read (Linux's /proc); a file still being written by a live
/// process on this machine is never touched (one on another machine
/// writing the same path into a shared folder would be; two writers of one
/// path race at the rename anyway). Best effort: errors are ignored.
fn remove_orphans(path: &Path, name: &std::ffi::OsStr) {
    let proc = Path::new("/proc/self");
    let (Some(folder), Some(name)) = (path.parent(), name.to_str()) else { return };
    let folder = if folder.as_os_str().is_empty() { Path::new(".") } else { folder };
    let Ok(entries) = std::fs::read_dir(folder) else { return };
    if !proc.exists() {
        return;
    }
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(&prefix)?.strip_suffix(".partial")) else {
            continue;
        };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|pid| !Path::new("/proc").join(pid.to_string()).exists()) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Where a file's bytes go as they are made: a file written atomically,
/// memory, or nowhere but a count, so that a writer holds only what it has
/// not written yet.
pub trait Sink {
    fn put(&mut self, bytes: &[u8]) -> Result<()>;
}

impl Sink for Vec<u8> {
    fn put(&mut self, bytes: &[u8]) -> Result<()> {
        self.extend_from_slice(bytes);
        Ok(())
    }
}

impl Sink for AtomicFile {
    fn put(&mut self, bytes: &[u8]) -> Result<()> {
        self.write_all(bytes)
    }
}

/// A sink that keeps only the number of bytes put in it.
#[derive(Debug, Default)]
pub struct Count(pub usize);

impl Sink for Count {
    fn put(&mut self, bytes: &[u8]) -> Result<()> {
        self.0 += bytes.len();
        Ok(())
    }
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}
