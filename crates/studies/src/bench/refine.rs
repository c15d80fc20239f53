//! What the early stop and adaptive refinement skip, `pendulum-atlas bench --refine`: the
//! default map's scene at a publication grid (257 × 193 points, 256 × 192 intervals) run in
//! full, with the early stop, and with the early stop and refinement, on the CPU engine and
//! (when open) the GPU engine; each scored against its engine's full map.
//!
//! Per row: instance-steps integrated, wall time, cells stopped early and inferred, the
//! audit's agreement, and the share of cells whose regime (and, for periodic cells, period)
//! equals the full map's.
//!
//! **Replays.** A cell's result does not depend on which other cells are computed with it
//! (the engine suite holds batches bit for bit), so refinement with other settings is
//! replayed on the CPU engine's early-stop map: [`refine`] is given that map's results
//! instead of an engine, and counts the steps of the cells it asks for. The replay of the
//! shipped setting is checked against the real refined run, cell for cell.
//!
//! **Ceilings.** From the full map: the early stop's, were every periodic and regular cell
//! free; and the share of cells with a neighbour of another regime (a refinement that
//! computes exactly the boundary cells gets every regime right at that cost).

use pendulum_atlas_core::config::{
    DEFAULT_MAP_TOML, MapSpec, RefineFollow, RefineSpec, map_from_toml,
};
use pendulum_atlas_core::engine::{Engine, EngineError, no_progress};
use pendulum_atlas_core::reduce::{InstanceResult, Regime};
use pendulum_atlas_map::map::refine::{agree, refine};
use pendulum_atlas_map::map::{MapRun, run_map};
use serde::Serialize;
use std::time::Instant;

/// Points per axis of the study's grid (frequency, amplitude): 256 × 192 intervals.
pub(crate) const REFINE_GRID: (usize, usize) = (257, 193);

/// Points per axis of `--quick` (32 × 24 intervals).
pub(crate) const REFINE_GRID_QUICK: (usize, usize) = (33, 25);

/// Settings replayed: (coarse spacing, audit minimum), those whose spacing divides the grid;
/// the shipped audit share. An audit minimum of 0 never goes deeper: corners alone decide.
const REPLAYS: [(u32, f64); 10] = [
    (8, 0.0),
    (4, 0.95),
    (4, 0.98),
    (4, 0.99),
    (8, 0.95),
    (8, 0.98),
    (8, 0.99),
    (16, 0.95),
    (16, 0.98),
    (16, 0.99),
];

/// The options of the study.
pub struct RefineOptions<'a> {
    /// The quick grid (a test of the study, not a result).
    pub quick: bool,
    /// The GPU engine, when one is open: its rows join the CPU's.
    pub gpu: Option<&'a Engine>,
}

/// One map of the study.
#[derive(Debug, Clone, Serialize)]
pub struct RefineRow {
    /// The engine's device.
    pub engine: String,
    /// "full", "early stop", or "early stop + refinement".
    pub setting: String,
    /// Instance-steps integrated.
    pub instance_steps: u64,
    /// The full grid's instance-steps over this row's.
    pub fewer_steps: f64,
    /// Wall time of the map (s).
    pub wall_s: f64,
    /// The full map's wall time over this row's.
    pub speedup: f64,
    /// Cells stopped early.
    pub stopped_early: usize,
    /// Cells filled by refinement.
    pub inferred: usize,
    /// The refinement audit's first agreement (NaN without refinement).
    pub audit_agreement: f64,
    /// Share of cells whose regime (and period, where periodic) equals the full map's.
    pub equal_regime: f64,
}

/// One replayed refinement setting (see the module doc).
#[derive(Debug, Clone, Serialize)]
pub struct ReplayRow {
    /// Coarse spacing.
    pub spacing: u32,
    /// Audit minimum (0: the audit never sends a class deeper).
    pub audit_min: f64,
    /// Audit share.
    pub audit_share: f64,
    /// Cells computed.
    pub computed: usize,
    /// Instance-steps of the computed cells.
    pub instance_steps: u64,
    /// The full map's instance-steps over this replay's.
    pub fewer_steps: f64,
    /// The audit's first and last agreement.
    pub first_agreement: f64,
    /// The audit's last agreement.
    pub final_agreement: f64,
    /// Audit rounds.
    pub rounds: usize,
    /// Share of cells whose regime (and period) equals the full map's.
    pub equal_regime: f64,
}

