//! Files of `pendulum-atlas-lab verdict`: `verdict.json` and `VERDICT.md`.

use super::reference::Reference;
use super::reliability::{FIRM, Firm, Reliability};
use super::settling::{SETTLED_TABLE_S, Settling};
use super::verdict::{REFERENCE_PERIOD_TOL_RAD, REFERENCE_PERIOD_WINDOW, Score, VerdictReport};
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_map::map::confidence::Calibration;
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{create_dir, write_bytes, write_json};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Write the study's files into `dir`.
pub fn write_verdict(dir: &Path, r: &VerdictReport) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    Ok(vec![
        write_bytes(&dir.join("VERDICT.md"), markdown(r).as_bytes())?,
        write_json(&dir.join("verdict.json"), r)?,
    ])
}

fn window(s: &Score) -> String {
    match s.candidate.window_s {
        Some(w) => format!("{w} s"),
        None => "whole run".into(),
    }
}

fn score_rows(out: &mut String, r: &VerdictReport) {
    let base = r.scores.first().map_or(f64::NAN, |s| s.wall_s);
    let _ = writeln!(
        out,
        "| engine | float | run / transient (s) | λ1 window | decided by | verdict = reference | periods right | reference's periods found | undecided | wall (s) | × first row |\n|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for s in &r.scores {
        let c = &s.candidate;
        let _ = writeln!(
            out,
            "| {} | {} | {} / {} | {} | {} | {}/{} ({:.1} %) | {}/{} ({:.1} %) | {}/{} ({:.1} %) | {}/{} ({:.1} %) | {:.2} | {:.2} |",
            c.backend.name(),
            c.precision.name(),
            c.duration_s,
            c.transient_s,
            window(s),
            c.decider.name(),
            s.agree,
            s.settled,
            s.agree_pct(),
            s.period_right,
            s.periodic,
            s.period_pct(),
            s.ref_period_found,
            s.ref_periodic,
            s.found_pct(),
            s.undecided,
            s.cells,
            s.undecided_pct(),
            s.wall_s,
            s.wall_s / base
        );
    }
}

fn markdown(r: &VerdictReport) -> String {
    let mut s = String::new();
    let f = &r.reference;
    let _ = writeln!(
        s,
        "# The map's accuracy: verdicts against a converged reference\n\n\
         Written by `pendulum-atlas-lab verdict --plane {}` \
         (`benches/src/verdict.rs`). The plane `{}` thinned to every {}th value of \
         each axis: {} × {} = {} cells, same scene and start.\n",
        r.plane.name(),
        r.plane.path(),
        r.thin,
        r.shape[0],
        r.shape[1],
        f.cells
    );
    let _ = writeln!(
        s,
        "## Reference\n\nCPU f64, runs of {} s and {} s (transient half the run), adaptive steps \
         at rtol {:e} and atol a hundredth of it, period window {} samples at {} rad. Doubling the \
         run changes the verdict of **{} of {} cells ({:.1} %)**; {}. {} cells are settled (both \
         runs reach the same decided verdict). Verdicts of the longer run: {}. Wall time {:.0} s{}.\n",
        f.durations_s[0],
        f.durations_s[1],
        f.rtol,
        REFERENCE_PERIOD_WINDOW,
        REFERENCE_PERIOD_TOL_RAD,
        f.changed,
        f.cells,
        100.0 * f.changed as f64 / f.cells as f64,
        tightened(f),
        f.settled,
        Regime::ALL
            .iter()
            .zip(f.counts)
            .map(|(g, n)| format!("{} {n}", g.name()))
            .collect::<Vec<_>>()
            .join(", "),
        f.wall_s,
        match &r.reference_kept_from {
            Some(dir) => format!(
                " (kept with subgrid B's from the study in `{dir}`, \
                 `--reference-from`; not part of this study's wall time)"
            ),
            None => String::new(),
        }
    );
    let _ = writeln!(
        s,
        "## Candidates\n\n\"verdict = reference\" is over the settled cells; \"periods right\" \
         over the cells the candidate calls periodic (the reference periodic with the same \
         period); \"reference's periods found\" over the settled cells the reference calls \
         periodic (the candidate periodic with the same period); \"undecided\" over all cells. Wall time of the subgrid alone, noisy at a few \
         seconds; the whole map's cost is below.\n"
    );
    score_rows(&mut s, r);
    if let Some(c) = &r.cost {
        let _ = writeln!(
            s,
            "\n## Cost of the whole map\n\n{} cells on {}: today's metrics (K, R, period, \
             hops, impacts, α range) {:.1} s; as shipped (with the verdict) {:.1} s, **{:.2}×**.\n",
            c.cells,
            c.engine,
            c.baseline_s,
            c.verdict_s,
            c.verdict_s / c.baseline_s
        );
    }
    reliability(&mut s, r);
    settling(&mut s, &r.settling);
    let _ = writeln!(s, "\nStudy wall time {:.0} s.", r.total_s);
    s
}

