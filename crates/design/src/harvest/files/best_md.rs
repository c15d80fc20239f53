//! `best.md`: the search's report, one function per section, in the order a reader meets them.
//!
//! Every section appends to one `String`; writing to a `String` cannot fail, so the
//! `fmt::Result`s are dropped.

use super::summary::{check_point, mean_hops, periodic_fraction, ratio, short_design, watts};
use crate::harvest::search::{DesignResult, SearchRun};
use crate::harvest::spec::{Objective, SearchSpec, Threshold};
use crate::harvest::verify::{Verification, VerifiedPoint};
use std::fmt::Write as _;

/// The markdown report.
pub(super) fn best_md(
    spec: &SearchSpec,
    run: &SearchRun,
    verification: Option<&Verification>,
    origin: &str,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Broadband harvesting search: the best designs\n");
    settings(&mut s, spec, origin);
    threshold_and_counts(&mut s, spec, run);
    in_short(&mut s, spec, run);
    baseline(&mut s, spec, run);
    top_designs(&mut s, spec, run);
    pareto_front(&mut s, spec, run);
    check_with_simulate(&mut s, spec, run, verification);
    let _ = writeln!(
        s,
        "\nFiles: `designs.csv` (every design), `instances.csv` (every instance's power), \
         `verification.csv` (the best design re-simulated point by point, with K), `pareto.png`, \
         `power_vs_frequency.png`, `search.json` (settings, timings, counts)."
    );
    s
}

/// The scene, the band and how robust and mean power are taken over the initial states.
fn settings(s: &mut String, spec: &SearchSpec, origin: &str) {
    let band = &spec.band;
    let sc = &spec.scene;
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
}

/// The bandwidth threshold, and how much work the search did on which engine.
fn threshold_and_counts(s: &mut String, spec: &SearchSpec, run: &SearchRun) {
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
}

/// "In short": the best design's robust bandwidth and power against the baseline's.
fn in_short(s: &mut String, spec: &SearchSpec, run: &SearchRun) {
    let b = &run.baseline;
    let bm = &b.metrics;
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
        spec.band.frequencies_hz.len(),
    );
}

/// "Linear baseline": what the clamped cantilever is, its metrics with and without the zoom
/// around its resonance, and whether the band's edges cut its bandwidth.
fn baseline(s: &mut String, spec: &SearchSpec, run: &SearchRun) {
    let b = &run.baseline;
    let bm = &b.metrics;
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
    baseline_band_edges(s, spec, run);
}

/// A sentence for each band edge at which the baseline still harvests above the threshold:
/// there the band, not the response, ends its bandwidth.
fn baseline_band_edges(s: &mut String, spec: &SearchSpec, run: &SearchRun) {
    let band = &spec.band;
    let p = &run.baseline.band_power_w;
    let edges = [
        (band.start_hz(), p[0], "lower"),
        (band.end_hz(), p[p.len() - 1], "upper"),
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
}

/// "Top designs": the ranking table, one column per design variable.
fn top_designs(s: &mut String, spec: &SearchSpec, run: &SearchRun) {
    let objective = match spec.objective {
        Objective::Bandwidth => "robust bandwidth, ties broken by robust band-averaged power",
        Objective::Power => "robust band-averaged power, ties broken by robust bandwidth",
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
        let _ = writeln!(s, "{}", top_design_row(run, d));
    }
}

/// One row of the ranking table.
fn top_design_row(run: &SearchRun, d: &DesignResult) -> String {
    let bm = &run.baseline.metrics;
    let mut row = format!("| {} | {} |", d.rank, d.id);
    for x in &d.values {
        let _ = write!(row, " {} |", pendulum_atlas_map::render::fmt_num(*x));
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
    row
}

/// "Pareto front": the designs no other beats in both robust bandwidth and robust power,
/// by increasing bandwidth.
fn pareto_front(s: &mut String, spec: &SearchSpec, run: &SearchRun) {
    let mut front: Vec<&DesignResult> = run.designs.iter().filter(|d| d.pareto).collect();
    front.sort_by(|a, b| a.robust.bandwidth_hz.total_cmp(&b.robust.bandwidth_hz));
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
}

/// "Checking the best design with `simulate`": how to run `best_design.toml`, and, when the
/// search re-simulated the best design itself, how the two agree.
fn check_with_simulate(
    s: &mut String,
    spec: &SearchSpec,
    run: &SearchRun,
    verification: Option<&Verification>,
) {
    let best = run.best();
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
        spec.scene.integration.transient_s,
        watts(best.power_w[0][j]),
    );
    if let Some(v) = verification {
        let table = verification_table(v, f, best.robust.peak_frequency_hz);
        check_point_resimulated(s, spec, v, f);
        s.push_str(&table);
        verification_over_band(s, spec, run, v);
    }
}

/// The re-simulated points at the check frequency and at the robust peak, as a table.
fn verification_table(v: &Verification, check_hz: f64, peak_hz: f64) -> String {
    let rows = v
        .points
        .iter()
        .filter(|p| p.frequency_hz == check_hz || p.frequency_hz == peak_hz);
    let mut table = String::from(
        "\n\n| f | initial state | search P | `simulate` P | difference | period (search) | K (`simulate`) |\n|---|---|---|---|---|---|---|\n",
    );
    for p in rows {
        let _ = writeln!(
            table,
            "| {} Hz{} | `{}` | {} | {} | {:+.2} % | {} | {:.2} |",
            p.frequency_hz,
            if p.frequency_hz == peak_hz {
                " (robust peak)"
            } else {
                " (check)"
            },
            p.state,
            watts(p.search_w),
            watts(p.simulate_w),
            rel_diff_percent(p),
            p.period,
            p.k_simulate
        );
    }
    table
}

/// `simulate`'s power against the search's at one point (%).
fn rel_diff_percent(p: &VerifiedPoint) -> f64 {
    100.0 * (p.simulate_w - p.search_w) / p.search_w
}

/// The sentence on the check point itself (first initial state), when it was re-simulated.
fn check_point_resimulated(s: &mut String, spec: &SearchSpec, v: &Verification, check_hz: f64) {
    let at = v
        .points
        .iter()
        .find(|p| p.frequency_hz == check_hz && p.state == spec.initial_states[0].name);
    if let Some(p) = at {
        let _ = write!(
            s,
            " The search re-ran that check itself with `simulate`'s engine (f64 RK4 at its own automatic step, \
             power from the 1 kHz output rows): **{}** vs the search's {} ({:+.2} %).",
            watts(p.simulate_w),
            watts(p.search_w),
            rel_diff_percent(p)
        );
    }
}

/// The re-simulation over the whole band: band-averaged power, and the differences on the
/// regular points and on all of them, with why chaotic ones need not match.
fn verification_over_band(s: &mut String, spec: &SearchSpec, run: &SearchRun, v: &Verification) {
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
        if run.engine.precision == pendulum_atlas_core::engine::Precision::F32 {
            "and integrates in f32 on the GPU"
        } else {
            "in f64"
        }
    );
}
