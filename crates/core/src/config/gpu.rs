//! The map's `[gpu]` section: settings of the GPU engine that do not change the physics.
//!
//! `gpu.kernel` chooses how the integration spreads over the device ([`GpuKernelChoice`]).
//! `gpu.layout` chose where an invocation kept its working
//! arrays: `private` (`var<private>`) or `global` (a storage buffer, structure of arrays). The
//! global layout was slower on every adapter measured (lavapipe 16.5×; an NVIDIA H100 in 29 of
//! 29 rows) and was removed with the key; a scene that still sets it is refused with that reason.

use super::error::ConfigError;
use super::reader::Reader;
use serde::Serialize;
use toml::Value;

/// Which integration kernel the GPU engine runs (`gpu.kernel`); resolved for each ensemble by
/// `engine::gpu::kernels::GpuKernel::resolve`. The CPU engine has no such choice.
#[derive(Debug, Clone, Copy, Serialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum GpuKernelChoice {
    /// The engine's rule (the thread kernel until hardware measures otherwise).
    #[default]
    Auto,
    /// One invocation per instance: for ensembles that fill the device.
    Thread,
    /// One workgroup per instance, its segments over the lanes: for ensembles too small to
    /// fill it.
    Workgroup,
}

/// Read `gpu.kernel`.
pub(crate) fn read_kernel(r: &mut Reader) -> Result<GpuKernelChoice, ConfigError> {
    let kernel = match r
        .choice("gpu.kernel", "auto", &["auto", "thread", "workgroup"])?
        .as_str()
    {
        "thread" => GpuKernelChoice::Thread,
        "workgroup" => GpuKernelChoice::Workgroup,
        _ => GpuKernelChoice::Auto,
    };
    Ok(kernel)
}

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
