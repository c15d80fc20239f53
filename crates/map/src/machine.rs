//! What the machine has: memory available now and the space free on a file system, read
//! before work starts so that a run or a map too large for them is refused with the figures.

use std::path::Path;

/// Memory the machine has available now (bytes), where the system says.
pub fn memory_available() -> Option<u64> {
    let mut sys = sysinfo::System::new().ok()?;
    sys.refresh_memory();
    Some(sys.available_memory()).filter(|&m| m > 0)
}

/// Space free to this user on the file system of `dir` or its nearest existing ancestor.
pub(crate) fn free_space(dir: &Path) -> Option<u64> {
    dir.ancestors()
        .find(|p| p.exists())
        .and_then(|p| fs4::available_space(p).ok())
}
