//! What a calibration writes: `candidates.csv`, `best_scene.toml`, `REPORT.md` and, last,
//! `calibrate.json` (its presence means the folder is complete).

use super::run::{CalibrationRun, Candidate};
use super::spec::CalibrationSpec;
use crate::config::set_key;
use crate::output::OutputError;
use crate::output::files::{commit_csv, create_csv, csv_error, write_bytes, write_json};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use toml::Value;

/// Write every file into `dir` (which the caller has claimed); returns their paths.
pub fn write_calibration(
    dir: &Path,
    spec: &CalibrationSpec,
    run: &CalibrationRun,
    about: &serde_json::Value,
) -> Result<Vec<PathBuf>, OutputError> {
    let mut files = vec![
        write_candidates(&dir.join("candidates.csv"), spec, run)?,
        write_bytes(
            &dir.join("best_scene.toml"),
            best_scene(spec, run.best()).as_bytes(),
        )?,
        write_bytes(&dir.join("REPORT.md"), report(spec, run).as_bytes())?,
    ];
    let names: Vec<String> = files
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .chain(["calibrate.json".to_string()])
        .collect();
    let json = serde_json::json!({
        "about": about,
        "unknowns": spec.unknowns,
        "cases": spec.cases,
        "initial_states": spec.initial_states,
        "initial_spread_deg": spec.initial_spread_deg,
        "agreement": spec.agreement,
        "refine": spec.refine,
        "observations": run.observations,
        "instances": run.instances,
        "best": run.best(),
        "never_matched": never_matched(spec, run),
        "files": names,
    });
    files.push(write_json(&dir.join("calibrate.json"), &json)?);
    Ok(files)
}

/// The name of observation `o` of case `c`, for headers and reports.
fn observation_name(spec: &CalibrationSpec, c: usize, o: usize) -> String {
    let case = &spec.cases[c];
    format!("{}: {}", case.name, case.observations[o].label())
}

/// Every (case, observation) index pair in order.
fn observation_ids(spec: &CalibrationSpec) -> Vec<(usize, usize)> {
    spec.cases
        .iter()
        .enumerate()
        .flat_map(|(c, case)| (0..case.observations.len()).map(move |o| (c, o)))
        .collect()
}

/// One row per candidate, best first: rank, stage, the unknowns, the score, then per
/// observation whether it matched, the share of runs that matched and the distance.
fn write_candidates(
    path: &Path,
    spec: &CalibrationSpec,
    run: &CalibrationRun,
) -> Result<PathBuf, OutputError> {
    let err = csv_error(path);
    let mut w = create_csv(path)?;
    let ids = observation_ids(spec);
    let mut header: Vec<String> = vec!["rank".into(), "stage".into()];
    header.extend(spec.unknowns.iter().map(|u| u.key.clone()));
    header.extend(["matched".into(), "observations".into(), "distance".into()]);
    for &(c, o) in &ids {
        let name = observation_name(spec, c, o);
        header.extend([
            format!("{name} | match"),
            format!("{name} | share"),
            format!("{name} | distance"),
        ]);
    }
    w.write_record(&header).map_err(&err)?;
    for (rank, &id) in run.ranking.iter().enumerate() {
        let cand = &run.candidates[id];
        let mut row = vec![(rank + 1).to_string(), cand.stage.clone()];
        row.extend(cand.values.iter().map(f64::to_string));
        row.extend([
            cand.matched.to_string(),
            run.observations.to_string(),
            cand.distance.to_string(),
        ]);
        for &(c, o) in &ids {
            let j = cand.judgements[c][o];
            row.extend([
                u8::from(j.matched).to_string(),
                j.share.to_string(),
                j.distance.to_string(),
            ]);
        }
        w.write_record(&row).map_err(&err)?;
    }
    commit_csv(w, path)
}

/// The base scene with the best candidate's unknowns: ready for `simulate` and `map`.
fn best_scene(spec: &CalibrationSpec, best: &Candidate) -> String {
    let mut table = spec.base_table.clone();
    for (u, &v) in spec.unknowns.iter().zip(&best.values) {
        set_key(&mut table, &u.key, Value::Float(v)).expect("checked when the spec was read");
    }
    let mut text = format!(
        "# The best candidate of a calibration: {} of {} observations matched.\n",
        best.matched,
        spec.cases
            .iter()
            .map(|c| c.observations.len())
            .sum::<usize>()
    );
    text.push_str(&toml::to_string(&table).expect("a TOML table serialises"));
    text
}

/// Observations that no candidate matched.
fn never_matched(spec: &CalibrationSpec, run: &CalibrationRun) -> Vec<String> {
    observation_ids(spec)
        .into_iter()
        .filter(|&(c, o)| !run.candidates.iter().any(|k| k.judgements[c][o].matched))
        .map(|(c, o)| observation_name(spec, c, o))
        .collect()
}

/// What the calibration found, in words.
fn report(spec: &CalibrationSpec, run: &CalibrationRun) -> String {
    let best = run.best();
    let mut s = String::from("# Calibration\n\n");
    let _ = writeln!(
        s,
        "{} candidates ({} instances: candidates × {} cases × {} initial states).\n",
        run.candidates.len(),
        run.instances,
        spec.cases.len(),
        spec.initial_states
    );
    let _ = writeln!(
        s,
        "## Best candidate: {} of {} observations\n",
        best.matched, run.observations
    );
    for (u, v) in spec.unknowns.iter().zip(&best.values) {
        let _ = writeln!(s, "- `{}` = {v}", u.key);
    }
    let ties = run
        .candidates
        .iter()
        .filter(|c| c.matched == best.matched)
        .count();
    let _ = writeln!(
        s,
        "\n{ties} candidate(s) match as many observations; `candidates.csv` lists them first.\n"
    );
    s.push_str("| case | observation | matched by the best | share of runs | distance |\n|---|---|---|---|---|\n");
    for (c, o) in observation_ids(spec) {
        let j = best.judgements[c][o];
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} | {:.2} |",
            spec.cases[c].name,
            spec.cases[c].observations[o].label(),
            if j.matched { "yes" } else { "no" },
            j.share,
            j.distance
        );
    }
    let never = never_matched(spec, run);
    s.push_str("\n## Never matched\n\n");
    if never.is_empty() {
        s.push_str("Every observation is matched by at least one candidate.\n");
    } else {
        for n in never {
            let _ = writeln!(s, "- {n}");
        }
    }
    s
}
