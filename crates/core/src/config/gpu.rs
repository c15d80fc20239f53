//! The map's `[gpu]` keys: settings of the GPU engine that do not change the physics.

use serde::{Deserialize, Serialize};

/// `gpu.layout`: where the GPU engine keeps an invocation's working arrays
/// (`crate::engine::gpu::state_layout`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LayoutChoice {
    /// The engine's rule (today: private).
    #[default]
    Auto,
    /// `var<private>` arrays.
    Private,
    /// A structure-of-arrays storage buffer.
    Global,
}

impl LayoutChoice {
    /// The accepted values of `gpu.layout`.
    pub const NAMES: [&'static str; 3] = ["auto", "private", "global"];

    /// The choice named `name`.
    pub fn from_name(name: &str) -> Option<LayoutChoice> {
        match name {
            "auto" => Some(LayoutChoice::Auto),
            "private" => Some(LayoutChoice::Private),
            "global" => Some(LayoutChoice::Global),
            _ => None,
        }
    }
}
