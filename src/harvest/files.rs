//! The files of a search: `designs.csv`, `instances.csv`, `best.md`, `best_design.toml`,
//! `pareto.png`, `power_vs_frequency.png` and `search.json`.

use super::error::HarvestError;
use super::figures::{pareto_figure, power_figure};
use super::search::{DesignResult, SearchRun};
use super::spec::{BaseExcitation, SearchSpec, Threshold};
use super::verify::Verification;
use crate::output::OutputError;
use crate::output::files::{AtomicFile, create_dir, draw, write_bytes, write_json};
use serde_json::json;
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A number for CSV (NaN as `nan`).
fn num(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else {
        format!("{v}")
    }
}

/// A power in engineering units for reports.
pub fn watts(p: f64) -> String {
    if !p.is_finite() {
        return format!("{p}");
    }
    let a = p.abs();
    let (scale, unit) = if a >= 1.0 || a == 0.0 {
        (1.0, "W")
    } else if a >= 1e-3 {
        (1e3, "mW")
    } else if a >= 1e-6 {
        (1e6, "µW")
    } else {
        (1e9, "nW")
    };
    format!("{:.3} {unit}", p * scale)
}

/// `key = value, ...` with values rounded for reading (best_design.toml has them exactly).
fn short_design(spec: &SearchSpec, values: &[f64]) -> String {
    spec.variables
        .iter()
        .zip(values)
        .map(|(v, &x)| format!("`{}` = {}", v.key, crate::render::fmt_num(x)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A ratio `a/b` for reports ("—" when b is 0).
fn ratio(a: f64, b: f64) -> String {
    if b > 0.0 && a.is_finite() {
        format!("{:.2}×", a / b)
    } else {
        "—".into()
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
    let json = search_json(spec, run, verification, origin);
    written.push(write_json(&dir.join("search.json"), &json)?);
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

/// Mean hops per instance (after the transient) over a design's ok instances.
pub fn mean_hops(d: &DesignResult) -> f64 {
    let v: Vec<f64> = d
        .hops
        .iter()
        .flatten()
        .copied()
        .filter(|h| h.is_finite())
        .collect();
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Share of a design's instances whose stroboscopic section is periodic (period ≥ 1).
pub fn periodic_fraction(d: &DesignResult) -> f64 {
    let all: Vec<f64> = d.period.iter().flatten().copied().collect();
    all.iter().filter(|&&p| p >= 1.0).count() as f64 / all.len().max(1) as f64
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

/// The frequency at which the best design is checked by `simulate`, from the first initial
/// state: its robust peak if the response there is regular, otherwise the regular frequency
/// of highest power, otherwise the robust peak. Regular: a periodic stroboscopic section in
/// the search and, when the design was re-simulated, K < 0.5 there too. Irregular
/// (chaotic) responses depend on the step, so only a regular one can be expected to match a
/// re-simulation with another step closely.
pub fn check_point(
    spec: &SearchSpec,
    d: &DesignResult,
    verification: Option<&Verification>,
) -> (f64, usize) {
    let freqs = &spec.band.frequencies_hz;
    let peak = freqs
        .iter()
        .position(|&x| x == d.robust.peak_frequency_hz)
        .unwrap_or(0);
    let regular = |j: usize| match verification.filter(|v| v.design_id == d.id) {
        // Points are stored states outermost: the first state's come first.
        Some(v) => v.points[j].regular(),
        None => d.period[0][j] >= 1.0,
    };
    let j = if regular(peak) {
        peak
    } else {
        (0..freqs.len())
            .filter(|&j| regular(j) && d.power_w[0][j].is_finite())
            .max_by(|&a, &b| d.power_w[0][a].total_cmp(&d.power_w[0][b]))
            .unwrap_or(peak)
    };
    (freqs[j], j)
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
        crate::config::set_key(&mut t, k, toml::Value::Float(v))?;
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

/// The markdown report.
fn best_md(
    spec: &SearchSpec,
    run: &SearchRun,
    verification: Option<&Verification>,
    origin: &str,
) -> String {
    let b = &run.baseline;
    let bm = &b.metrics;
    let band = &spec.band;
    let sc = &spec.scene;
    let mut s = String::new();
    let _ = writeln!(s, "# Broadband harvesting search: the best designs\n");
    let _ = writeln!(
        s,
        "Scene `{origin}`: N = {} segments, piezo patch over segments 1–{} (C = {} nF, Θ = {:e} N m/V), \
         duration {} s with the first {} s discarded. Band {}–{} Hz ({} frequencies, step {:.3} Hz) at {}. \
         Every (design, frequency) is integrated from {} initial states ({}); **robust** P(f) is the \
         smallest power over them, **mean** their mean. Bandwidth = total span where P ≥ the threshold \
         (P linear between samples); band-averaged power = ∫P df / band width.\n",
        sc.beam.segments,
        sc.piezo.segments + 1,
        sc.piezo.capacitance_f * 1e9,
        sc.piezo.coupling_nm_per_v,
        sc.integration.duration_s,
        sc.integration.transient_s,
        band.start_hz(),
        band.end_hz(),
        band.frequencies_hz.len(),
        band.step_hz(),
        band.excitation.describe(),
        spec.initial_states.len(),
        spec.initial_states
            .iter()
            .map(|s| format!("`{}`", s.name))
            .collect::<Vec<_>>()
            .join(", "),
    );
    let thr = match spec.threshold {
        Threshold::Absolute { power_w } => format!("{} (absolute)", watts(power_w)),
        Threshold::RelativeToBaselinePeak { fraction } => format!(
            "{} = {} × the baseline's peak",
            watts(run.threshold_w),
            fraction
        ),
    };
    let _ = writeln!(s, "Threshold: {thr}.\n");
    let _ = writeln!(
        s,
        "{} designs evaluated ({} instances, {:.2e} instance-steps) on {} [{}] in {:.0} s.\n",
        run.designs.len(),
        run.stages.iter().map(|st| st.instances).sum::<usize>(),
        run.stages
            .iter()
            .map(|st| st.instance_steps as f64)
            .sum::<f64>(),
        run.engine.kind.name(),
        run.engine.device,
        run.total_s
    );

    let best = run.best();
    let _ = writeln!(s, "## In short\n");
    let _ = writeln!(
        s,
        "The best design, #{} ({}), harvests at least the threshold over **{:.2} Hz** of the band from \
         every initial state, against **{:.2} Hz** for the linear clamped baseline ({}), with a robust \
         band-averaged power of **{}** against the baseline's **{}** ({}). The baseline's resonance \
         ({} at {:.2} Hz) dominates its average; the best design's robust power exceeds the \
         baseline's at {} of the {} band frequencies.\n",
        best.id,
        short_design(spec, &best.values),
        best.robust.bandwidth_hz,
        bm.bandwidth_hz,
        ratio(best.robust.bandwidth_hz, bm.bandwidth_hz),
        watts(best.robust.band_average_w),
        watts(bm.band_average_w),
        ratio(best.robust.band_average_w, bm.band_average_w),
        watts(bm.peak_w),
        bm.peak_frequency_hz,
        best.robust_w
            .iter()
            .zip(&b.band_power_w)
            .filter(|(d, b)| d > b)
            .count(),
        band.frequencies_hz.len(),
    );

    let _ = writeln!(s, "## Linear baseline\n");
    let _ = writeln!(
        s,
        "The clamped cantilever (`pivot.mode = \"clamped\"`, no bumpers) with the same beam, tip, patch \
         and load (R_L = {} kΩ), started at rest; it is linear, so one initial state suffices. \
         Its first natural frequency (`modes`) is **{:.3} Hz**; besides the band grid it is evaluated at {} \
         frequencies within ±{} Hz of it, since its resonance is narrower than the band step.\n",
        b.scene.piezo.load_ohm / 1e3,
        b.first_natural_hz,
        spec.baseline_zoom.count,
        spec.baseline_zoom.halfwidth_hz,
    );
    let _ = writeln!(s, "| | peak P | at | bandwidth | band-averaged P |");
    let _ = writeln!(s, "|---|---|---|---|---|");
    let _ = writeln!(
        s,
        "| baseline (band + zoom) | {} | {:.3} Hz | {:.3} Hz | {} |",
        watts(bm.peak_w),
        bm.peak_frequency_hz,
        bm.bandwidth_hz,
        watts(bm.band_average_w)
    );
    let bb = &b.band_metrics;
    let _ = writeln!(
        s,
        "| baseline (band grid only) | {} | {:.3} Hz | {:.3} Hz | {} |\n",
        watts(bb.peak_w),
        bb.peak_frequency_hz,
        bb.bandwidth_hz,
        watts(bb.band_average_w)
    );
    let edges = [
        (band.start_hz(), b.band_power_w[0], "lower"),
        (
            band.end_hz(),
            b.band_power_w[b.band_power_w.len() - 1],
            "upper",
        ),
    ];
    for (f, p, which) in edges {
        if p >= run.threshold_w {
            let _ = writeln!(
                s,
                "At the band's {which} edge ({f} Hz) the baseline still harvests {}, above the threshold: \
                 its bandwidth is cut there by the band, not by its response.\n",
                watts(p)
            );
        }
    }

    let objective = match spec.objective {
        super::spec::Objective::Bandwidth => {
            "robust bandwidth, ties broken by robust band-averaged power"
        }
        super::spec::Objective::Power => {
            "robust band-averaged power, ties broken by robust bandwidth"
        }
    };
    let _ = writeln!(s, "## Top designs (ranked by {objective})\n");
    let mut head = String::from("| rank | id |");
    let mut rule = String::from("|---|---|");
    for v in &spec.variables {
        let _ = write!(head, " `{}` |", v.key);
        rule.push_str("---|");
    }
    head.push_str(
        " robust bandwidth | vs baseline | robust band-avg P | vs baseline | mean bandwidth | mean band-avg P | robust peak P (at) | hops/instance | periodic section | Pareto |",
    );
    rule.push_str("---|---|---|---|---|---|---|---|---|---|");
    let _ = writeln!(s, "{head}\n{rule}");
    for d in run.top(spec.report_top) {
        let mut row = format!("| {} | {} |", d.rank, d.id);
        for x in &d.values {
            let _ = write!(row, " {} |", crate::render::fmt_num(*x));
        }
        let _ = write!(
            row,
            " {:.2} Hz | {} | {} | {} | {:.2} Hz | {} | {} ({} Hz) | {:.1} | {:.0} % | {} |",
            d.robust.bandwidth_hz,
            ratio(d.robust.bandwidth_hz, bm.bandwidth_hz),
            watts(d.robust.band_average_w),
            ratio(d.robust.band_average_w, bm.band_average_w),
            d.mean.bandwidth_hz,
            watts(d.mean.band_average_w),
            watts(d.robust.peak_w),
            d.robust.peak_frequency_hz,
            mean_hops(d),
            100.0 * periodic_fraction(d),
            if d.pareto { "yes" } else { "" }
        );
        let _ = writeln!(s, "{row}");
    }
    let front: Vec<&DesignResult> = {
        let mut f: Vec<&DesignResult> = run.designs.iter().filter(|d| d.pareto).collect();
        f.sort_by(|a, b| a.robust.bandwidth_hz.total_cmp(&b.robust.bandwidth_hz));
        f
    };
    let _ = writeln!(
        s,
        "\n## Pareto front ({} designs: none is beaten in both robust bandwidth and robust band-averaged power)\n",
        front.len()
    );
    let _ = writeln!(s, "| id | design | robust bandwidth | robust band-avg P |");
    let _ = writeln!(s, "|---|---|---|---|");
    for d in &front {
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} Hz | {} |",
            d.id,
            short_design(spec, &d.values),
            d.robust.bandwidth_hz,
            watts(d.robust.band_average_w)
        );
    }

    let (f, j) = check_point(spec, best, verification);
    let _ = writeln!(s, "\n## Checking the best design with `simulate`\n");
    let _ = write!(
        s,
        "`best_design.toml` is design #{} as a plain scene at {f} Hz from `{}` ({}):\n\n\
         ```sh\npendulum-atlas simulate best_design.toml --out runs/check\n```\n\n\
         The mean of `power_w` in `trajectory.csv` over t ≥ {} s should match the search's {} there.",
        best.id,
        spec.initial_states[0].name,
        if f == best.robust.peak_frequency_hz {
            "its robust peak; the response there is regular".to_string()
        } else {
            format!(
                "its robust peak is at {} Hz, where the response is not regular: this is its strongest regular response",
                best.robust.peak_frequency_hz
            )
        },
        sc.integration.transient_s,
        watts(best.power_w[0][j]),
    );
    if let Some(v) = verification {
        let peak = best.robust.peak_frequency_hz;
        let rows: Vec<_> = v
            .points
            .iter()
            .filter(|p| p.frequency_hz == f || p.frequency_hz == peak)
            .collect();
        let mut table = String::from(
            "\n\n| f | initial state | search P | `simulate` P | difference | period (search) | K (`simulate`) |\n|---|---|---|---|---|---|---|\n",
        );
        for p in rows {
            let _ = writeln!(
                table,
                "| {} Hz{} | `{}` | {} | {} | {:+.2} % | {} | {:.2} |",
                p.frequency_hz,
                if p.frequency_hz == peak {
                    " (robust peak)"
                } else {
                    " (check)"
                },
                p.state,
                watts(p.search_w),
                watts(p.simulate_w),
                100.0 * (p.simulate_w - p.search_w) / p.search_w,
                p.period,
                p.k_simulate
            );
        }
        let at = v
            .points
            .iter()
            .find(|p| p.frequency_hz == f && p.state == spec.initial_states[0].name);
        if let Some(p) = at {
            let _ = write!(
                s,
                " The search re-ran that check itself with `simulate`'s engine (f64 RK4 at its own automatic step, \
                 power from the 1 kHz output rows): **{}** vs the search's {} ({:+.2} %).",
                watts(p.simulate_w),
                watts(p.search_w),
                100.0 * (p.simulate_w - p.search_w) / p.search_w
            );
        }
        s.push_str(&table);
        let _ = writeln!(
            s,
            "\n\nOver the whole band ({} points: {} frequencies × {} initial states) the re-simulation gives a \
             robust band-averaged power of **{}** against the search's **{}** ({:+.2} %). On the {} points \
             where the response is regular (a periodic stroboscopic section in the search and K < 0.5 in \
             the re-simulation) the median difference is {:.2} % and the largest {:.2} %; over all points the median is {:.2} % and the largest {:.1} % (at {} Hz). \
             The steps differ: the ensemble rounds its step to a whole number per forcing period ({}), \
             `simulate` takes its automatic step; chaotic responses (and hopping ones) follow other \
             trajectories at another step and only their averages compare.\n",
            v.points.len(),
            spec.band.frequencies_hz.len(),
            spec.initial_states.len(),
            watts(v.simulate_band_average_w),
            watts(v.search_band_average_w),
            100.0 * (v.simulate_band_average_w - v.search_band_average_w) / v.search_band_average_w,
            v.regular_points,
            100.0 * v.median_rel_diff_regular,
            100.0 * v.max_rel_diff_regular,
            100.0 * v.median_rel_diff,
            100.0 * v.max_rel_diff,
            v.max_rel_diff_at_hz,
            if run.engine.precision == crate::engine::Precision::F32 {
                "and integrates in f32 on the GPU"
            } else {
                "in f64"
            }
        );
    }
    let _ = writeln!(
        s,
        "\nFiles: `designs.csv` (every design), `instances.csv` (every instance's power), \
         `verification.csv` (the best design re-simulated point by point, with K), `pareto.png`, \
         `power_vs_frequency.png`, `search.json` (settings, timings, counts)."
    );
    s
}

/// `search.json`: settings, baseline, threshold, counts, timings, backend, best design.
fn search_json(
    spec: &SearchSpec,
    run: &SearchRun,
    verification: Option<&Verification>,
    origin: &str,
) -> serde_json::Value {
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
    json!({
        "scene_origin": origin,
        "settings": spec,
        "excitation": excitation,
        "backend": run.engine.kind,
        "backend_reason": run.engine.reason,
        "adapter": run.engine.device,
        "precision": run.engine.precision,
        "threshold_w": run.threshold_w,
        "period_test": super::search::period_test_possible(spec),
        "baseline": {
            "first_natural_hz": run.baseline.first_natural_hz,
            "metrics": run.baseline.metrics,
            "band_grid_metrics": run.baseline.band_metrics,
            "frequencies_hz": run.baseline.frequencies_hz,
            "power_w": run.baseline.power_w,
            "failed_instances": run.baseline.failed,
        },
        "counts": {
            "designs": run.designs.len(),
            "grid_designs": spec.grid_designs(),
            "refined_designs": run.designs.len() - spec.grid_designs(),
            "pareto_designs": run.designs.iter().filter(|d| d.pareto).count(),
            "instances": run.stages.iter().map(|s| s.instances).sum::<usize>(),
            "instance_steps": run.stages.iter().map(|s| s.instance_steps).sum::<u64>(),
            "failed_instances": failed,
        },
        "timings_s": {
            "total": run.total_s,
            "stages": run.stages,
            "verification": verification.map(|v| v.wall_s),
        },
        "best": {
            "id": best.id,
            "values": spec.variables.iter().zip(&best.values)
                .map(|(v, x)| (v.key.clone(), json!(x)))
                .collect::<serde_json::Map<_, _>>(),
            "robust": best.robust,
            "mean": best.mean,
            "frequencies_hz": spec.band.frequencies_hz,
            "robust_w": best.robust_w,
            "mean_w": best.mean_w,
        },
        "verification": verification,
    })
}
