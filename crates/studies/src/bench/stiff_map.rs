//! The map half of the stiff-chain study, `pendulum-atlas bench --stiff-map`: does the IMEX
//! method classify a map's cells as RK4 at its own (stability) limit does?
//!
//! One (f, A) map at N = 17 with the library damping, every cell a 2-s transient and 100
//! forcing periods, integrated as:
//! - `rk4`: RK4 at its automatic step, CPU f64: the reference map;
//! - `imex`: the IMEX method at its automatic step on each engine;
//! - `imex-twin`: the same from a start perturbed by `TWIN_RATE_DEG_S` (CPU f64);
//! - `imex-half`: the IMEX method at half its automatic step (CPU f64).
//!
//! A chaotic trajectory's K over 100 periods scatters about 0.5 and its class can change with
//! the start itself. The twin measures that floor: the share of cells on which two starts
//! 1e-3 deg/s apart already disagree. A cell is **settled** when `imex`, `imex-twin` and
//! `imex-half` agree on K class and period among themselves: what a user can establish
//! without RK4. Agreement with the reference is reported over all cells RK4 classifies and
//! over the settled ones.

use super::{run_map_scenes, timing};
use pendulum_atlas_core::config::{MethodChoice, Metric, Scene, TimeStep};
use pendulum_atlas_core::engine::method::{Method, MethodSteps};
use pendulum_atlas_core::engine::{Engine, EngineError, EngineKind, Precision};
use pendulum_atlas_core::model::{ExcitationKind, Status};
use serde::Serialize;
use std::time::Instant;

/// Perturbation of the twin's initial rate of every segment (deg/s).
pub(crate) const TWIN_RATE_DEG_S: f64 = 1e-3;

/// The K class threshold.
const K_CHAOTIC: f64 = 0.5;

/// One map of the study: its settings and each cell's result.
#[derive(Debug, Clone, Serialize)]
pub struct MapCells {
    /// `rk4`, `imex`, `imex-twin` or `imex-half`.
    pub label: String,
    /// Integration method.
    pub method: Method,
    /// Engine.
    pub backend: EngineKind,
    /// Float type.
    pub precision: Precision,
    /// Step (s), the largest of the map.
    pub dt_s: f64,
    /// Engine wall time (s).
    pub wall_s: f64,
    /// K per cell (NaN where not ok).
    pub k: Vec<f64>,
    /// Period per cell in forcing periods (0 = none).
    pub period: Vec<f64>,
    /// Status per cell.
    pub status: Vec<Status>,
}

impl MapCells {
    fn ok(&self, c: usize) -> bool {
        self.status[c] == Status::Ok
    }

    /// Same K class and same period as `other` at cell `c`, both ok.
    pub fn agrees(&self, other: &MapCells, c: usize) -> (bool, bool) {
        let both = self.ok(c) && other.ok(c);
        (
            both && (self.k[c] > K_CHAOTIC) == (other.k[c] > K_CHAOTIC),
            both && self.period[c].to_bits() == other.period[c].to_bits(),
        )
    }
}

/// Agreement of one map with the reference.
#[derive(Debug, Clone, Serialize)]
pub struct Agreement {
    /// The map's label and engine.
    pub map: String,
    /// Cells counted.
    pub cells: usize,
    /// Cells with the same K class.
    pub k_class: usize,
    /// Cells with the same period.
    pub period: usize,
    /// Cells with both.
    pub both: usize,
}

/// The study.
#[derive(Debug, Clone, Serialize)]
pub struct StiffMapReport {
    /// Machine description.
    pub machine: String,
    /// Segments.
    pub segments: usize,
    /// Forcing frequencies (Hz).
    pub frequencies_hz: Vec<f64>,
    /// Amplitudes (m).
    pub amplitudes_m: Vec<f64>,
    /// (f, A) per cell, amplitude fastest.
    pub cells: Vec<(f64, f64)>,
    /// The reference map first.
    pub maps: Vec<MapCells>,
    /// Cells RK4 classifies (ok on the reference).
    pub classified: Vec<usize>,
    /// Classified cells on which the IMEX CPU f64 map, its twin and its half step agree.
    pub settled: Vec<usize>,
    /// Each map against the reference over the classified cells.
    pub over_classified: Vec<Agreement>,
    /// Each map against the reference over the settled cells.
    pub over_settled: Vec<Agreement>,
    /// The floor: `imex` against `imex-twin` over the classified cells.
    pub twin_floor: Agreement,
    /// Total wall time (s).
    pub total_s: f64,
}

/// Settings of the study.
pub struct StiffMapOptions<'a> {
    /// N = 5 and a 2 × 2 grid (a test of the study itself, minutes less).
    pub quick: bool,
    /// The GPU engine, when measured too.
    pub gpu: Option<&'a Engine>,
}

/// The grid: (frequencies, amplitudes, N).
fn grid(quick: bool) -> (Vec<f64>, Vec<f64>, usize) {
    if quick {
        return (vec![8.0, 12.0], vec![0.009, 0.015], 5);
    }
    let fs = (7..=12).map(f64::from).collect();
    let amps = (0..8).map(|i| 0.006 + 0.0015 * f64::from(i)).collect();
    (fs, amps, 17)
}

/// A map's variant: method, step factor and start perturbation.
#[derive(Clone, Copy)]
struct Variant {
    label: &'static str,
    method: Method,
    dt_factor: f64,
    twin: bool,
}

const RK4: Variant = Variant {
    label: "rk4",
    method: Method::Rk4,
    dt_factor: 1.0,
    twin: false,
};
const IMEX: Variant = Variant {
    label: "imex",
    method: Method::Imex,
    dt_factor: 1.0,
    twin: false,
};
const IMEX_TWIN: Variant = Variant {
    label: "imex-twin",
    twin: true,
    ..IMEX
};
const IMEX_HALF: Variant = Variant {
    label: "imex-half",
    dt_factor: 0.5,
    ..IMEX
};