/// The step check of a reference, in words.
fn tightened(f: &Reference) -> String {
    match f.tightened {
        Some(n) => format!(
            "dividing the shorter run's tolerances by ten changes the verdict or period of **{n} \
             of {} cells ({:.1} %)**",
            f.cells,
            100.0 * n as f64 / f.cells as f64
        ),
        None => "its steps are not checked on this subgrid".into(),
    }
}

/// `3rd`, `5th`.
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

/// A table's seven accuracies as the cells of a Markdown row (`–` where a bin had no cell).
pub(crate) fn calibration_row(t: &Calibration) -> String {
    [
        t.chaotic_all,
        t.chaotic_some,
        t.periodic_half,
        t.periodic_few,
        t.regular,
        t.chaotic_mean,
        t.periodic_mean,
    ]
    .map(|x| {
        if x.is_nan() {
            "–".into()
        } else {
            format!("{x}")
        }
    })
    .join(" | ")
}

/// Stage 5: the reliability of `verdict_confidence` and the cross-fit of its table.
fn reliability(s: &mut String, r: &VerdictReport) {
    let g = &r.second;
    let _ = writeln!(
        s,
        "\n## Reliability of `verdict_confidence`\n\n\
         The plane's map as shipped (raw), run whole (so that every cell has its neighbours), scored \
         on subgrid A (the study's, above) and on subgrid B: every {}th value of each axis from \
         the {}, with a reference of its own ({} s and {} s; {} of {} cells change on \
         doubling, {} settled; wall time {:.0} s). Bins of `verdict_confidence` over the settled \
         cells; undecided cells carry none and are in no bin.\n",
        r.thin,
        ordinal(r.thin / 2 + 1),
        g.durations_s[0],
        g.durations_s[1],
        g.changed,
        g.cells,
        g.settled,
        g.wall_s
    );
    reliability_body(s, &r.reliability, "shipped");
}

/// The bins, the firm verdicts and the tables of one map's reliability `rel`, its applied
/// table called `applied`.
fn reliability_body(s: &mut String, rel: &Reliability, applied: &str) {
    let _ = writeln!(
        s,
        "| subgrid | confidence | cells | right | mean confidence |\n|---|---|---|---|---|"
    );
    for (name, rows, _) in &rel.tables {
        for b in rows {
            let (right, mean) = if b.cells == 0 {
                ("–".to_string(), "–".to_string())
            } else {
                (
                    format!(
                        "{} ({:.1} %)",
                        b.right,
                        100.0 * b.right as f64 / b.cells as f64
                    ),
                    format!("{:.3}", b.mean_confidence),
                )
            };
            let _ = writeln!(
                s,
                "| {name} | {:.2}–{:.2} | {} | {right} | {mean} |",
                b.from, b.to, b.cells
            );
        }
    }
    let _ = writeln!(
        s,
        "\nFirm verdicts (confidence ≥ {FIRM}), with the shipped table and with a table fitted on \
         the other subgrid:\n\n| table | scored on | firm cells of settled | right of firm |\n|---|---|---|---|"
    );
    let firm_row = |s: &mut String, table: &str, on: &str, f: &Firm| {
        let _ = writeln!(
            s,
            "| {table} | {on} | {}/{} ({:.1} %) | {}/{} ({:.1} %) |",
            f.cells,
            f.settled,
            f.coverage_pct(),
            f.right,
            f.cells,
            f.right_pct()
        );
    };
    for (name, _, f) in &rel.tables {
        firm_row(s, &format!("{applied} (fitted on A and B)"), name, f);
    }
    for (name, _, f) in &rel.cross {
        let (fit, on) = name.split_once(", scored on ").unwrap_or((name, ""));
        firm_row(s, fit, on, f);
    }
    let _ = writeln!(
        s,
        "\nThe table (accuracy per class and neighbourhood; `crates/map/src/map/confidence.rs`):\n\n\
         | fitted on | chaotic, all agree | chaotic, some not | periodic, ≥ ½ agree | periodic, < ½ | regular | chaotic, no neighbour | periodic, no neighbour |\n\
         |---|---|---|---|---|---|---|---|"
    );
    for (name, t, _) in &rel.cross {
        let fit = name.split_once(',').map_or(*name, |x| x.0);
        let _ = writeln!(s, "| {fit} | {} |", calibration_row(t));
    }
    let _ = writeln!(
        s,
        "| A and B | {} |\n| {applied} | {} |\n\nThe {applied} table {} the fit on A and B.",
        calibration_row(&rel.pooled),
        calibration_row(&rel.shipped),
        if rel.shipped_is_pooled {
            "equals"
        } else {
            "differs from"
        }
    );
}

