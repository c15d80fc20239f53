//! What a calibration writes: `candidates.csv`, `best_scene.toml`, `REPORT.md`,
//! `calibrate_scene.toml` (the calibration's scene after its overrides) and, last,
//! `calibrate.json` (its presence means the folder is complete).

use super::run::{CalibrationRun, Candidate};
use super::spec::CalibrationSpec;
use crate::about::StudyAbout;
use pendulum_atlas_core::config::axis_label;
use pendulum_atlas_core::config::set_key;
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{
    commit_csv, create_csv, csv_error, draw, write_bytes, write_json, write_toml,
};
use pendulum_atlas_map::output::manifest::Manifest;
use pendulum_atlas_map::render::{Axis, CellMarks, Palette, heatmap_scaled};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use toml::Value;

/// Write every file into `dir` (which the caller has claimed); returns their paths.
pub fn write_calibration(
    dir: &Path,
    spec: &CalibrationSpec,
    run: &CalibrationRun,
    about: &StudyAbout,
) -> Result<Vec<PathBuf>, OutputError> {
    let mut files = vec![
        write_candidates(&dir.join("candidates.csv"), spec, run)?,
        write_bytes(
            &dir.join("best_scene.toml"),
            best_scene(spec, run.best()).as_bytes(),
        )?,
        write_bytes(&dir.join("REPORT.md"), report(spec, run).as_bytes())?,
        write_toml(
            &dir.join("calibrate_scene.toml"),
            &spec.source_table,
            "The scene of this calibration after every --set override.\n\
             `pendulum-atlas calibrate calibrate_scene.toml` runs it again; `pendulum-atlas explore` reads it.",
        )?,
    ];
    files.extend(draw_agreement(dir, spec, run)?);
    let names: Vec<String> = files
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .chain([CalibrateManifest::NAME.to_string()])
        .collect();
    let manifest = CalibrateManifest {
        about: about.clone(),
        unknowns: json(&spec.unknowns),
        cases: json(&spec.cases),
        initial_states: spec.initial_states,
        initial_spread_deg: spec.initial_spread_deg,
        agreement: json(&spec.agreement),
        refine: json(&spec.refine),
        observations: json(&run.observations),
        instances: json(&run.instances),
        best: json(run.best()),
        never_matched: never_matched(spec, run),
        usable: run.usable(),
        files: names,
    };
    files.push(write_json(&dir.join(CalibrateManifest::NAME), &manifest)?);
    Ok(files)
}

/// A block of a manifest as JSON (`null` if it cannot be one, which the types written here
/// never are).
fn json<T: Serialize + ?Sized>(v: &T) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or_default()
}

/// `calibrate.json`: what ran, the unknowns and cases, every candidate's agreement and the
/// best, and the files of the folder. Written last; the explorer reads it back.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CalibrateManifest {
    /// What ran the calibration.
    pub about: StudyAbout,
    /// The unknowns and their grids.
    pub unknowns: serde_json::Value,
    /// The observed cases.
    pub cases: serde_json::Value,
    /// Starts per case.
    pub initial_states: u32,
    /// Spread of the starts (deg).
    pub initial_spread_deg: f64,
    /// How agreement is scored.
    pub agreement: serde_json::Value,
    /// The refinement rounds' settings.
    pub refine: serde_json::Value,
    /// Each observation, named.
    pub observations: serde_json::Value,
    /// Instances run.
    pub instances: serde_json::Value,
    /// The best candidate.
    pub best: serde_json::Value,
    /// Observations no candidate matched.
    pub never_matched: Vec<String>,
    /// Whether any run of any candidate ended ok (false: every run failed, and nothing could
    /// be compared with the observations).
    #[serde(default = "earlier_usable")]
    pub usable: bool,
    /// The files of the folder, by name.
    pub files: Vec<String>,
}

/// A folder written before `usable` was recorded: only usable calibrations were kept then
/// without an error, so it is taken as usable.
fn earlier_usable() -> bool {
    true
}

