//! One clicked cell, run again with its motion kept: the cell's scene is the run's scene with
//! the cell's axis values (and, for a calibration or a search, the chosen case or frequency
//! and initial state), with the integration method and the step `dt = 1/(f·spp)` its command
//! took pinned, so that `pendulum-atlas simulate` on the downloaded TOML runs exactly what the
//! page shows. The run is `simulate`'s: the CPU engine in f64, then
//! [`analyze_record`] with [`Scene::record_options`].

use super::CellLimits;
use super::error::ExploreError;
use super::folder::{RunFolder, Source};
use super::search_folder::split_variant;
use pendulum_atlas_core::analysis::{RecordAnalysis, stroboscopic};
use pendulum_atlas_core::config::Scene;
use pendulum_atlas_core::engine::{
    EnsembleOptions, Instance, Outcome, ProgressUnit, StepPlan, integrate,
};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_core::model::linear::LinearError;
use pendulum_atlas_core::text::bytes;
use pendulum_atlas_map::map::cell::{
    CellStages, cell_values, map_cell_table, read_cell_scene, rerun_cell,
};
use pendulum_atlas_map::output::TrajectoryRecorder;
use pendulum_atlas_map::output::budget::RunSize;
use serde::Serialize;
use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;
use toml::Table;

/// Most points of a curve sent to the page.
const MAX_POINTS: usize = 4000;
/// Most time columns and period rows of the scalogram sent to the page.
const MAX_SCALOGRAM: (usize, usize) = (480, 120);
/// The spectrum is sent up to this multiple of the forcing frequency (the paper's band).
const SPECTRUM_MAX_HARMONIC: f64 = 6.0;

/// A cell's scene: validated, and as the TOML `simulate` accepts.
#[derive(Debug, Clone)]
pub struct CellScene {
    /// The validated scene.
    pub scene: Scene,
    /// Its text (with `[cell]` for a cell of a plain map).
    pub toml: String,
    /// A plain map's cell: the map of that cell alone (`map::cell::read_cell_scene`).
    pub cell: Option<pendulum_atlas_core::config::MapSpec>,
}

/// The scene of cell `k` run as variant `v` (a case, or a frequency and initial state; 0 for
/// a map), with the method and the step its command took pinned.
pub fn cell_scene(folder: &RunFolder, k: usize, v: usize) -> Result<CellScene, ExploreError> {
    let fail = |e: String| ExploreError::Cell(format!("cell {k}: {e}"));
    let values = folder.values_of(k);
    let pinned = |t: Table, opts: &EnsembleOptions| {
        pendulum_atlas_map::map::cell::pinned_cell(t, opts)
            .map(|p| p.0)
            .map_err(|e| fail(e.to_string()))
    };
    let table = match &folder.source {
        // The map's cell as Python's `Scene.cell(..., run=ds)` makes it: one rule.
        Source::Map(spec, manifest) => {
            let start = match v {
                0 => folder.starts.get(k).copied(),
                s => Some(s - 1),
            };
            let ran = CellStages {
                ran_on: folder.ran_on.get(k).copied(),
                copies: folder.copies.get(k).copied(),
            };
            map_cell_table(spec, k, start, &manifest.method, ran, &[])
                .map_err(|e| fail(e.to_string()))?
                .0
        }
        Source::Calibrate(c) => {
            let t = c
                .spec
                .scene_table(&c.spec.cases[v], &values, 0.0)
                .map_err(|e| fail(e.to_string()))?;
            pinned(
                t,
                &pendulum_atlas_design::calibrate::run::options(&c.spec).0,
            )?
        }
        Source::Search(s) => {
            let spec = &s.spec;
            let (design, scene) = spec
                .design_table(&values)
                .map_err(|e| fail(e.to_string()))?;
            let (state, j) = split_variant(spec, v);
            let t = spec
                .instance_table(
                    &design,
                    scene.limiter.clearance_deg,
                    &spec.initial_states[state],
                    spec.band.frequencies_hz[j],
                )
                .map_err(|e| fail(e.to_string()))?;
            pinned(
                t,
                &pendulum_atlas_design::harvest::search::ensemble_options(spec),
            )?
        }
    };
    let toml = scene_text(folder, k, v, &table)?;
    let (scene, cell) =
        read_cell_scene(&toml, "<the cell>", &[]).map_err(|e| fail(e.to_string()))?;
    Ok(CellScene { scene, toml, cell })
}

