//! One process per run directory: a run holds an exclusive lock on `<run>/.lock` while it trains
//! and evaluates, so a second process started on the same directory (a double-clicked script, an
//! ablation worker given the wrong `--variant`) stops with a clear message instead of
//! interleaving checkpoints with the first.
//!
//! The lock is the operating system's advisory file lock (`File::try_lock`, `flock` on Unix), not
//! the file's existence: the kernel releases it when the holder exits, however it exits (a
//! SIGKILL, an OOM kill, a power cut), so a lock left by a dead run never blocks the next one.
//! The file itself only says who holds it (pid and start time) for the message. Where the
//! folder is on a file system without locks (some network mounts), `FIELDPROBE_NO_LOCK=1` is the
//! way past.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, bail};

/// The lock file's name in a run directory.
pub const FILE: &str = ".lock";

/// An exclusive lock on a run directory, released when dropped (or when the process ends).
#[derive(Debug)]
pub struct RunLock {
    /// `None` when locking is turned off (`FIELDPROBE_NO_LOCK`).
    _file: Option<File>,
    path: PathBuf,
}

impl RunLock {
    /// Locks `dir` (created if missing) for this process, or says which process holds it.
    pub fn acquire(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let path = dir.join(FILE);
        if std::env::var_os("FIELDPROBE_NO_LOCK").is_some_and(|v| v != "0") {
            return Ok(Self { _file: None, path });
        }
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .with_context(|| format!("cannot open the run lock {}", path.display()))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                let holder = holder.trim();
                let holder = if holder.is_empty() {
                    "another process".to_string()
                } else {
                    holder.to_string()
                };
                bail!(
                    "{} is in use by a running FieldProbe process ({holder}); wait for it to \
                     finish, or write this run elsewhere with --out DIR. (The lock is released \
                     when that process exits, even if it is killed; on a file system without \
                     locks set FIELDPROBE_NO_LOCK=1.)",
                    dir.display()
                );
            }
            Err(TryLockError::Error(e)) => {
                bail!(
                    "cannot lock {} ({e}); on a file system without locks set FIELDPROBE_NO_LOCK=1",
                    path.display()
                )
            }
        }
        let since = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        // Who holds it, for the message of a second process (best effort).
        let _ = file.set_len(0);
        let _ = file.rewind();
        let _ = write!(
            file,
            "pid {}, started at unix time {since}",
            std::process::id()
        );
        let _ = file.flush();
        Ok(Self {
            _file: Some(file),
            path,
        })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_on_a_directory_is_refused_with_the_holder_and_freed_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let run = dir.path().join("run");
        let first = RunLock::acquire(&run).unwrap();
        let e = RunLock::acquire(&run).unwrap_err().to_string();
        assert!(
            e.contains("in use") && e.contains(&format!("pid {}", std::process::id())),
            "{e}"
        );
        drop(first);
        // A lock file left behind (by a killed run) does not block: only a live holder does.
        assert!(run.join(FILE).is_file());
        RunLock::acquire(&run).unwrap();
    }
}
