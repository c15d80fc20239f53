//! What explore keeps of a calibration or a search beside its grid, read once by
//! `calibrate_folder` and `search_folder` and held in a [`super::folder::Source`].

use pendulum_atlas_design::calibrate::CalibrationSpec;
use pendulum_atlas_design::harvest::spec::SearchSpec;
use std::collections::HashMap;

/// How a candidate fared on one observation, as `candidates.csv` says.
#[derive(Debug, Clone)]
pub struct Judged {
    /// The observation, in words.
    pub observation: String,
    /// 1 when matched, 0 when not.
    pub matched: f64,
    /// Share of the initial states that matched.
    pub share: f64,
    /// Distance to the observation (0 when matched).
    pub distance: f64,
}

/// A calibration and what its candidates' rows say per case.
#[derive(Debug)]
pub struct Calibration {
    /// The calibration, rebuilt from `calibrate_scene.toml`.
    pub spec: CalibrationSpec,
    /// Its `calibrate.json`.
    pub manifest: pendulum_atlas_design::calibrate::CalibrateManifest,
    /// Per cell and case, the observations judged (empty where the grid has no candidate).
    pub judged: Vec<Vec<Vec<Judged>>>,
}

/// One row of `instances.csv`: what the search found for a design at one frequency from one
/// initial state.
#[derive(Debug, Clone, Copy)]
pub struct Found {
    /// Mean harvested power (W).
    pub power_w: f64,
    /// Hops between the wells.
    pub hops: f64,
    /// Period (forcing periods; 0 none, NaN not tested).
    pub period: f64,
}

/// `(design id, initial state name, frequency index)`.
pub(crate) type InstanceKey = (String, String, usize);

/// A search and what `instances.csv` says of each grid design.
#[derive(Debug)]
pub struct Search {
    /// The search, rebuilt from `search_scene.toml`.
    pub spec: SearchSpec,
    /// Its `search.json`.
    pub manifest: pendulum_atlas_design::harvest::SearchManifest,
    /// Per cell: its design's id in `instances.csv`.
    pub design: Vec<Option<String>>,
    /// What the search found per instance.
    pub instances: HashMap<InstanceKey, Found>,
}
