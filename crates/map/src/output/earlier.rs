//! An earlier run replaced only once the new one is complete. `--force` moves the earlier
//! run's files aside into `EARLIER_DIR` inside the folder (renames, nothing copied or
//! rewritten); the new run writes its own; then either
//! - [`Replacement::keep`]: the new run completed, the earlier files are deleted; or
//! - [`Replacement::undo`]: it failed (a lost GPU, a refusal found late, Ctrl-C), what it wrote
//!   is deleted and the earlier files move back, whole.
//!
//! A run killed outright leaves the earlier files aside; the next claim of the folder puts
//! them back first (`recover`), unless the killed run had written its manifest (it was
//! complete). The user's own files are never moved.

use super::error::OutputError;
use std::path::{Path, PathBuf};

/// The names a kind of run writes, as far as setting its earlier run aside needs them
/// (`folder::Product` is the one kind there is; the trait keeps this file from importing it).
pub(crate) trait RunFiles: std::fmt::Debug + Send + Sync {
    /// Whether a file of this name is this kind of run's (its temporary files included).
    fn writes(&self, name: &str) -> bool;
    /// The name of its manifest, written last, when the run is complete.
    fn manifest(&self) -> &'static str;
}

/// The folder, inside an output folder, that holds an earlier run's files while a new run
/// replaces them.
pub const EARLIER_DIR: &str = ".pendulum-atlas.earlier";

/// An earlier run set aside for a new one: kept aside until the new run ends.
#[derive(Debug)]
pub struct Replacement {
    dir: PathBuf,
    product: Box<dyn RunFiles>,
    /// The names of the earlier run's files, now in [`EARLIER_DIR`].
    moved: Vec<String>,
    /// The names of the files left in the folder when the new run began.
    present: Vec<String>,
}

impl Replacement {
    /// Move `files` (the earlier run's, in `dir`) aside, and note what stays in `dir`.
    pub(super) fn set_aside(
        dir: &Path,
        product: Box<dyn RunFiles>,
        files: &[PathBuf],
    ) -> Result<Replacement, OutputError> {
        let aside = dir.join(EARLIER_DIR);
        std::fs::create_dir(&aside).map_err(|e| OutputError::io(&aside, e))?;
        let mut moved = Vec::with_capacity(files.len());
        for p in files {
            let Some(name) = p.file_name() else { continue };
            std::fs::rename(p, aside.join(name)).map_err(|e| OutputError::io(p, e))?;
            moved.push(name.to_string_lossy().into_owned());
        }
        Ok(Replacement {
            dir: dir.to_path_buf(),
            product,
            moved,
            present: names(dir)?,
        })
    }

    /// How many files of the earlier run are set aside.
    pub fn count(&self) -> usize {
        self.moved.len()
    }

    /// The new run is complete: delete the earlier run's files.
    pub fn keep(self) -> Result<(), OutputError> {
        let aside = self.dir.join(EARLIER_DIR);
        std::fs::remove_dir_all(&aside).map_err(|e| OutputError::io(&aside, e))
    }

    /// The new run failed: delete the files it wrote (this product's names that were not in
    /// the folder when it began) and move the earlier run's files back.
    pub fn undo(self) -> Result<(), OutputError> {
        for name in names(&self.dir)? {
            if self.product.writes(&name) && !self.present.contains(&name) {
                let p = self.dir.join(&name);
                std::fs::remove_file(&p).map_err(|e| OutputError::io(&p, e))?;
            }
        }
        put_back(&self.dir)
    }
}

/// Before a folder is claimed: an earlier run left aside by a run killed outright is put back
/// (over the killed run's partial files of the same names, its temporary files deleted), or,
/// where the killed run wrote `product`'s manifest (it was complete), deleted.
///
/// An [`EARLIER_DIR`] this tool did not make is refused before anything moves
/// ([`refuse_planted`]).
pub(super) fn recover(dir: &Path, product: &dyn RunFiles) -> Result<(), OutputError> {
    let aside = dir.join(EARLIER_DIR);
    if !refuse_planted(&aside, product)? {
        return Ok(());
    }
    if dir.join(product.manifest()).is_file() {
        return std::fs::remove_dir_all(&aside).map_err(|e| OutputError::io(&aside, e));
    }
    for name in names(dir)? {
        if name.starts_with('.') && product.writes(&name) {
            let p = dir.join(&name);
            std::fs::remove_file(&p).map_err(|e| OutputError::io(&p, e))?;
        }
    }
    put_back(dir)
}

/// Whether `aside` (an [`EARLIER_DIR`]) exists, refused where this tool cannot have made it:
/// a symlink (never followed: its target's files would move into the output folder), not a
/// folder, or a folder holding anything but regular files of `product`'s names or of the
/// earlier run's own list (its manifest's `files`, set aside with it). Nothing is touched.
fn refuse_planted(aside: &Path, product: &dyn RunFiles) -> Result<bool, OutputError> {
    let planted = |path: &Path, what: &'static str| OutputError::PlantedEarlier {
        path: path.display().to_string(),
        what,
    };
    let kind = match std::fs::symlink_metadata(aside) {
        Ok(m) => m.file_type(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(OutputError::io(aside, e)),
    };
    if !kind.is_dir() {
        return Err(planted(aside, entry_kind(kind)));
    }
    // Every entry a regular file first: only then is the manifest read (a symlink to a FIFO
    // in its place would block the read).
    let mut names = Vec::new();
    let entries = std::fs::read_dir(aside).map_err(|e| OutputError::io(aside, e))?;
    for entry in entries {
        let entry = entry.map_err(|e| OutputError::io(aside, e))?;
        let kind = entry
            .file_type()
            .map_err(|e| OutputError::io(&entry.path(), e))?;
        if !kind.is_file() {
            return Err(planted(&entry.path(), entry_kind(kind)));
        }
        names.push(entry.file_name().to_string_lossy().into_owned());
    }
    let listed = super::folder::listed_files(&aside.join(product.manifest())).unwrap_or_default();
    if let Some(name) = names
        .iter()
        .find(|n| !product.writes(n) && !listed.contains(n))
    {
        return Err(planted(
            &aside.join(name),
            "a file no run of this command writes",
        ));
    }
    Ok(true)
}

/// What an entry that is not a regular file is, in words.
fn entry_kind(kind: std::fs::FileType) -> &'static str {
    if kind.is_symlink() {
        "a symlink"
    } else if kind.is_dir() {
        "a folder"
    } else if kind.is_file() {
        "a file"
    } else {
        "not a regular file"
    }
}

/// Move every file of [`EARLIER_DIR`] back into `dir` and remove the emptied folder.
fn put_back(dir: &Path) -> Result<(), OutputError> {
    let aside = dir.join(EARLIER_DIR);
    for name in names(&aside)? {
        let from = aside.join(&name);
        std::fs::rename(&from, dir.join(&name)).map_err(|e| OutputError::io(&from, e))?;
    }
    std::fs::remove_dir(&aside).map_err(|e| OutputError::io(&aside, e))
}

/// The names of the regular files in `dir`.
fn names(dir: &Path) -> Result<Vec<String>, OutputError> {
    let entries = std::fs::read_dir(dir).map_err(|e| OutputError::io(dir, e))?;
    Ok(entries
        .filter_map(Result::ok)
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect())
}
