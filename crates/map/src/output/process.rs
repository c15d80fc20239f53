//! The output folder of this process: claimed once by a command (the command line's, the
//! lab's), then either kept when the command completes or abandoned when it fails or is
//! interrupted. Abandoning puts back the earlier run that `--force` set aside
//! ([`super::earlier`]) and, in a folder the command created, deletes what it wrote there
//! and the folder.
//!
//! The state is process-wide so that a Ctrl-C handler on another thread can abandon the
//! folder and end the process: every command that writes a folder stops the same way.

use super::earlier::Replacement;
use super::error::OutputError;
use super::folder::{LOCK_FILE, Product};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// The folder this process claimed.
#[derive(Debug)]
struct Claimed {
    /// The folder.
    dir: PathBuf,
    /// What the command writes there.
    product: Product,
    /// Whether this process created it.
    created: bool,
    /// The earlier run set aside by `--force`, until the run ends.
    earlier: Option<Replacement>,
}

/// This process's claimed folder, if any.
static CLAIMED: Mutex<Option<Claimed>> = Mutex::new(None);

fn claimed() -> MutexGuard<'static, Option<Claimed>> {
    CLAIMED.lock().unwrap_or_else(|e| e.into_inner())
}

/// Claim `out` for `product` for the rest of the process (see [`Product::claim`]), refused
/// when one of `inputs` would be overwritten. The folder stays locked until the process ends.
/// Returns how many files of an earlier run `--force` set aside.
pub fn claim(
    product: Product,
    out: &Path,
    force: bool,
    inputs: &[&Path],
) -> Result<usize, OutputError> {
    product.refuse_inputs(out, inputs)?;
    let created = !out.exists();
    let (lock, earlier) = product.claim(out, force)?;
    // Held until the process ends: no other run writes into `out` meanwhile.
    std::mem::forget(lock);
    let aside = earlier.as_ref().map_or(0, Replacement::count);
    *claimed() = Some(Claimed {
        dir: out.to_path_buf(),
        product,
        created,
        earlier,
    });
    Ok(aside)
}

/// The command completed: delete the earlier run that `--force` set aside.
pub fn keep() -> Result<(), OutputError> {
    match claimed().take().and_then(|c| c.earlier) {
        Some(earlier) => earlier.keep(),
        None => Ok(()),
    }
}

/// The command failed or was interrupted: put back the earlier run that `--force` set aside
/// (the files this run wrote deleted), or, in a folder the command created, delete the files
/// it wrote there (its product's names, temporary files included) and then the folder when
/// nothing but the lock is left. Anything else in the folder is left as it is. Returns what
/// to tell the user.
pub fn abandon() -> Option<String> {
    let c = claimed().take()?;
    if let Some(earlier) = c.earlier {
        let count = earlier.count();
        return Some(match earlier.undo() {
            Ok(()) => format!("the earlier run's {count} file(s) in --out are kept as they were"),
            Err(e) => format!("warning: the earlier run's files could not all be put back: {e}"),
        });
    }
    if c.created {
        delete_written(&c.dir, c.product);
    }
    None
}

/// Delete `product`'s files in `dir`, then `dir` with its lock where nothing else is left.
fn delete_written(dir: &Path, product: Product) {
    let mut left = 0;
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let ours = entry.file_type().is_ok_and(|t| t.is_file()) && product.writes(&name);
        if name != LOCK_FILE && !(ours && std::fs::remove_file(entry.path()).is_ok()) {
            left += 1;
        }
    }
    if left == 0 {
        let _ = std::fs::remove_file(dir.join(LOCK_FILE));
        let _ = std::fs::remove_dir(dir);
    }
}
