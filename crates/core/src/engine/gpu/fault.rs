//! A test-only failpoint that injects the GPU faults real hardware can raise, so that their
//! error path is tested on any adapter (lavapipe included):
//!
//! - `PENDULUM_ATLAS_GPU_FAULT=lose_device`: the device is destroyed after the first
//!   integration dispatch (a real loss: wgpu's device-lost callback fires and every later
//!   wait sees it);
//! - `PENDULUM_ATLAS_GPU_FAULT=oom`: the buffers' allocation reports out of memory.
//!
//! Any other value is refused with the accepted ones.

use crate::engine::error::EngineError;

/// The failpoint's environment variable.
pub const GPU_FAULT_ENV: &str = "PENDULUM_ATLAS_GPU_FAULT";

/// The faults the failpoint injects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failpoint {
    /// Destroy the device after the first integration dispatch.
    LoseDevice,
    /// Fail the buffers' allocation as out of memory.
    Oom,
}

/// The failpoint set in the environment, if any.
pub fn failpoint() -> Result<Option<Failpoint>, EngineError> {
    let Some(value) = std::env::var_os(GPU_FAULT_ENV) else {
        return Ok(None);
    };
    match value.to_str() {
        Some("") => Ok(None),
        Some("lose_device") => Ok(Some(Failpoint::LoseDevice)),
        Some("oom") => Ok(Some(Failpoint::Oom)),
        _ => Err(EngineError::Gpu {
            stage: "failpoint",
            message: format!(
                "{GPU_FAULT_ENV}={} is not a fault: the accepted values are lose_device and oom",
                value.to_string_lossy()
            ),
        }),
    }
}
