//! The map's `[gpu]` section: settings of the GPU engine that do not change the physics.
//!
//! `gpu.kernel` chooses how the integration spreads over the device ([`GpuKernelChoice`]); its
//! `workgroup` kernel was removed (issue 73) and is refused with the reason.
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
    /// One invocation per instance.
    Thread,
}

/// Read `gpu.kernel`.
pub(crate) fn read_kernel(r: &mut Reader) -> Result<GpuKernelChoice, ConfigError> {
    match r
        .choice("gpu.kernel", "auto", &["auto", "thread", "workgroup"])?
        .as_str()
    {
        "thread" => Ok(GpuKernelChoice::Thread),
        "workgroup" => Err(ConfigError::Inconsistent {
            key: "gpu.kernel".into(),
            reason: "\"workgroup\" was removed: the cooperative kernel was a hand-written copy \
                     of the physics that ran 17-49x slower on lavapipe and that \"auto\" never \
                     picked; the kernels are now generated from the Rust model (docs/model.md \
                     §14). Use \"auto\" or \"thread\""
                .into(),
        }),
        _ => Ok(GpuKernelChoice::Auto),
    }
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