/// The downloadable TOML of cell `k` (variant `v`), with a header saying where it comes from.
fn scene_text(
    folder: &RunFolder,
    k: usize,
    v: usize,
    table: &Table,
) -> Result<String, ExploreError> {
    let values: Vec<String> = folder
        .axes
        .iter()
        .zip(folder.values_of(k))
        .map(|(a, x)| format!("{} = {x}", a.key))
        .collect();
    let variant = folder
        .variants
        .get(v)
        .map_or_else(String::new, |n| format!(", run as `{n}`"));
    let body = toml::to_string(table).map_err(|e| {
        ExploreError::Cell(format!("cell {k}: its scene does not write as TOML: {e}"))
    })?;
    Ok(format!(
        "# Cell {k} of the `{}` run in {} ({}){variant}, with the method and step it took.\n\
         # `pendulum-atlas simulate THIS_FILE --out DIR` runs what `explore` showed.\n\n{body}",
        folder.product.command(),
        folder.dir.display(),
        values.join(", "),
    ))
}

/// A curve: x and y of equal length.
#[derive(Debug, Serialize, Default)]
pub struct Curve {
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
}

/// The wavelet power of α, thinned for the page.
#[derive(Debug, Serialize, Default)]
pub struct Scalogram {
    /// Time of each column (s).
    pub t_s: Vec<f64>,
    /// Fourier period of each row (s), short to long.
    pub period_s: Vec<f64>,
    /// log2 of the power over its maximum, `[row][column]`.
    pub log2_power: Vec<Vec<f64>>,
    /// Cone of influence per column (s): longer periods are unreliable there.
    pub coi_s: Vec<f64>,
}

/// What the page shows of a clicked cell.
#[derive(Debug, Serialize)]
pub struct CellRun {
    /// Cell index.
    pub cell: usize,
    /// The cell's axis values, `[key, value]` in axis order.
    pub values: Vec<(String, f64)>,
    /// How the run ended.
    pub status: Status,
    /// When it stopped early, the time (s).
    pub failed_at_s: Option<f64>,
    /// Segments, method and step.
    pub segments: usize,
    /// `rk4` or `imex`.
    pub method: &'static str,
    /// The step (s).
    pub dt_s: f64,
    /// Wall time of integration and analysis (s).
    pub wall_s: f64,
    /// K, R and period of this run, as `simulate` reports them (absent when not computed).
    pub simulated: BTreeMap<&'static str, Option<f64>>,
    /// The map's stored values of every metric for this cell (empty for other folders).
    pub map: BTreeMap<String, Option<f64>>,
    /// A plain map's cell: its values as the map computes them, rerun on the CPU engine in
    /// f64 (`map::cell::rerun_cell`): the map's numbers exactly where the map ran there.
    pub rerun: serde_json::Map<String, serde_json::Value>,
    /// What the folder says of this cell and variant, in words (a calibration's judgements,
    /// a search's power there).
    pub notes: Vec<String>,
    /// The variant run (`null` for a map).
    pub variant: Option<String>,
    /// α(t) (rad).
    pub alpha: Curve,
    /// Cart x0(t) (m).
    pub cart: Curve,
    /// α̇ against α after the transient.
    pub phase: Curve,
    /// (α, α̇) once per forcing period after the transient.
    pub strobe: Curve,
    /// Amplitude spectrum of α after the transient, up to six times the forcing.
    pub spectrum: Curve,
    /// Wavelet power of α.
    pub scalogram: Scalogram,
    /// Time from which the analysis runs (s).
    pub transient_s: f64,
    /// Forcing frequency (Hz).
    pub forcing_hz: f64,
    /// Anything the user should know (plan and analysis warnings).
    pub warnings: Vec<String>,
}

/// Memory a cell run holds per byte of its rows: the rows themselves, the analysis's copies
/// of α and the cart, its spectra and the wavelet transform of the (block-averaged) record.
/// Measured with `simulate` on the default scene (see `docs/bench/EXPLORE.md`).
pub(crate) const MEMORY_PER_ROW_BYTE: u64 = 18;

/// The memory a run of `scene` over `plan` holds in `explore` (bytes, estimated): its rows
/// times `MEMORY_PER_ROW_BYTE`.
pub fn cell_memory_bytes(scene: &Scene, plan: &StepPlan) -> Result<u64, ExploreError> {
    let size = RunSize::of_run(scene, plan).map_err(|e| ExploreError::Cell(e.to_string()))?;
    Ok(size.memory_bytes.saturating_mul(MEMORY_PER_ROW_BYTE))
}