/// Stage 6: transient chaos, the accuracy/cost curve of settling, the settled map's table.
fn settling(s: &mut String, g: &Settling) {
    let t = &g.transient;
    let at = |q: f64| {
        t.stop_s
            .get(((t.stop_s.len() as f64 - 1.0) * q).round() as usize)
    };
    let _ = writeln!(
        s,
        "\n## Transient chaos and settling (`map.settle_max_s`)\n\n\
         Of the {} settled cells of A and B, the plane's map as shipped (raw) calls {} chaotic. The \
         reference settles **{} of those** as periodic or regular: chaos at 34 s that is a \
         transient. The reference's early stop (orbit confirmed, λ1 shrinking) stopped {} of \
         them, at {} s (median {} s, largest {} s); {} ran to the reference's end (regular, no \
         period confirmed).\n",
        t.settled,
        t.chaotic,
        t.settle_later,
        t.stop_s.len(),
        list_s(&t.stop_s),
        at(0.5).map_or("–".into(), |x| format!("{x:.0}")),
        at(1.0).map_or("–".into(), |x| format!("{x:.0}")),
        t.not_stopped
    );
    let _ = writeln!(
        s,
        "The whole map of the plane with `map.settle_max_s`: the cells below confidence {FIRM} (or \
         undecided) run on to that time, with the early stop, from the map's end (the default) or \
         from their start (one run of that length); the rest keep their verdict. \
         Wall time of the whole map (one run each, the same engine); \"right\" over the settled \
         cells of both subgrids; \"transient chaos right\" over the {} cells above; firm verdicts \
         with the table the map applies (`SHIPPED` unsettled, `SETTLED` settled).\n\n\
         | settle_max_s | from | wall (s) | × unsettled | cells run on | verdicts changed | right of settled | transient chaos right | firm of settled | right of firm |\n\
         |---|---|---|---|---|---|---|---|---|---|",
        t.settle_later
    );
    let base = g.curve.first().map_or(f64::NAN, |p| p.wall_s);
    for p in &g.curve {
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {:.2} | {} | {} | {}/{} ({:.1} %) | {}/{} | {}/{} ({:.1} %) | {}/{} ({:.1} %) |",
            p.settle_max_s.map_or("off".into(), |x| format!("{x} s")),
            p.from.map_or("–", |f| f.name()),
            p.wall_s,
            p.wall_s / base,
            p.rerun,
            p.changed,
            p.right,
            p.settled,
            100.0 * p.right as f64 / p.settled.max(1) as f64,
            p.transient_right,
            t.settle_later,
            p.firm.cells,
            p.firm.settled,
            p.firm.coverage_pct(),
            p.firm.right,
            p.firm.cells,
            p.firm.right_pct()
        );
    }
    let _ = writeln!(
        s,
        "\n### Reliability of the settled map ({SETTLED_TABLE_S} s)\n\n\
         The map settled for {SETTLED_TABLE_S} s, scored as above; its confidence comes from \
         the table `SETTLED`, fitted here.\n"
    );
    reliability_body(s, &g.reliability, "settled");
}

/// `12, 30, 41` (s), or "none".
fn list_s(v: &[f64]) -> String {
    if v.is_empty() {
        return "none".into();
    }
    v.iter()
        .map(|x| format!("{x:.0}"))
        .collect::<Vec<_>>()
        .join(", ")
}
