//! One writer per run directory: `waggle run` holds an advisory lock on `DIR/.lock` for the
//! whole run, so a second run on the same `--out` is refused instead of interleaving its
//! recording and summary with the first one's.

use std::fs::{File, OpenOptions, TryLockError};
use std::path::{Path, PathBuf};

use super::{CASE_FILE, OBSERVERS_FILE, RECORDING_FILE, SESSION_FILE, SUMMARY_FILE};

/// The lock file inside a run directory.
pub const LOCK_FILE: &str = ".lock";

/// Why a run directory could not be locked for a run.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error("creating {}", dir.display())]
    CreateDir {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("opening {}", path.display())]
    Open {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Another process holds the lock.
    #[error(
        "{} is in use by another waggle run (it holds {}); choose another --out",
        dir.display(),
        path.display()
    )]
    InUse { dir: PathBuf, path: PathBuf },
    #[error("locking {}", path.display())]
    Lock {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A previous run's file could not be removed.
    #[error("removing the previous run's {}", path.display())]
    RemovePrevious {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Held while a run writes its directory; released when dropped (or when the process dies:
/// the kernel drops `flock` locks with the last descriptor).
#[derive(Debug)]
pub struct RunLock {
    _file: File,
    path: PathBuf,
}

impl RunLock {
    /// Creates `dir` if needed and locks it; refuses when another process holds the lock.
    /// A previous, finished run's files are removed so that nothing of it mixes with this one.
    pub fn acquire(dir: &Path) -> Result<Self, LockError> {
        std::fs::create_dir_all(dir).map_err(|source| LockError::CreateDir {
            dir: dir.to_path_buf(),
            source,
        })?;
        let path = dir.join(LOCK_FILE);
        let file = match OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
        {
            Ok(file) => file,
            Err(source) => return Err(LockError::Open { path, source }),
        };
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                return Err(LockError::InUse {
                    dir: dir.to_path_buf(),
                    path,
                });
            }
            Err(TryLockError::Error(source)) => return Err(LockError::Lock { path, source }),
        }
        for name in [
            SUMMARY_FILE,
            OBSERVERS_FILE,
            SESSION_FILE,
            RECORDING_FILE,
            CASE_FILE,
        ] {
            let old = dir.join(name);
            if old.exists() {
                std::fs::remove_file(&old)
                    .map_err(|source| LockError::RemovePrevious { path: old, source })?;
            }
        }
        Ok(Self { _file: file, path })
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
    fn a_second_writer_is_refused_until_the_first_lets_go() {
        let dir = std::env::temp_dir().join(format!("waggle-lock-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(SUMMARY_FILE), "{}").unwrap();
        let first = RunLock::acquire(&dir).unwrap();
        assert!(!dir.join(SUMMARY_FILE).exists(), "the old summary must go");
        let err = RunLock::acquire(&dir).unwrap_err().to_string();
        assert!(err.contains("in use by another waggle run"), "{err}");
        assert!(err.contains(&dir.display().to_string()), "{err}");
        drop(first);
        let again = RunLock::acquire(&dir).unwrap();
        assert!(again.path().ends_with(LOCK_FILE));
        drop(again);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
