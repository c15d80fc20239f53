//! The files of a search: `designs.csv`, `instances.csv`, `best.md`, `best_design.toml`,
//! `search_scene.toml` (the search's scene after its overrides), `pareto.png`,
//! `power_vs_frequency.png` and `search.json`.

use super::error::HarvestError;
use super::figures::{pareto_figure, power_figure};
use super::search::{DesignResult, SearchRun};
use super::spec::{BaseExcitation, SearchSpec};
use super::verify::Verification;
use pendulum_atlas_core::engine::{EngineKind, Precision};
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{
    AtomicFile, create_dir, draw, write_bytes, write_json, write_toml,
};
use pendulum_atlas_map::output::manifest::Manifest;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

mod best_md;
mod summary;
use best_md::best_md;
use summary::{check_point, mean_hops, periodic_fraction};

/// A number for CSV (NaN as `nan`).
fn num(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else {
        format!("{v}")
    }
}

/// Write every file of a search into `dir` (created if needed); returns the paths written.
pub fn write_search(
    dir: &Path,
    spec: &SearchSpec,
    run: &SearchRun,
    verification: Option<&Verification>,
    origin: &str,
) -> Result<Vec<PathBuf>, HarvestError> {
    create_dir(dir)?;
    let toml = best_design_toml(spec, run.best(), verification)?;
    let mut written = vec![
        write_designs_csv(&dir.join("designs.csv"), spec, run)?,
        write_instances_csv(&dir.join("instances.csv"), spec, run)?,
        write_bytes(&dir.join("best_design.toml"), toml.as_bytes())?,
        write_toml(
            &dir.join("search_scene.toml"),
            &spec.source_table,
            "The scene of this search after every --set override.\n\
             `pendulum-atlas search search_scene.toml` runs it again; `pendulum-atlas explore` reads it.",
        )?,
    ];
    if let Some(v) = verification {
        written.push(write_verification_csv(&dir.join("verification.csv"), v)?);
    }
    let md = best_md(spec, run, verification, origin);
    written.push(write_bytes(&dir.join("best.md"), md.as_bytes())?);
    written.push(draw(&dir.join("pareto.png"), |p| {
        pareto_figure(p, spec, run)
    })?);
    written.push(draw(&dir.join("power_vs_frequency.png"), |p| {
        power_figure(p, spec, run)
    })?);
    let files = written
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .chain([SearchManifest::NAME.to_string()])
        .collect();
    let manifest = search_manifest(spec, run, verification, origin, files);
    written.push(write_json(&dir.join(SearchManifest::NAME), &manifest)?);
    Ok(written)
}

/// `designs.csv`: one row per evaluated design.
fn write_designs_csv(
    path: &Path,
    spec: &SearchSpec,
    run: &SearchRun,
) -> Result<PathBuf, OutputError> {
    let io = |e| OutputError::io(path, e);
    let mut w = AtomicFile::create(path)?;
    let mut header: Vec<String> = vec!["id".into(), "stage".into()];
    header.extend(spec.variables.iter().map(|v| v.key.clone()));
    header.extend(
        [
            "bandwidth_robust_hz",
            "band_avg_power_robust_w",
            "peak_power_robust_w",
            "peak_frequency_robust_hz",
            "bandwidth_mean_hz",
            "band_avg_power_mean_w",
            "hops_per_instance_mean",
            "periodic_fraction",
            "failed_instances",
            "pareto",
            "rank",
        ]
        .map(String::from),
    );
    writeln!(w, "{}", header.join(",")).map_err(io)?;
    for d in &run.designs {
        let mut row = vec![d.id.to_string(), d.stage.clone()];
        row.extend(d.values.iter().map(|&v| num(v)));
        row.extend([
            num(d.robust.bandwidth_hz),
            num(d.robust.band_average_w),
            num(d.robust.peak_w),
            num(d.robust.peak_frequency_hz),
            num(d.mean.bandwidth_hz),
            num(d.mean.band_average_w),
            num(mean_hops(d)),
            num(periodic_fraction(d)),
            d.failed.to_string(),
            d.pareto.to_string(),
            d.rank.to_string(),
        ]);
        writeln!(w, "{}", row.join(",")).map_err(io)?;
    }
    w.commit()
}

