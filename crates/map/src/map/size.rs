//! A map's size before any work: its runs, their steps, the memory it holds and an estimate
//! of its integration time. A map above `HUGE_RUNS` runs, `HUGE_MEMORY` bytes or
//! [`HUGE_WORK`] instance-steps runs only when accepted (`map --yes`, `map.accept_huge`);
//! otherwise it is refused with these figures before it is planned.
//!
//! The time is estimated by a probe on the engine that would run the map: its first runs
//! (`PROBE_RUNS_CPU` on the CPU, `PROBE_RUNS_GPU` on a GPU) over `PROBE_PERIODS` forcing periods with
//! no transient and one cheap metric give the engine's rate (instance-steps/s); the map's
//! instance-steps over that rate is the estimate. A GPU's rate grows with the instance count,
//! so there the estimate is an upper bound. Settling (`map.settle_max_s`) counts as every cell
//! running on to `settle_max_s` (its most): the guard holds whatever the map's verdicts.

use crate::map::host_bytes_estimate;
use pendulum_atlas_core::config::{MapSpec, Metric};
use pendulum_atlas_core::engine::{
    Engine, EngineError, EnsembleOptions, EnsemblePlan, Readback, StepPlan, no_progress,
};
use pendulum_atlas_core::reduce::ReduceOptions;
use pendulum_atlas_core::text::{bytes, duration};

/// Runs (cells × starts) above which a map asks first.
pub(crate) const HUGE_RUNS: usize = 1_000_000;

/// Host memory (bytes) above which a map asks first.
pub(crate) const HUGE_MEMORY: u64 = 4 << 30;

/// Instance-steps above which a map asks first (about 2 h of the 2-core machine's CPU
/// engine at N = 3).
pub const HUGE_WORK: f64 = 1e11;

/// Forcing periods each probe run integrates (with no transient).
pub(crate) const PROBE_PERIODS: f64 = 8.0;

/// Runs of the timing probe on the CPU engine.
pub(crate) const PROBE_RUNS_CPU: usize = 64;

/// Runs of the timing probe on the GPU engine.
pub(crate) const PROBE_RUNS_GPU: usize = 4096;

/// A map's size (or a shard's), estimated before any work.
#[derive(Debug, Clone, PartialEq)]
pub struct MapSize {
    /// Runs: cells × starts (a shard's share of them).
    pub runs: usize,
    /// Steps of one run at the base scene's step.
    pub steps: u64,
    /// Steps a run may add by settling (a rerun to `map.settle_max_s`; 0 without settling).
    pub settle_steps: u64,
    /// Segments N.
    pub segments: usize,
    /// Host memory to plan and hold it (bytes): the whole map's, which every shard plans.
    pub memory_bytes: u64,
    /// The shard count it is a share of (1: the whole map).
    pub shards: u32,
}

impl MapSize {
    /// The size of `spec`'s map; `Err` when its base scene has no step plan.
    pub fn of(spec: &MapSpec) -> Result<MapSize, EngineError> {
        MapSize::of_shard(spec, 1)
    }

    /// The size of one of `shards` shards of `spec`'s map (the largest).
    pub fn of_shard(spec: &MapSpec, shards: u32) -> Result<MapSize, EngineError> {
        let plan = StepPlan::for_scene(&spec.scene)?;
        let runs = spec.instances() * spec.starts_per_cell();
        let per_s = plan.steps as f64 / spec.scene.integration.duration_s;
        Ok(MapSize {
            runs: runs.div_ceil(shards.max(1) as usize),
            steps: plan.steps,
            settle_steps: settle_steps(spec, per_s),
            segments: spec.scene.beam.segments,
            memory_bytes: host_bytes_estimate(spec),
            shards: shards.max(1),
        })
    }

    /// Instance-steps in all, settling's most included.
    pub fn work(&self) -> f64 {
        self.runs as f64 * (self.steps as f64 + self.settle_steps as f64)
    }

    /// Whether the map is above one of the sizes at which `map` asks first.
    pub fn is_huge(&self) -> bool {
        self.runs > HUGE_RUNS || self.memory_bytes > HUGE_MEMORY || self.work() > HUGE_WORK
    }

