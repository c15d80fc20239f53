//! What the server opened, as the file system knows it: the folder's identity (device, inode)
//! and its manifest's (inode, length, modification time), taken when the server starts. Every
//! request checks it first ([`Seal::check`]), so that a folder replaced or rerun with
//! `--force` while it is served is never shown as a mix of the earlier run's data and the new
//! run's pictures: the request is refused with `409` and what to do, and the terminal is told
//! once.

use super::error::ExploreError;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::SystemTime;

/// The folder's (device, inode) and its manifest's (inode, length, modification time).
type Stamp = ((u64, u64), (u64, u64, Option<SystemTime>));

/// The stamp of a served folder, and whether its change was told.
#[derive(Debug)]
pub(crate) struct Seal {
    dir: PathBuf,
    manifest: PathBuf,
    stamp: Option<Stamp>,
    told: AtomicBool,
}

impl Seal {
    /// The stamp of `dir` and its manifest `manifest` (a name in `dir`) as they are now.
    pub fn take(dir: &Path, manifest: &str) -> Seal {
        let manifest = dir.join(manifest);
        Seal {
            stamp: stamp(dir, &manifest),
            dir: dir.to_path_buf(),
            manifest,
            told: AtomicBool::new(false),
        }
    }

    /// `Err` once the folder or its manifest is not the one the server opened (deleted,
    /// replaced, rewritten by a new run).
    pub fn check(&self) -> Result<(), ExploreError> {
        if stamp(&self.dir, &self.manifest) == self.stamp {
            return Ok(());
        }
        let e = ExploreError::Replaced(self.dir.display().to_string());
        if !self.told.swap(true, Ordering::Relaxed) {
            eprintln!(
                "explore: {}",
                pendulum_atlas_core::text::printable(&e.to_string())
            );
        }
        Err(e)
    }
}

fn stamp(dir: &Path, manifest: &Path) -> Option<Stamp> {
    let (d, m) = (
        std::fs::metadata(dir).ok()?,
        std::fs::metadata(manifest).ok()?,
    );
    Some((identity(&d), (identity(&m).1, m.len(), m.modified().ok())))
}

/// (device, inode) where the file system has them.
fn identity(meta: &std::fs::Metadata) -> (u64, u64) {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        (meta.dev(), meta.ino())
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        (0, 0)
    }
}