/// `verification.csv`: the best design re-simulated at every point, next to the search.
fn write_verification_csv(path: &Path, v: &Verification) -> Result<PathBuf, OutputError> {
    let io = |e| OutputError::io(path, e);
    let mut w = AtomicFile::create(path)?;
    writeln!(
        w,
        "design,initial_state,frequency_hz,search_power_w,simulate_power_w,rel_diff,period,hops,k_simulate,regular,status"
    ).map_err(io)?;
    for p in &v.points {
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{},{}",
            v.design_id,
            p.state,
            p.frequency_hz,
            num(p.search_w),
            num(p.simulate_w),
            num((p.simulate_w - p.search_w) / p.search_w),
            num(p.period),
            num(p.hops),
            num(p.k_simulate),
            p.regular(),
            p.status
        )
        .map_err(io)?;
    }
    w.commit()
}

/// `instances.csv`: every instance of every design (and the baseline), one row each.
fn write_instances_csv(
    path: &Path,
    spec: &SearchSpec,
    run: &SearchRun,
) -> Result<PathBuf, OutputError> {
    let io = |e| OutputError::io(path, e);
    let mut w = AtomicFile::create(path)?;
    writeln!(
        w,
        "design,initial_state,frequency_hz,amplitude_m,power_w,hops,impacts_per_s,period"
    )
    .map_err(io)?;
    for (f, p) in run
        .baseline
        .frequencies_hz
        .iter()
        .zip(&run.baseline.power_w)
    {
        writeln!(
            w,
            "baseline,rest,{f},{},{},nan,nan,nan",
            spec.band.excitation.amplitude_m(*f),
            num(*p)
        )
        .map_err(io)?;
    }
    for d in &run.designs {
        for (s, state) in spec.initial_states.iter().enumerate() {
            for (j, f) in spec.band.frequencies_hz.iter().enumerate() {
                writeln!(
                    w,
                    "{},{},{f},{},{},{},{},{}",
                    d.id,
                    state.name,
                    spec.band.excitation.amplitude_m(*f),
                    num(d.power_w[s][j]),
                    num(d.hops[s][j]),
                    num(d.impacts_per_s[s][j]),
                    num(d.period[s][j])
                )
                .map_err(io)?;
            }
        }
    }
    w.commit()
}

/// `best_design.toml`: a plain scene (no `[search]`) of the best design at its check point,
/// which `pendulum-atlas simulate` runs as it is.
fn best_design_toml(
    spec: &SearchSpec,
    d: &DesignResult,
    verification: Option<&Verification>,
) -> Result<String, HarvestError> {
    let (table, scene) = spec.design_table(&d.values)?;
    let (f, j) = check_point(spec, d, verification);
    let state = &spec.initial_states[0];
    let inst = spec.instance_scene(&table, scene.limiter.clearance_deg, state, f)?;
    let mut t = table.clone();
    for (k, v) in [
        ("excitation.frequency_hz", f),
        ("excitation.amplitude_m", inst.excitation.amplitude_m),
        ("initial.angle_deg", inst.initial.angle_deg),
        ("initial.rate_deg_s", inst.initial.rate_deg_s),
        ("initial.voltage_v", inst.initial.voltage_v),
    ] {
        pendulum_atlas_core::config::set_key(&mut t, k, toml::Value::Float(v))?;
    }
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# The best design of a harvesting search (design #{}) at {f} Hz from the initial\n\
         # state `{}` (its robust peak, or its strongest regular response if the peak is not\n\
         # regular: see best.md). Run it with\n\
         #   pendulum-atlas simulate best_design.toml --out runs/check\n\
         # and average the power_w column of trajectory.csv over t_s >= {} s: the search\n\
         # reported {} W here. Other band frequencies: --set excitation.frequency_hz=F\n\
         # --set excitation.amplitude_m=A (A from instances.csv).\n",
        d.id,
        state.name,
        scene.integration.transient_s,
        num(d.power_w[0][j]),
    );
    out.push_str(&toml::to_string(&t).map_err(HarvestError::Toml)?);
    Ok(out)
}

