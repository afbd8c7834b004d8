//! Atomic writes: every file FieldProbe writes (datasets, meshes, checkpoints, reports) goes
//! through [`write_atomic`], so that a crash, a kill or an error never leaves a half-written file
//! where a good one was.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use crate::{Error, Result};

/// Writes `path` through a temporary sibling, `fsync`, a rename and an `fsync` of the folder.
///
/// The temporary (`tempfile`: `.<name>.<random>.tmp`, unique per call, so concurrent writers of
/// one path never share one) is removed when `write` fails or panics; on success the rename
/// replaces `path` in one step, so readers see either the old file or the new one, never a mix,
/// and the folder's `fsync` makes the rename itself survive a power cut. A full disk is an
/// error naming `path`, with the old file intact. Missing parent folders are created.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<()> {
    let parent = match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(p) => {
            std::fs::create_dir_all(p).map_err(|e| Error::io(p, e))?;
            p
        }
        None => Path::new("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let result = (|| {
        // Dropped (and so deleted) on every early return and on a panic in `write`.
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        // tempfile makes owner-only (0600) files; a written result is an ordinary file, so it
        // gets the mode `File::create` would give it (0666 less the umask).
        #[cfg(unix)]
        builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
        let tmp = builder.tempfile_in(parent)?;
        let mut w = BufWriter::new(tmp.reopen()?);
        write(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        tmp.persist(path).map_err(|e| e.error)?;
        sync_dir(parent)
    })();
    result.map_err(|e| Error::io(path, e))
}

/// `fsync` of a folder, so that a rename in it is durable (a no-op where folders cannot be
/// opened as files).
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    match File::open(dir) {
        Ok(d) => d.sync_all().or(Ok(())),
        Err(_) => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn atomic_write_keeps_the_old_file_on_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.txt");
        write_atomic(&p, |w| w.write_all(b"good")).unwrap();
        let e = write_atomic(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(e.is_err());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "good");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temporary left"
        );
    }

    #[test]
    fn a_panicking_writer_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.txt");
        write_atomic(&p, |w| w.write_all(b"good")).unwrap();
        let r = std::panic::catch_unwind(|| {
            let _ = write_atomic(&p, |w| {
                w.write_all(b"half").unwrap();
                panic!("writer bug");
            });
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "good");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    /// A result is readable like a file `File::create` makes (tempfile's own default is 0600).
    #[cfg(unix)]
    #[test]
    fn a_written_file_has_the_mode_of_a_created_one() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let (atomic, plain) = (dir.path().join("a"), dir.path().join("b"));
        write_atomic(&atomic, |w| w.write_all(b"x")).unwrap();
        File::create(&plain).unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&atomic), mode(&plain));
    }

    /// A full disk (Linux's `/dev/full` answers every write with ENOSPC): the error names the
    /// file and says why; what was there stays.
    #[test]
    fn a_full_disk_is_a_clear_error_and_the_old_file_stays() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("ckpt.bin");
        write_atomic(&p, |w| w.write_all(b"last good")).unwrap();
        let e = write_atomic(&p, |w| {
            let mut full = std::fs::OpenOptions::new().write(true).open("/dev/full")?;
            w.write_all(b"new")?;
            full.write_all(&[0; 4096])
        });
        if Path::new("/dev/full").exists() {
            let e = e.unwrap_err().to_string();
            assert!(
                e.contains("ckpt.bin") && e.to_lowercase().contains("space"),
                "{e}"
            );
            assert_eq!(std::fs::read_to_string(&p).unwrap(), "last good");
            assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        }
    }

    #[test]
    fn concurrent_writers_of_one_path_do_not_collide() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("shared.txt");
        std::thread::scope(|s| {
            for t in 0..8u8 {
                let p = &p;
                s.spawn(move || {
                    for _ in 0..20 {
                        write_atomic(p, |w| w.write_all(&[b'a' + t; 4096])).unwrap();
                    }
                });
            }
        });
        let text = std::fs::read(&p).unwrap();
        assert_eq!(text.len(), 4096, "one whole write, not a mix");
        assert!(
            text.iter().all(|&b| b == text[0]),
            "bytes of one writer only"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