/// A running cell's progress (0 to 1000) and the page's cancel.
#[derive(Debug, Default)]
pub struct CellControl {
    done: AtomicU64,
    cancelled: AtomicBool,
}

impl CellControl {
    /// Share of the steps done, 0 to 1.
    pub fn progress(&self) -> f64 {
        self.done.load(Ordering::Relaxed) as f64 / 1000.0
    }

    /// Ask the run to stop at its next output row.
    pub fn cancel(&self) {
        self.cancelled.store(true, Ordering::Relaxed);
    }

    /// Whether the run was asked to stop.
    pub(crate) fn is_cancelled(&self) -> bool {
        self.cancelled.load(Ordering::Relaxed)
    }
}

/// Integrate and analyse cell `k` (variant `v`) as `simulate` would, within `limits`:
/// refused before it starts when it would hold more memory, stopped when it runs longer or
/// when `control` is cancelled.
pub fn run_cell(
    folder: &RunFolder,
    k: usize,
    v: usize,
    control: &Arc<CellControl>,
    limits: CellLimits,
) -> Result<CellRun, ExploreError> {
    let started = Instant::now();
    let cs = cell_scene(folder, k, v)?;
    let scene = &cs.scene;
    let plan =
        StepPlan::for_scene(scene).map_err(|e| ExploreError::Cell(format!("cell {k}: {e}")))?;
    let need = cell_memory_bytes(scene, &plan)?;
    if need > limits.memory_bytes {
        return Err(ExploreError::TooLarge {
            cell: k,
            need: bytes(need),
            limit: bytes(limits.memory_bytes),
        });
    }
    let (rec, outcome) = record(scene, &plan, control, started, limits.wall_s)
        .map_err(|e| ExploreError::Cell(format!("cell {k}: {e}")))?;
    if rec.stopped {
        let done_percent = 100.0 * outcome.steps_done as f64 / plan.steps.max(1) as f64;
        return Err(if control.is_cancelled() {
            ExploreError::Cancelled(k)
        } else {
            ExploreError::TooLong {
                cell: k,
                limit_s: limits.wall_s,
                done_percent,
            }
        });
    }
    let t: Vec<f64> = rec.rows.iter().map(|r| r.t_s).collect();
    let alpha: Vec<f64> = rec.rows.iter().map(|r| r.alpha_rad).collect();
    let cart: Vec<f64> = rec.rows.iter().map(|r| r.x0_m).collect();
    let mut warnings = plan.warnings.clone();
    let analysis = analyse(scene, &plan, &outcome, &rec.rows, &mut warnings);
    let forcing_hz = scene.excitation.reference_frequency_hz();
    let rows = &rec.rows;
    let skip = rows.partition_point(|r| r.t_s < scene.integration.transient_s);
    let alpha_dot: Vec<f64> = rows.iter().map(|r| r.alpha_dot_rad_s).collect();
    Ok(CellRun {
        cell: k,
        values: folder
            .axes
            .iter()
            .zip(folder.values_of(k))
            .map(|(a, x)| (a.key.clone(), x))
            .collect(),
        status: outcome.status,
        failed_at_s: outcome.failed_at_s,
        segments: scene.beam.segments,
        method: plan.method.name(),
        dt_s: plan.dt_s,
        wall_s: started.elapsed().as_secs_f64(),
        simulated: simulated_values(analysis.as_ref()),
        map: map_values(folder, k),
        rerun: rerun_values(k, &cs, control)?,
        notes: notes(folder, k, v),
        variant: folder.variants.get(v).cloned(),
        alpha: thin(&t, &alpha),
        cart: thin(&t, &cart),
        phase: thin(&alpha[skip..], &alpha_dot[skip..]),
        strobe: strobe_section(&t, &alpha, &alpha_dot, forcing_hz, folder, scene),
        spectrum: analysis
            .as_ref()
            .map_or_else(Curve::default, |a| spectrum(a, forcing_hz)),
        scalogram: analysis.as_ref().map_or_else(Scalogram::default, scalogram),
        transient_s: scene.integration.transient_s,
        forcing_hz,
        warnings,
    })
}

