//! The map's `[gpu]` section: settings of the GPU engine that do not change the physics.
//!
//! No key is read from it today. `gpu.layout` chose where an invocation kept its working
//! arrays: `private` (`var<private>`) or `global` (a storage buffer, structure of arrays). The
//! global layout was slower on every adapter measured (lavapipe 16.5×; an NVIDIA H100 in 29 of
//! 29 rows) and was removed with the key; a scene that still sets it is refused with that reason.

use super::error::ConfigError;
use toml::Value;

/// Refuse the removed keys of a map's `[gpu]` section `gpu`, each with its reason.
pub(crate) fn refuse_removed(gpu: Option<&Value>) -> Result<(), ConfigError> {
    if gpu.and_then(|g| g.get("layout")).is_some() {
        return Err(ConfigError::Inconsistent {
            key: "gpu.layout".into(),
            reason: "was removed: the GPU kernels keep each invocation's arrays in private \
                     memory, the layout measured faster on every adapter (docs/model.md §14); \
                     delete the key"
                .into(),
        });
    }
    Ok(())
}