    /// The figures in words, with the integration time where a rate was probed (rate,
    /// probe runs, device).
    pub fn figures(&self, probed: Option<(f64, usize, &str)>) -> String {
        let whose = match self.shards {
            1 => "this map is large".to_string(),
            n => format!("each of the {n} shards of this map is large"),
        };
        let time = probed.map_or(String::new(), |(rate, runs, device)| {
            format!(
                ", and about {} of integration (at {rate:.2e} instance-steps/s, probed with {runs} runs on {device})",
                duration(self.work() / rate)
            )
        });
        let settling = match self.settle_steps {
            0 => String::new(),
            n => format!(" and up to {n} more settling (map.settle_max_s)"),
        };
        format!(
            "{whose}: {} runs of about {} steps each{settling} at N = {} ({:.2e} instance-steps), about {} of memory{time}",
            self.runs,
            self.steps,
            self.segments,
            self.work(),
            bytes(self.memory_bytes),
        )
    }

    /// This size refused, or said as accepted (`accepted`), with `probed`'s time.
    pub fn verdict(&self, accepted: bool, probed: Option<(f64, usize, &str)>) -> EngineError {
        let advice = if accepted {
            "accepted (--yes, map.accept_huge), it runs now"
        } else {
            "pass --yes (or set map.accept_huge = true) to run it, or use a coarser grid"
        };
        EngineError::HugeMap {
            figures: self.figures(probed),
            advice: advice.into(),
        }
    }
}

/// Refuse a huge map (or shard of `shards`) that is not accepted, with its figures (its time
/// probed on `engine`); a map below the sizes passes, and an accepted huge map's figures are
/// returned for the user.
pub fn check_map_size(
    spec: &MapSpec,
    shards: u32,
    engine: &Engine,
) -> Result<Option<EngineError>, EngineError> {
    let first = MapSize::of_shard(spec, shards)?;
    if !first.is_huge() {
        return Ok(None);
    }
    let probe = probe_rate(spec, engine)?;
    // The probe's plan has the map's own steps (a whole number per forcing period), which
    // the single-run plan of the first estimate only approaches.
    let size = MapSize {
        steps: (probe.steps_per_s * spec.scene.integration.duration_s).round() as u64,
        settle_steps: settle_steps(spec, probe.steps_per_s),
        ..first
    };
    if !size.is_huge() {
        return Ok(None);
    }
    let verdict = size.verdict(
        spec.accept_huge,
        Some((probe.rate, probe.runs, &engine.info().device)),
    );
    if spec.accept_huge {
        Ok(Some(verdict))
    } else {
        Err(verdict)
    }
}

/// The steps a run adds at most by settling, at `per_s` steps per simulated second: a run
/// from its start to `map.settle_max_s` (`settle.rs`; a cell continued from the map's end adds
/// `settle_max_s − duration_s`, one the early stop ended or `map.settle_from = "start"`
/// reruns the whole).
fn settle_steps(spec: &MapSpec, per_s: f64) -> u64 {
    spec.settle_max_s
        .map_or(0, |max_s| (per_s * max_s).round() as u64)
}

/// What the probe found.
struct Probe {
    /// Runs it took.
    runs: usize,
    /// The engine's rate (instance-steps/s).
    rate: f64,
    /// The mean steps per simulated second of those runs, as the map plans them.
    steps_per_s: f64,
}

/// The engine's rate on the map's first runs, each over [`PROBE_PERIODS`] periods of its
/// forcing with no transient and the α range alone.
fn probe_rate(spec: &MapSpec, engine: &Engine) -> Result<Probe, EngineError> {
    let cap = match engine.gpu_context() {
        Some(_) => PROBE_RUNS_GPU,
        None => PROBE_RUNS_CPU,
    };
    let runs = cap.min(spec.instances() * spec.starts_per_cell());
    let scenes = (0..runs)
        .map(|i| {
            let mut s = spec.run_scene(i)?;
            s.integration.transient_s = 0.0;
            s.integration.duration_s = PROBE_PERIODS / s.excitation.reference_frequency_hz();
            Ok(s)
        })
        .collect::<Result<Vec<_>, EngineError>>()?;
    let opts = EnsembleOptions {
        metrics: vec![Metric::AlphaRange],
        keep_strobe: false,
        early_stop: None,
        ..EnsembleOptions::from_spec(spec)
    };
    let plan = EnsemblePlan::from_scenes(&scenes, &opts)?;
    let run = engine.run(
        &plan,
        &ReduceOptions::default(),
        Readback::default(),
        &no_progress,
    )?;
    let steps_per_s = plan
        .instances
        .iter()
        .zip(&scenes)
        .map(|(p, s)| p.total_steps() as f64 / s.integration.duration_s)
        .sum::<f64>()
        / runs.max(1) as f64;
    Ok(Probe {
        runs,
        rate: plan.total_steps as f64 / run.integration_s().max(1e-9),
        steps_per_s,
    })
}
