//! The folders this process has locked, with the identity each had when locked: every file
//! writer checks its folder against them ([`check_held`]) before it creates and before it
//! commits, so that two runs never mix in one folder.

use super::error::OutputError;
use std::path::{Path, PathBuf};

/// The identity of a folder on its file system (device, inode), where it has one.
fn identity(dir: &Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(dir).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        std::fs::metadata(dir).ok().map(|_| (0, 0))
    }
}

/// A folder this process has locked, with the identity it had when locked.
type Held = (PathBuf, Option<(u64, u64)>);

/// The folders this process has locked.
static HELD: std::sync::Mutex<Vec<Held>> = std::sync::Mutex::new(Vec::new());

/// Remember `dir`'s identity as this process's lock of it.
pub(super) fn hold(dir: &Path) {
    let mut held = HELD.lock().unwrap_or_else(|e| e.into_inner());
    held.retain(|(d, _)| d != dir);
    held.push((dir.to_path_buf(), identity(dir)));
}

/// Refuse to write into `dir` when this process locked it and it has since been deleted or
/// replaced (another folder of that name, perhaps locked by another run): every file writer
/// checks before it creates and before it commits, so that two runs never mix in one folder.
pub fn check_held(dir: &Path) -> Result<(), OutputError> {
    let held = HELD.lock().unwrap_or_else(|e| e.into_inner());
    match held.iter().find(|(d, _)| d == dir) {
        Some((_, locked)) if identity(dir) != *locked => Err(OutputError::FolderReplaced {
            dir: dir.display().to_string(),
        }),
        _ => Ok(()),
    }
}
