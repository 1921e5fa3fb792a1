//! One writer per run directory: `waggle run` holds an advisory lock on `DIR/.lock` for the
//! whole run, so a second run on the same `--out` is refused instead of interleaving its
//! recording and summary with the first one's.

use std::fs::{File, OpenOptions, TryLockError};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use super::{CASE_FILE, OBSERVERS_FILE, RECORDING_FILE, SESSION_FILE, SUMMARY_FILE};

/// The lock file inside a run directory.
pub const LOCK_FILE: &str = ".lock";

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
    pub fn acquire(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join(LOCK_FILE);
        let file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .with_context(|| format!("opening {}", path.display()))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => bail!(
                "{} is in use by another waggle run (it holds {}); choose another --out",
                dir.display(),
                path.display()
            ),
            Err(TryLockError::Error(e)) => {
                return Err(e).with_context(|| format!("locking {}", path.display()));
            }
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
                    .with_context(|| format!("removing the previous run's {}", old.display()))?;
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
        let err = format!("{:#}", RunLock::acquire(&dir).unwrap_err());
        assert!(err.contains("in use by another waggle run"), "{err}");
        assert!(err.contains(&dir.display().to_string()), "{err}");
        drop(first);
        let again = RunLock::acquire(&dir).unwrap();
        assert!(again.path().ends_with(LOCK_FILE));
        drop(again);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
