//! What ran a study, as its manifest states it (`about` of `calibrate.json` and `search.json`).

use pendulum_atlas_core::engine::EngineInfo;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The scene file, its overrides, the engine and the wall time of a study.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StudyAbout {
    /// The scene file, as given.
    pub scene: String,
    /// The `--set` overrides, in order.
    pub sets: Vec<String>,
    /// The engine that ran it.
    pub engine: EngineInfo,
    /// Wall time of the study (s).
    pub wall_s: f64,
}

impl StudyAbout {
    /// The about block of a study of `scene` with `sets`, run on `engine` in `wall_s`.
    pub fn new(scene: &Path, sets: &[String], engine: EngineInfo, wall_s: f64) -> StudyAbout {
        StudyAbout {
            scene: scene.display().to_string(),
            sets: sets.to_vec(),
            engine,
            wall_s,
        }
    }
}