/// Bounds from the full map (see the module doc).
#[derive(Debug, Clone, Serialize)]
pub struct Ceilings {
    /// The full map's steps over its steps without those of its periodic and regular cells.
    pub early_stop: f64,
    /// Share of cells with a neighbour (along an axis) of another regime or period.
    pub boundary_share: f64,
    /// Share of cells whose every neighbour differs from them.
    pub isolated_share: f64,
}

/// The study's result.
#[derive(Debug, Clone, Serialize)]
pub struct RefineReport {
    /// Points per axis.
    pub grid: (usize, usize),
    /// The rows, per engine: full, early stop, both.
    pub rows: Vec<RefineRow>,
    /// Refinement settings replayed on the CPU engine's early-stop map.
    pub replays: Vec<ReplayRow>,
    /// The replay of the shipped setting equals the real refined run, cell for cell.
    pub replay_matches_run: bool,
    /// Bounds from the CPU engine's full map.
    pub ceilings: Ceilings,
    /// The shipped refinement setting.
    pub shipped: RefineSpec,
    /// Wall time of the study (s).
    pub total_s: f64,
    /// The machine, in words.
    pub machine: String,
}

/// The default map at `grid` with the early stop and refinement as given.
fn spec(grid: (usize, usize), early: bool, refine: bool) -> Result<MapSpec, EngineError> {
    let text = DEFAULT_MAP_TOML
        .replace("count = 64", &format!("count = {}", grid.0))
        .replace("count = 48", &format!("count = {}", grid.1));
    let sets = vec![
        format!("map.early_stop={early}"),
        format!("map.refine={refine}"),
        // The full map against the refined one, both raw (a refined map does not settle).
        "map.settle=false".to_string(),
    ];
    Ok(map_from_toml(&text, "the default map", &sets)?)
}

fn timed(spec: &MapSpec, engine: &Engine) -> Result<(MapRun, f64), EngineError> {
    let t0 = Instant::now();
    let run = run_map(spec, engine, &no_progress)?;
    Ok((run, t0.elapsed().as_secs_f64()))
}

fn steps(results: &[InstanceResult]) -> u64 {
    results.iter().map(|r| r.steps).sum()
}

/// Share of `results` whose regime (and period) equals `full`'s.
fn equal_share(full: &[InstanceResult], results: &[InstanceResult]) -> f64 {
    let equal = full
        .iter()
        .zip(results)
        .filter(|(a, b)| agree(a, b, RefineFollow::Regime))
        .count();
    equal as f64 / full.len().max(1) as f64
}