/// `search.json`: settings, baseline, threshold, counts, timings, backend, best design.
fn search_manifest(
    spec: &SearchSpec,
    run: &SearchRun,
    verification: Option<&Verification>,
    origin: &str,
    files: Vec<String>,
) -> SearchManifest {
    let best = run.best();
    let excitation = match spec.band.excitation {
        BaseExcitation::Acceleration { acceleration_m_s2 } => {
            json!({"kind": "acceleration", "acceleration_m_s2": acceleration_m_s2})
        }
        BaseExcitation::Amplitude { amplitude_m } => {
            json!({"kind": "amplitude", "amplitude_m": amplitude_m})
        }
    };
    let failed: usize = run.designs.iter().map(|d| d.failed).sum();
    SearchManifest {
        scene_origin: origin.to_string(),
        settings: json!(spec),
        excitation,
        backend: run.engine.kind,
        backend_reason: run.engine.reason.clone(),
        adapter: run.engine.device.clone(),
        precision: run.engine.precision,
        threshold_w: run.threshold_w,
        period_test: super::search::period_test_possible(spec),
        files,
        baseline: json!({
            "first_natural_hz": run.baseline.first_natural_hz,
            "metrics": run.baseline.metrics,
            "band_grid_metrics": run.baseline.band_metrics,
            "frequencies_hz": run.baseline.frequencies_hz,
            "power_w": run.baseline.power_w,
            "failed_instances": run.baseline.failed,
        }),
        counts: json!({
            "designs": run.designs.len(),
            "grid_designs": spec.grid_designs(),
            "refined_designs": run.designs.len() - spec.grid_designs(),
            "pareto_designs": run.designs.iter().filter(|d| d.pareto).count(),
            "instances": run.stages.iter().map(|s| s.instances).sum::<usize>(),
            "instance_steps": run.stages.iter().map(|s| s.instance_steps).sum::<u64>(),
            "failed_instances": failed,
        }),
        timings_s: json!({
            "total": run.total_s,
            "stages": run.stages,
            "verification": verification.map(|v| v.wall_s),
        }),
        best: json!({
            "id": best.id,
            "values": spec.variables.iter().zip(&best.values)
                .map(|(v, x)| (v.key.clone(), json!(x)))
                .collect::<serde_json::Map<_, _>>(),
            "robust": best.robust,
            "mean": best.mean,
            "frequencies_hz": spec.band.frequencies_hz,
            "robust_w": best.robust_w,
            "mean_w": best.mean_w,
            "top_attractor": (!best.top_attractor.is_empty()).then_some(&best.top_attractor),
        }),
        ranked_by: json!({
            "weighting": spec.weighting,
            "in_words": spec.weighting.describe(spec.initial_states.len()),
            "curve": match spec.weighting {
                crate::harvest::Weighting::Robust => "robust_w (bandwidth_robust_hz, band_avg_power_robust_w in designs.csv)",
                crate::harvest::Weighting::Expected { .. } => "mean_w over the sampled starts (bandwidth_mean_hz, band_avg_power_mean_w in designs.csv)",
            },
            "top_attractor_rule": format!(
                "per frequency, the starts within {} % of the most powerful start's power and of its period; basin_fraction counts them among all starts",
                100.0 * crate::harvest::TOP_POWER_SHARE
            ),
        }),
        verification: json!(verification),
    }
}

/// `search.json`: the settings, the engine, the baseline, the counts and timings, the best
/// design and how designs were ranked, and the files of the folder. Written last; the
/// explorer reads it back.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SearchManifest {
    /// The scene file (or the embedded default) the search read.
    pub scene_origin: String,
    /// The search's settings.
    pub settings: serde_json::Value,
    /// The base excitation: an acceleration or an amplitude.
    pub excitation: serde_json::Value,
    /// Engine kind.
    pub backend: EngineKind,
    /// Why this engine.
    pub backend_reason: String,
    /// The device (adapter name, or the CPU's threads and loop).
    pub adapter: String,
    /// Float type.
    pub precision: Precision,
    /// Power above which a frequency counts toward the bandwidth (W).
    pub threshold_w: f64,
    /// Whether the runs are long enough for the period test.
    pub period_test: bool,
    /// The baseline design.
    pub baseline: serde_json::Value,
    /// Designs, instances and steps.
    pub counts: serde_json::Value,
    /// Wall time per stage (s).
    pub timings_s: serde_json::Value,
    /// The best design.
    pub best: serde_json::Value,
    /// How designs were ranked.
    pub ranked_by: serde_json::Value,
    /// The verification of the best design (null without it).
    pub verification: serde_json::Value,
    /// The files of the folder, by name (empty in searches written before it was kept).
    #[serde(default)]
    pub files: Vec<String>,
}

impl Manifest for SearchManifest {
    const NAME: &'static str = "search.json";

    fn listed(&self) -> &[String] {
        &self.files
    }
}