/// Integrate `scene` with every output row kept, moving the progress from 0 to 1000; the
/// run stops at the row where `control` is cancelled or `wall_s` has passed since `started`
/// (the recorder's `stopped` then says so).
fn record(
    scene: &Scene,
    plan: &StepPlan,
    control: &Arc<CellControl>,
    started: Instant,
    wall_s: f64,
) -> Result<(TrajectoryRecorder, Outcome), LinearError> {
    let mut rec = TrajectoryRecorder {
        load_ohm: scene.piezo_params().map(|z| z.load_ohm),
        ..Default::default()
    };
    let (c, total) = (control.clone(), plan.steps.max(1));
    rec.on_row = Some(Box::new(move |step| {
        c.done
            .store(step.min(total) * 1000 / total, Ordering::Relaxed);
        if c.is_cancelled() || started.elapsed().as_secs_f64() > wall_s {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }));
    let outcome = integrate(&Instance::<f64>::from_scene(scene)?, plan, &mut rec);
    Ok((rec, outcome))
}

/// `simulate`'s analysis of a run that ended ok; why not, in `warnings`, otherwise.
fn analyse(
    scene: &Scene,
    plan: &StepPlan,
    outcome: &Outcome,
    rows: &[pendulum_atlas_map::output::Row],
    warnings: &mut Vec<String>,
) -> Option<RecordAnalysis> {
    if outcome.status != Status::Ok {
        warnings.push(format!("the run stopped with status `{}`", outcome.status));
        return None;
    }
    match pendulum_atlas_map::output::record_analysis(scene, plan, rows) {
        Ok(a) => {
            warnings.extend(a.warnings.iter().cloned());
            Some(a)
        }
        Err(e) => {
            warnings.push(format!("analysis skipped: {e}"));
            None
        }
    }
}

/// A plain map's cell rerun as its map computes it (`run.json`'s `map_cell` of `simulate`);
/// nothing for other cells. A cancel from the page stops it.
fn rerun_values(
    k: usize,
    cs: &CellScene,
    control: &Arc<CellControl>,
) -> Result<serde_json::Map<String, serde_json::Value>, ExploreError> {
    let Some(spec) = &cs.cell else {
        return Ok(serde_json::Map::new());
    };
    let c = control.clone();
    let go_on = move |_: u64, _: u64, _: ProgressUnit| match c.is_cancelled() {
        true => ControlFlow::Break(()),
        false => ControlFlow::Continue(()),
    };
    let r = rerun_cell(spec, &go_on).map_err(|e| match e {
        pendulum_atlas_core::engine::EngineError::Cancelled => ExploreError::Cancelled(k),
        e => ExploreError::Cell(format!("cell {k}: {e}")),
    })?;
    Ok(cell_values(spec, &r))
}

/// K, R and period as `simulate` writes them in `run.json` (`analysis`).
fn simulated_values(a: Option<&RecordAnalysis>) -> BTreeMap<&'static str, Option<f64>> {
    BTreeMap::from([
        ("K", a.and_then(|a| a.zero_one.as_ref().map(|z| z.k))),
        ("R", a.and_then(|a| a.phase_sync.as_ref().map(|p| p.r))),
        (
            "period",
            a.and_then(|a| a.statistics.period.map(|p| p as f64)),
        ),
        ("hops", a.and_then(|a| a.statistics.hops.map(|h| h as f64))),
        ("line_ratio", a.and_then(|a| a.spectrum.ratio_to_forcing)),
    ])
}

/// Every metric the map stored for cell `k` (`null` where not finite); none for a folder
/// that is not a map.
fn map_values(folder: &RunFolder, k: usize) -> BTreeMap<String, Option<f64>> {
    if folder.source.map().is_none() {
        return BTreeMap::new();
    }
    folder
        .columns
        .iter()
        .map(|c| {
            (
                c.name.clone(),
                c.values[k].is_finite().then_some(c.values[k]),
            )
        })
        .collect()
}