/// Run the study (see the module doc); `log` gets a line per map.
pub fn run_refine(opts: &RefineOptions, log: &dyn Fn(String)) -> Result<RefineReport, EngineError> {
    let t0 = Instant::now();
    let grid = if opts.quick {
        REFINE_GRID_QUICK
    } else {
        REFINE_GRID
    };
    let cpu = Engine::cpu(pendulum_atlas_core::engine::Precision::F64);
    let mut engines = vec![&cpu];
    engines.extend(opts.gpu);
    let shipped_spec = spec(grid, true, true)?;
    let shipped = *shipped_spec.refine().expect("refinement asked for");
    let mut rows = Vec::new();
    let mut cpu_maps: Option<(MapRun, MapRun, MapRun)> = None;
    for engine in engines {
        let (full, full_s) = timed(&spec(grid, false, false)?, engine)?;
        let (early, early_s) = timed(&spec(grid, true, false)?, engine)?;
        let (both, both_s) = timed(&shipped_spec, engine)?;
        for (setting, run, wall_s) in [
            ("full", &full, full_s),
            ("early stop", &early, early_s),
            ("early stop + refinement", &both, both_s),
        ] {
            let row = RefineRow {
                engine: engine.info().device.clone(),
                setting: setting.into(),
                instance_steps: steps(&run.results),
                fewer_steps: steps(&full.results) as f64 / steps(&run.results).max(1) as f64,
                wall_s,
                speedup: full_s / wall_s.max(1e-9),
                stopped_early: run.stopped_early,
                inferred: run.inferred.iter().filter(|&&i| i).count(),
                audit_agreement: run.refine.as_ref().map_or(f64::NAN, |r| r.audit.agreement),
                equal_regime: equal_share(&full.results, &run.results),
            };
            log(format!(
                "{} / {}: {:.3e} instance-steps ({:.2}x fewer), {:.1} s, {:.2} % equal regimes",
                row.engine,
                row.setting,
                row.instance_steps as f64,
                row.fewer_steps,
                wall_s,
                100.0 * row.equal_regime
            ));
            rows.push(row);
        }
        if cpu_maps.is_none() {
            cpu_maps = Some((full, early, both));
        }
    }
    let (full, early, both) = cpu_maps.expect("the CPU engine ran");
    let divides = |h: u32| [grid.0, grid.1].iter().all(|&n| (n - 1) % h as usize == 0);
    let replays = REPLAYS
        .iter()
        .filter(|&&(spacing, _)| divides(spacing))
        .map(|&(spacing, audit_min)| {
            let rs = RefineSpec {
                spacing,
                audit_min,
                ..shipped
            };
            replay(&shipped_spec, &rs, &full.results, &early.results)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let again = refine(&shipped_spec, &shipped, |idx| {
        Ok(idx.iter().map(|&k| early.results[k]).collect())
    })?;
    let replay_matches_run = again.inferred == both.inferred
        && again.results.iter().zip(&both.results).all(|(a, b)| {
            a.regime == b.regime && a.k.to_bits() == b.k.to_bits() && a.steps == b.steps
        });
    Ok(RefineReport {
        grid,
        rows,
        replays,
        replay_matches_run,
        ceilings: ceilings(&full.results, grid),
        shipped,
        total_s: t0.elapsed().as_secs_f64(),
        machine: super::machine(opts.gpu),
    })
}

/// Refinement with `rs` on the results `early` (see the module doc), scored against `full`.
fn replay(
    spec: &MapSpec,
    rs: &RefineSpec,
    full: &[InstanceResult],
    early: &[InstanceResult],
) -> Result<ReplayRow, EngineError> {
    let out = refine(spec, rs, |idx| Ok(idx.iter().map(|&k| early[k]).collect()))?;
    let a = &out.report.audit;
    Ok(ReplayRow {
        spacing: rs.spacing,
        audit_min: rs.audit_min,
        audit_share: rs.audit_share,
        computed: out.report.computed,
        instance_steps: steps(&out.results),
        fewer_steps: steps(full) as f64 / steps(&out.results).max(1) as f64,
        first_agreement: a.agreement,
        final_agreement: a.final_agreement,
        rounds: a.rounds.len(),
        equal_regime: equal_share(full, &out.results),
    })
}

/// The bounds of the module doc on a 2-axis grid of `shape` points.
fn ceilings(full: &[InstanceResult], shape: (usize, usize)) -> Ceilings {
    let settled = |r: &InstanceResult| matches!(r.regime, Regime::Periodic | Regime::Regular);
    let free: u64 = full.iter().filter(|r| settled(r)).map(|r| r.steps).sum();
    let (nx, ny) = shape;
    let (mut boundary, mut isolated) = (0usize, 0usize);
    for i in 0..nx {
        for j in 0..ny {
            let me = &full[i * ny + j];
            let near = [(1, 0), (-1, 0), (0, 1), (0, -1)]
                .into_iter()
                .map(|(di, dj)| (i as isize + di, j as isize + dj))
                .filter(|&(x, y)| x >= 0 && y >= 0 && (x as usize) < nx && (y as usize) < ny)
                .map(|(x, y)| {
                    !agree(
                        me,
                        &full[x as usize * ny + y as usize],
                        RefineFollow::Regime,
                    )
                })
                .collect::<Vec<bool>>();
            boundary += usize::from(near.iter().any(|&d| d));
            isolated += usize::from(near.iter().all(|&d| d));
        }
    }
    let n = full.len().max(1) as f64;
    Ceilings {
        early_stop: steps(full) as f64 / (steps(full) - free).max(1) as f64,
        boundary_share: boundary as f64 / n,
        isolated_share: isolated as f64 / n,
    }
}

/// Write `REFINE.md` and `refine.json` into `dir`.
pub fn write_refine(
    dir: &std::path::Path,
    r: &RefineReport,
) -> Result<Vec<std::path::PathBuf>, pendulum_atlas_map::output::OutputError> {
    use pendulum_atlas_map::output::files::{create_dir, write_bytes, write_json};
    create_dir(dir)?;
    Ok(vec![
        write_bytes(&dir.join("REFINE.md"), markdown(r).as_bytes())?,
        write_json(&dir.join("refine.json"), r)?,
    ])
}

fn markdown(r: &RefineReport) -> String {
    use std::fmt::Write as _;
    let s = &r.shipped;
    let mut out = format!(
        "# What the early stop and refinement skip\n\n\
         `pendulum-atlas bench --refine` on {}: the default map's scene (`configs/maps/default.toml`: \
         34 s runs, λ1 over the last 12 s, the regime) on a grid of {} × {} points \
         ({} × {} intervals), in full, with the early stop, and with the early stop and adaptive \
         refinement as shipped (coarse spacing {}, follows the regime, audit of {} % a round, \
         classes below {} % agreement one level deeper). Each row is scored against its own \
         engine's full map: the share of cells with the same regime (and the same period where \
         periodic). The study took {:.0} s.\n\n",
        r.machine,
        r.grid.0,
        r.grid.1,
        r.grid.0 - 1,
        r.grid.1 - 1,
        s.spacing,
        100.0 * s.audit_share,
        100.0 * s.audit_min,
        r.total_s
    );
    out.push_str(
        "| engine | setting | instance-steps | fewer steps | wall (s) | faster | stopped early | inferred | first audit | equal regimes |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for w in &r.rows {
        let audit = if w.audit_agreement.is_nan() {
            String::new()
        } else {
            format!("{:.1} %", 100.0 * w.audit_agreement)
        };
        let _ = writeln!(
            out,
            "| {} | {} | {:.3e} | {:.2}× | {:.1} | {:.2}× | {} | {} | {} | {:.2} % |",
            w.engine,
            w.setting,
            w.instance_steps as f64,
            w.fewer_steps,
            w.wall_s,
            w.speedup,
            w.stopped_early,
            w.inferred,
            audit,
            100.0 * w.equal_regime
        );
    }
    let _ = write!(
        out,
        "\n## Other refinement settings, replayed\n\n\
         On the CPU engine's early-stop map (a cell's result does not depend on the cells \
         computed with it). The replay of the shipped setting {} the real refined run cell for \
         cell. Steps are those of the computed cells; audit share {} % a round.\n\n\
         | spacing | audit minimum | computed cells | fewer steps | first audit | last audit | rounds | equal regimes |\n|---|---|---|---|---|---|---|---|\n",
        if r.replay_matches_run {
            "equals"
        } else {
            "DIFFERS FROM"
        },
        100.0 * s.audit_share
    );
    for p in &r.replays {
        let min = if p.audit_min == 0.0 {
            "none (corners only)".to_string()
        } else {
            format!("{:.0} %", 100.0 * p.audit_min)
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {:.2}× | {:.1} % | {:.1} % | {} | {:.2} % |",
            p.spacing,
            min,
            p.computed,
            p.fewer_steps,
            100.0 * p.first_agreement,
            100.0 * p.final_agreement,
            p.rounds,
            100.0 * p.equal_regime
        );
    }
    let c = &r.ceilings;
    let _ = write!(
        out,
        "\n## Ceilings, from the full map\n\n\
         - Early stop: were every periodic and regular cell free, the map would take {:.2}× fewer \
         steps; the rest is chaotic or undecided and runs to its end.\n\
         - Refinement: {:.1} % of the cells have a neighbour of another regime or period, \
         {:.1} % differ from every neighbour. A refinement that computed exactly the boundary \
         cells would take {:.2}× fewer cells; the isolated cells cannot be found without \
         computing them.\n\n\
         The early stop ends a cell whose whole state repeats within 1e-5 (relative; 1e-4 in \
         f32) with a period of at most 8 forcing periods over 16 stroboscopic instants, and \
         whose λ1 on that cycle is shrinking and within 10 % of itself; its indicators are the \
         confirmed cycle continued to the run's end (`docs/analysis.md` §11). Refinement computes \
         a lattice of every {}th point, halves the spacing inside blocks whose corners differ, \
         fills the rest from the block's nearest corner (`inferred.npy`), and audits the fill by \
         class (`docs/analysis.md` §12).\n",
        c.early_stop,
        100.0 * c.boundary_share,
        100.0 * c.isolated_share,
        1.0 / c.boundary_share.max(1e-9),
        s.spacing
    );
    out
}
