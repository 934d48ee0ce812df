//! One writer per study directory.
//!
//! `learner tune` and `learner study` read a directory's record, run what
//! is missing and write the record back; two of them on one directory
//! would run the same trials twice and overwrite each other's records. So
//! each holds an exclusive lock on `DIR/.lock` (the operating system's
//! advisory file lock, [`std::fs::File::try_lock`]) for as long as it
//! runs. The lock belongs to the open file, not to the file's existence:
//! a process that dies for any reason releases it, so there is never a
//! stale lock to delete by hand. The file holds the holder's process id,
//! for the error message.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// The lock file's name inside a study directory.
pub const LOCK_FILE: &str = ".lock";

/// Why a study directory could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process (or another lock in this one) holds the directory.
    #[error(
        "{} is in use by another `learner tune` or `learner study` (process {holder}); \
         wait for it to finish or choose another --out",
        dir.display()
    )]
    Busy {
        /// The study directory.
        dir: PathBuf,
        /// The holder's process id as it wrote it (`?` if unreadable).
        holder: String,
    },
    /// The directory or its lock file could not be created or locked.
    #[error("locking {}: {source}", path.display())]
    Io {
        /// The lock file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

/// An exclusive lock on a study directory, released when dropped.
///
/// ```
/// use buridan_study::lock::{DirLock, LockError};
/// let dir = tempfile::tempdir().unwrap();
/// let held = DirLock::acquire(dir.path()).unwrap();
/// let again = DirLock::acquire(dir.path());
/// assert!(matches!(again, Err(LockError::Busy { .. })));
/// drop(held);
/// assert!(DirLock::acquire(dir.path()).is_ok());
/// ```
#[derive(Debug)]
pub struct DirLock {
    _file: File,
}

impl DirLock {
    /// Creates `dir` if needed and locks it, or says who holds it.
    pub fn acquire(dir: &Path) -> Result<Self, LockError> {
        let path = dir.join(LOCK_FILE);
        let io = |source| LockError::Io {
            path: path.clone(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(io)?;
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                let holder = match holder.trim() {
                    "" => "?".to_string(),
                    h => h.to_string(),
                };
                return Err(LockError::Busy {
                    dir: dir.to_path_buf(),
                    holder,
                });
            }
            Err(TryLockError::Error(e)) => return Err(io(e)),
        }
        file.set_len(0).map_err(io)?;
        file.rewind().map_err(io)?;
        writeln!(file, "{}", std::process::id()).map_err(io)?;
        Ok(Self { _file: file })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_directory_names_its_holder_and_frees_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let study = dir.path().join("a/b");
        let held = DirLock::acquire(&study).unwrap();
        let err = DirLock::acquire(&study).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains(&std::process::id().to_string()) && msg.contains("a/b"),
            "{msg}"
        );
        drop(held);
        let again = DirLock::acquire(&study).unwrap();
        // The record of the new holder replaced the old one, not appended.
        let text = std::fs::read_to_string(study.join(LOCK_FILE)).unwrap();
        assert_eq!(text, format!("{}\n", std::process::id()));
        drop(again);
    }

    #[test]
    fn a_directory_that_cannot_be_created_is_an_io_error() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain-file");
        std::fs::write(&file, "x").unwrap();
        let err = DirLock::acquire(&file.join("study")).unwrap_err();
        assert!(matches!(err, LockError::Io { .. }), "{err}");
    }
}