/// What a calibration or a search found for cell `k` run as variant `v`.
fn notes(folder: &RunFolder, k: usize, v: usize) -> Vec<String> {
    match &folder.source {
        Source::Map(spec, _) if v == 0 => match spec.continuation() {
            Some(c) => vec![format!(
                "this map ran by continuation along {}: each cell started from the state its neighbour ended in, and this run starts from the scene's own state, so it may land on another attractor (where hysteresis.npy is 1, the two sweeps did)",
                c.key
            )],
            None => Vec::new(),
        },
        Source::Map(..) => {
            let reached = folder.cell_attractors[k]
                .iter()
                .find(|a| a.start == v - 1)
                .map_or(String::new(), |a| {
                    format!(
                        ", and is the first start of this cell to reach `{}`",
                        a.name
                    )
                });
            vec![format!(
                "this run is start {v} of the cell{reached}; the map's values are those of its representative start {}",
                folder.starts.get(k).map_or(1, |s| s + 1)
            )]
        }
        Source::Calibrate(c) => c.judged[k]
            .get(v)
            .map(|obs| {
                obs.iter()
                    .map(|j| {
                        format!(
                            "{}: {} (share of initial states {}, distance {:.3})",
                            j.observation,
                            if j.matched > 0.5 {
                                "matched"
                            } else {
                                "not matched"
                            },
                            j.share,
                            j.distance
                        )
                    })
                    .collect()
            })
            .unwrap_or_default(),
        Source::Search(s) => {
            let (state, j) = split_variant(&s.spec, v);
            let name = &s.spec.initial_states[state].name;
            s.design[k]
                .as_ref()
                .and_then(|d| s.instances.get(&(d.clone(), name.clone(), j)))
                .map(|found| {
                    vec![format!(
                        "the search at {} Hz from `{name}`: power {:.4e} W, {} hops, period {}",
                        s.spec.band.frequencies_hz[j], found.power_w, found.hops, found.period
                    )]
                })
                .unwrap_or_default()
        }
    }
}

/// At most [`MAX_POINTS`] of `(x, y)`, evenly thinned.
fn thin(x: &[f64], y: &[f64]) -> Curve {
    let every = x.len().div_ceil(MAX_POINTS).max(1);
    Curve {
        x: x.iter().step_by(every).copied().collect(),
        y: y.iter().step_by(every).copied().collect(),
    }
}

/// (α, α̇) at the map's stroboscopic phase, once per forcing period after the transient.
fn strobe_section(
    t: &[f64],
    alpha: &[f64],
    alpha_dot: &[f64],
    forcing_hz: f64,
    folder: &RunFolder,
    scene: &Scene,
) -> Curve {
    let phase = std::f64::consts::TAU * folder.source.map().map_or(0.0, |m| m.strobe_phase);
    let tr = scene.integration.transient_s;
    let at = |x: &[f64]| stroboscopic(t, x, forcing_hz, phase, tr).unwrap_or_default();
    let (x, y) = (at(alpha), at(alpha_dot));
    let n = x.len().min(y.len());
    Curve {
        x: x[..n].to_vec(),
        y: y[..n].to_vec(),
    }
}

/// The amplitude spectrum of α up to [`SPECTRUM_MAX_HARMONIC`] times the forcing.
fn spectrum(a: &RecordAnalysis, forcing_hz: f64) -> Curve {
    let s = &a.spectrum_full;
    let keep = s
        .frequency_hz
        .iter()
        .take_while(|&&f| f <= SPECTRUM_MAX_HARMONIC * forcing_hz)
        .count();
    thin(&s.frequency_hz[..keep], &s.amplitude[..keep])
}

/// The wavelet power of α, thinned to at most [`MAX_SCALOGRAM`], as log2 of power over its
/// maximum.
fn scalogram(a: &RecordAnalysis) -> Scalogram {
    let w = &a.wavelet_full;
    let cols = w.power.first().map_or(0, Vec::len);
    if cols == 0 {
        return Scalogram::default();
    }
    let ce = cols.div_ceil(MAX_SCALOGRAM.0).max(1);
    let re = w.power.len().div_ceil(MAX_SCALOGRAM.1).max(1);
    let max = w
        .power
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f64::MIN_POSITIVE, f64::max);
    let t0 = a.analysed_from_s;
    Scalogram {
        t_s: (0..cols)
            .step_by(ce)
            .map(|j| t0 + j as f64 * w.dt_s)
            .collect(),
        period_s: w.period_s.iter().step_by(re).copied().collect(),
        log2_power: w
            .power
            .iter()
            .step_by(re)
            .map(|row| {
                row.iter()
                    .step_by(ce)
                    .map(|&p| (p.max(max * 1e-12) / max).log2())
                    .collect()
            })
            .collect(),
        coi_s: w.coi_s.iter().step_by(ce).copied().collect(),
    }
}
