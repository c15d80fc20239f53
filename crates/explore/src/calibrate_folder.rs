//! A calibration folder: `calibrate.json`, `calibrate_scene.toml` and `candidates.csv`. The
//! grid is the one of the unknowns; each grid candidate's row gives how many observations it
//! matched, in all and case by case. A cell runs in one of the cases (the variants), from the
//! scene's initial angle (the middle of the spread of initial states).

use super::error::ExploreError;
use super::folder::{
    Axis, Column, Csv, RunFolder, Source, bad, grid_cell, num, read_manifest, read_text,
};
use super::sources::{Calibration, Judged};
use pendulum_atlas_core::config::{Scene, axis_label};
use pendulum_atlas_design::calibrate::{CalibrateManifest, CalibrationSpec, calibration_from_toml};
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::render::Palette;
use std::path::Path;

/// The grid rows of `candidates.csv`: matched in all, distance, and the judgements per case.
struct Grid {
    total: Vec<f64>,
    distance: Vec<f64>,
    judged: Vec<Vec<Vec<Judged>>>,
}

/// Read a calibration folder.
pub fn open(dir: &Path) -> Result<RunFolder, ExploreError> {
    let manifest: CalibrateManifest = read_manifest(dir)?;
    let text = read_text(
        dir,
        "calibrate_scene.toml",
        "the calibration's scene is needed to rerun a candidate; calibrations written before \
         calibrate_scene.toml was added have none: run the calibration again",
    )?;
    let path = dir.join("calibrate_scene.toml");
    let spec = calibration_from_toml(&text, &path.display().to_string(), &[])
        .map_err(|e| bad(&path, e.to_string()))?;
    let axes: Vec<Axis> = spec
        .unknowns
        .iter()
        .map(|u| Axis {
            key: u.key.clone(),
            label: axis_label(&u.key),
            values: u.values.clone(),
            scale: u.scale,
        })
        .collect();
    let grid = read_grid(dir, &spec, &axes)?;
    let columns = columns(&spec, &grid);
    let cells = grid.total.len();
    Ok(RunFolder {
        cell_attractors: Vec::new(),
        starts: Vec::new(),
        dir: dir.to_path_buf(),
        product: Product::Calibrate,
        files: manifest.files.clone(),
        axes,
        columns,
        status: vec![0; cells],
        inferred: Vec::new(),
        ran_on: Vec::new(),
        marks: Vec::new(),
        copies: Vec::new(),
        variants: spec.cases.iter().map(|c| c.name.clone()).collect(),
        segments: Scene::from_table(spec.base_table.clone())
            .map_err(|e| bad(&path, e.to_string()))?
            .beam
            .segments,
        source: Source::Calibrate(Box::new(Calibration {
            spec,
            manifest,
            judged: grid.judged,
        })),
    })
}

/// The grid candidates of `candidates.csv`, placed on the grid of the unknowns.
fn read_grid(dir: &Path, spec: &CalibrationSpec, axes: &[Axis]) -> Result<Grid, ExploreError> {
    let cells: usize = axes.iter().map(|a| a.values.len()).product();
    let csv = Csv::read(dir, "candidates.csv")?;
    let (stage, matched, distance) = (csv.col("stage")?, csv.col("matched")?, csv.col("distance")?);
    let unknown_cols: Vec<usize> = spec
        .unknowns
        .iter()
        .map(|u| csv.col(&u.key))
        .collect::<Result<_, _>>()?;
    let mut grid = Grid {
        total: vec![f64::NAN; cells],
        distance: vec![f64::NAN; cells],
        judged: vec![vec![Vec::new(); spec.cases.len()]; cells],
    };
    for row in csv.rows.iter().filter(|r| r[stage] == "grid") {
        let values: Vec<f64> = unknown_cols.iter().map(|&c| num(&row[c])).collect();
        let k = grid_cell(axes, &values).ok_or_else(|| {
            bad(&csv.path, format!("a grid candidate at ({}) is not on the grid of calibrate_scene.toml: the files are from different calibrations", values.iter().map(|&v| pendulum_atlas_core::text::num(v)).collect::<Vec<_>>().join(", ")))
        })?;
        grid.total[k] = num(&row[matched]);
        grid.distance[k] = num(&row[distance]);
        for (c, case) in spec.cases.iter().enumerate() {
            grid.judged[k][c] = case_judgements(&csv.header, row, &case.name);
        }
    }
    Ok(grid)
}

/// Matched in all, the distance, and matched per case.
fn columns(spec: &CalibrationSpec, grid: &Grid) -> Vec<Column> {
    let observations = spec
        .cases
        .iter()
        .map(|c| c.observations.len())
        .sum::<usize>();
    let mut columns = vec![
        Column {
            name: "matched".into(),
            label: format!("observations matched (of {observations})"),
            palette: Palette::Sequential(Some((0.0, observations as f64))),
            values: grid.total.clone(),
        },
        Column {
            name: "distance".into(),
            label: "distance to the observations (the tie-break; lower is closer)".into(),
            palette: Palette::Sequential(None),
            values: grid.distance.clone(),
        },
    ];
    for (c, case) in spec.cases.iter().enumerate() {
        let n = case.observations.len();
        columns.push(Column {
            name: format!("matched: {}", case.name),
            label: format!("observations of `{}` matched (of {n})", case.name),
            palette: Palette::Sequential(Some((0.0, n as f64))),
            values: grid
                .judged
                .iter()
                .map(|j| {
                    if j[c].is_empty() {
                        f64::NAN
                    } else {
                        j[c].iter().map(|o| o.matched).sum()
                    }
                })
                .collect(),
        });
    }
    columns
}

/// The judgements of case `name` in one row: its `OBS | match`, `| share`, `| distance`
/// columns.
fn case_judgements(header: &[String], row: &[String], name: &str) -> Vec<Judged> {
    let prefix = format!("{name}: ");
    let at = |i: usize| row.get(i).map_or(f64::NAN, |s| num(s));
    header
        .iter()
        .enumerate()
        .filter_map(|(i, h)| {
            let obs = h.strip_prefix(&prefix)?.strip_suffix(" | match")?;
            Some(Judged {
                observation: obs.to_string(),
                matched: at(i),
                share: at(i + 1),
                distance: at(i + 2),
            })
        })
        .collect()
}