fn scenes(cells: &[(f64, f64)], n: usize, v: Variant) -> Result<Vec<Scene>, EngineError> {
    cells
        .iter()
        .map(|&(f, a)| {
            let mut s = Scene::paper();
            s.beam.segments = n;
            s.excitation.kind = ExcitationKind::Harmonic { frequency_hz: f };
            s.excitation.amplitude_m = a;
            timing(&mut s, 2.0 + 100.0 / f, 2.0);
            if v.twin {
                s.initial.rate_deg_s += TWIN_RATE_DEG_S;
            }
            let auto = MethodSteps::of_scene(&s)?.auto_s(v.method);
            s.integration.method = match v.method {
                Method::Rk4 => MethodChoice::Rk4,
                Method::Imex => MethodChoice::Imex,
            };
            s.integration
                .set_fixed(TimeStep::Seconds(v.dt_factor * auto));
            Ok(s)
        })
        .collect()
}

fn run_variant(
    cells: &[(f64, f64)],
    n: usize,
    v: Variant,
    engine: &Engine,
) -> Result<MapCells, EngineError> {
    let map = run_map_scenes(
        &scenes(cells, n, v)?,
        vec![Metric::K, Metric::Period],
        engine,
    )?;
    let info = engine.info();
    Ok(MapCells {
        label: v.label.to_string(),
        method: v.method,
        backend: info.kind,
        precision: info.precision,
        dt_s: map.plan.dt_range_s.1,
        wall_s: map.engine_s(),
        k: map.results.iter().map(|r| r.k).collect(),
        period: map.results.iter().map(|r| r.period).collect(),
        status: map.results.iter().map(|r| r.status).collect(),
    })
}

/// `map` against `reference` over `cells`.
pub fn agreement(map: &MapCells, reference: &MapCells, cells: &[usize]) -> Agreement {
    let pairs: Vec<(bool, bool)> = cells.iter().map(|&c| map.agrees(reference, c)).collect();
    Agreement {
        map: format!(
            "{} ({} {})",
            map.label,
            map.backend.name(),
            map.precision.name()
        ),
        cells: cells.len(),
        k_class: pairs.iter().filter(|p| p.0).count(),
        period: pairs.iter().filter(|p| p.1).count(),
        both: pairs.iter().filter(|p| p.0 && p.1).count(),
    }
}

/// Classified cells on which `imex`, `twin` and `half` agree on K class and period.
fn settled(classified: &[usize], imex: &MapCells, twin: &MapCells, half: &MapCells) -> Vec<usize> {
    let same = |a: &MapCells, b: &MapCells, c: usize| a.agrees(b, c) == (true, true);
    classified
        .iter()
        .copied()
        .filter(|&c| same(imex, twin, c) && same(imex, half, c))
        .collect()
}

/// The IMEX maps: CPU f64 (plain, twin, half step), CPU f32, then the GPU.
fn imex_maps(
    cells: &[(f64, f64)],
    n: usize,
    gpu: Option<&Engine>,
    progress: &dyn Fn(&str),
) -> Result<Vec<MapCells>, EngineError> {
    let (cpu64, cpu32) = (Engine::cpu(Precision::F64), Engine::cpu(Precision::F32));
    let mut runs: Vec<(Variant, &Engine)> = vec![
        (IMEX, &cpu64),
        (IMEX_TWIN, &cpu64),
        (IMEX_HALF, &cpu64),
        (IMEX, &cpu32),
    ];
    runs.extend(gpu.map(|g| (IMEX, g)));
    let mut maps = Vec::new();
    for (v, engine) in runs {
        let m = run_variant(cells, n, v, engine)?;
        progress(&format!(
            "{} on {} {}: {:.1} s",
            m.label,
            m.backend.name(),
            m.precision.name(),
            m.wall_s
        ));
        maps.push(m);
    }
    Ok(maps)
}

/// Run the study: the IMEX maps first (seconds), then RK4's reference (the long part).
pub fn run_stiff_map(
    opts: &StiffMapOptions,
    progress: &dyn Fn(&str),
) -> Result<StiffMapReport, EngineError> {
    let t_all = Instant::now();
    let (fs, amps, n) = grid(opts.quick);
    let cells: Vec<(f64, f64)> = fs
        .iter()
        .flat_map(|&f| amps.iter().map(move |&a| (f, a)))
        .collect();
    let imex = imex_maps(&cells, n, opts.gpu, progress)?;
    progress(&format!(
        "rk4 reference: {} cells at N = {n} on the CPU in f64 (the long part)",
        cells.len()
    ));
    let reference = run_variant(&cells, n, RK4, &Engine::cpu(Precision::F64))?;
    progress(&format!("rk4 reference: {:.1} s", reference.wall_s));
    let classified: Vec<usize> = (0..cells.len()).filter(|&c| reference.ok(c)).collect();
    let settled = settled(&classified, &imex[0], &imex[1], &imex[2]);
    let mut maps = vec![reference];
    maps.extend(imex);
    let over = |cs: &[usize]| {
        maps[1..]
            .iter()
            .map(|m| agreement(m, &maps[0], cs))
            .collect()
    };
    Ok(StiffMapReport {
        machine: super::machine(opts.gpu),
        segments: n,
        over_classified: over(&classified),
        over_settled: over(&settled),
        twin_floor: agreement(&maps[2], &maps[1], &classified),
        frequencies_hz: fs,
        amplitudes_m: amps,
        cells,
        classified,
        settled,
        maps,
        total_s: t_all.elapsed().as_secs_f64(),
    })
}
