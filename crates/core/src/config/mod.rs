//! Scenes: TOML files plus `--set key=value` overrides, validated into a typed [`Scene`].
//!
//! Parsing happens in two phases (as in ripgrep): the raw TOML table is overridden, then read
//! key by key into a [`Scene`] that can only hold valid values. Every key left unread is an
//! error, so a typo never silently falls back to a default.

mod continuation;
mod error;
mod field;
mod gpu;
mod map;
mod mode;
mod orbits;
mod physics;
mod reader;
mod scene;
mod settle;
mod starts;
mod sweep;
mod transients;

pub use crate::schema::Metric;
pub use continuation::{ContinuationSpec, Direction, Sweep};
pub use error::ConfigError;
pub use field::SceneField;
pub use gpu::GpuKernelChoice;
pub use map::{
    DEFAULT_MAP_TOML, LyapunovSettings, MAX_INSTANCES, MapSpec, Perturbation, SEPARATION_MAX,
    c_order_index, grid_point, load_map, map_from_toml, refuse_sets_on_swept, scene_text,
    split_section,
};
pub use mode::{MapMode, ModeKeys, RefineFollow, RefineSpec};
pub use orbits::{OrbitSpec, REACH_MAX};
pub use physics::DampingReport;
pub use reader::{
    MAX_SCENE_BYTES, Range, Reader, apply_override, parse_override_value, parse_toml,
    read_scene_file, set_key, shorten_lines,
};
pub use scene::{
    Beam, BeamDamping, ContactDamping, DEFAULT_ATOL, DEFAULT_RTOL, EARLIER_READING_DAMPING_RATIO,
    Excitation, ExcitationKind, Gravity, Initial, Integration, LIBRARY_JOINT_DAMPING_NMS,
    LIBRARY_SEGMENTS, Limiter, MAX_SEGMENTS, MethodChoice, Output, PAPER_SCENE_TOML, Piezo, Pivot,
    PivotMode, Scene, StepControl, TimeStep, Tip, load_scene,
};
pub use settle::{FIRM, SETTLE_LIMIT_S, SettleFrom};
pub use starts::{MAX_START_RATE_DEG_S, MAX_STARTS, Start, StartSet, StartSource, latin_hypercube};
pub use sweep::{
    AxisScale, MapAxis, SweepList, SweptKey, axis_label, entry_tables, key_unit, lookup_key,
    neighbours, point_key,
};
pub use transients::{COPIES_MAX, TransientSpec};