impl Manifest for CalibrateManifest {
    const NAME: &'static str = "calibrate.json";

    fn listed(&self) -> &[String] {
        &self.files
    }
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

/// One row per candidate, best first: rank, stage, the unknowns, the score (observations
/// matched, of all, judged: with at least one run that ended ok), then per observation whether
/// it matched, the share of runs that matched and the distance.
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
    header.extend([
        "matched".into(),
        "observations".into(),
        "judged".into(),
        "distance".into(),
    ]);
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
            cand.judged().to_string(),
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
    if !run.usable() {
        s.push_str(
            "**Every run failed.** No run of any candidate ended ok (each diverged, turned \
             non-finite or escaped), so nothing could be compared with the observations: the \
             ranking below is the evaluation order, not a finding. Check the scene's ranges \
             and steps (`pendulum-atlas simulate` one candidate to see how it fails).\n\n",
        );
    }
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

/// `agreement_<key1>_<key2>.png` for each pair of unknowns with two or more grid values: the
/// share of observations the grid candidate matches over the pair, the other unknowns at the
/// best grid candidate's values.
fn draw_agreement(
    dir: &Path,
    spec: &CalibrationSpec,
    run: &CalibrationRun,
) -> Result<Vec<PathBuf>, OutputError> {
    let grid: Vec<&Candidate> = run
        .candidates
        .iter()
        .filter(|c| c.stage == "grid")
        .collect();
    let Some(best) = run
        .ranking
        .iter()
        .map(|&i| &run.candidates[i])
        .find(|c| c.stage == "grid")
    else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    let n = spec.unknowns.len();
    for i in 0..n {
        for j in i + 1..n {
            if spec.unknowns[i].values.len() >= 2 && spec.unknowns[j].values.len() >= 2 {
                let pair = Pair {
                    i,
                    j,
                    best,
                    grid: &grid,
                };
                out.push(draw_pair(dir, spec, run, &pair)?);
            }
        }
    }
    Ok(out)
}

/// Unknowns `i` and `j` of the grid, the others held at `best`'s values.
struct Pair<'a> {
    i: usize,
    j: usize,
    best: &'a Candidate,
    grid: &'a [&'a Candidate],
}

impl Pair<'_> {
    /// Share of observations matched by the grid candidate at (x, y), NaN if none.
    fn share(&self, x: f64, y: f64, observations: usize) -> f64 {
        let at = |k: usize| match k {
            k if k == self.i => x,
            k if k == self.j => y,
            k => self.best.values[k],
        };
        self.grid
            .iter()
            .find(|c| c.values.iter().enumerate().all(|(k, &v)| v == at(k)))
            .map_or(f64::NAN, |c| c.matched as f64 / observations as f64)
    }
}

/// One agreement picture.
fn draw_pair(
    dir: &Path,
    spec: &CalibrationSpec,
    run: &CalibrationRun,
    pair: &Pair,
) -> Result<PathBuf, OutputError> {
    let (ux, uy) = (&spec.unknowns[pair.i], &spec.unknowns[pair.j]);
    let vals: Vec<f64> = uy
        .values
        .iter()
        .flat_map(|&y| {
            ux.values
                .iter()
                .map(move |&x| pair.share(x, y, run.observations))
        })
        .collect();
    let name = |k: &str| k.replace('.', "_");
    let path = dir.join(format!("agreement_{}_{}.png", name(&ux.key), name(&uy.key)));
    let (xl, yl) = (axis_label(&ux.key), axis_label(&uy.key));
    let x = Axis {
        label: &xl,
        values: &ux.values,
    };
    let y = Axis {
        label: &yl,
        values: &uy.values,
    };
    let title = "share of observations matched (other unknowns at the best)";
    draw(&path, |p| {
        heatmap_scaled(
            p,
            title,
            &x,
            &y,
            [ux.scale, uy.scale],
            &vals,
            "share matched",
            &CellMarks::default(),
            &Palette::Sequential(Some((0.0, 1.0))),
        )
    })
}
