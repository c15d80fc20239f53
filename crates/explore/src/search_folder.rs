//! A search folder: `search.json`, `search_scene.toml`, `designs.csv` and `instances.csv`.
//! The grid is the initial grid of the design variables; each grid design's row gives its
//! bandwidth and power. A cell runs at one frequency of the band from one initial state (the
//! variants), with the cart amplitude the band's base excitation gives there.

use super::error::ExploreError;
use super::folder::{
    Axis, Column, Csv, RunFolder, Source, bad, grid_cell, num, read_manifest, read_text,
};
use super::sources::{Found, InstanceKey, Search};
use pendulum_atlas_core::config::axis_label;
use pendulum_atlas_design::harvest::SearchManifest;
use pendulum_atlas_design::harvest::spec::{SearchSpec, search_from_toml};
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::render::Palette;
use std::collections::HashMap;
use std::path::Path;

/// The quantities of `designs.csv` shown per design: (column, label).
const DESIGN_COLUMNS: [(&str, &str); 9] = [
    (
        "bandwidth_robust_hz",
        "robust bandwidth (Hz): band where every initial state harvests",
    ),
    ("band_avg_power_robust_w", "robust band-averaged power (W)"),
    ("peak_power_robust_w", "robust peak power (W)"),
    (
        "peak_frequency_robust_hz",
        "frequency of the robust peak (Hz)",
    ),
    (
        "bandwidth_mean_hz",
        "bandwidth of the mean over initial states (Hz)",
    ),
    (
        "band_avg_power_mean_w",
        "band-averaged power, mean over initial states (W)",
    ),
    ("hops_per_instance_mean", "hops per instance (mean)"),
    ("periodic_fraction", "share of periodic instances"),
    ("failed_instances", "failed instances"),
];

/// Read a search folder.
pub fn open(dir: &Path) -> Result<RunFolder, ExploreError> {
    let manifest: SearchManifest = read_manifest(dir)?;
    let text = read_text(
        dir,
        "search_scene.toml",
        "the search's scene is needed to rerun a design; searches written before \
         search_scene.toml was added have none: run the search again",
    )?;
    let path = dir.join("search_scene.toml");
    let spec = search_from_toml(&text, &path.display().to_string(), &[])
        .map_err(|e| bad(&path, e.to_string()))?;
    let axes: Vec<Axis> = spec
        .variables
        .iter()
        .map(|v| Axis {
            key: v.key.clone(),
            label: axis_label(&v.key),
            values: v.values.clone(),
            scale: v.scale,
        })
        .collect();
    let (columns, design) = read_designs(dir, &spec, &axes)?;
    let cells = design.len();
    let instances = read_instances(dir, &spec)?;
    let variants = spec
        .initial_states
        .iter()
        .flat_map(|s| {
            spec.band
                .frequencies_hz
                .iter()
                .map(move |f| format!("{f} Hz, {}", s.name))
        })
        .collect();
    Ok(RunFolder {
        cell_attractors: Vec::new(),
        starts: Vec::new(),
        dir: dir.to_path_buf(),
        product: Product::Search,
        files: manifest.files.clone(),
        axes,
        columns,
        status: vec![0; cells],
        inferred: Vec::new(),
        ran_on: Vec::new(),
        marks: Vec::new(),
        copies: Vec::new(),
        variants,
        segments: spec.scene.beam.segments,
        source: Source::Search(Box::new(Search {
            spec,
            manifest,
            design,
            instances,
        })),
    })
}

/// The grid designs of `designs.csv` placed on the grid: their quantities, and each cell's
/// design id.
fn read_designs(
    dir: &Path,
    spec: &SearchSpec,
    axes: &[Axis],
) -> Result<(Vec<Column>, Vec<Option<String>>), ExploreError> {
    let cells: usize = axes.iter().map(|a| a.values.len()).product();
    let csv = Csv::read(dir, "designs.csv")?;
    let col = |name: &str| csv.col(name);
    let (id, stage) = (col("id")?, col("stage")?);
    let var_cols: Vec<usize> = spec
        .variables
        .iter()
        .map(|v| col(&v.key))
        .collect::<Result<_, _>>()?;
    let data_cols: Vec<usize> = DESIGN_COLUMNS
        .iter()
        .map(|(n, _)| col(n))
        .collect::<Result<_, _>>()?;
    let mut columns: Vec<Column> = DESIGN_COLUMNS
        .iter()
        .map(|(name, label)| Column {
            name: (*name).into(),
            label: (*label).into(),
            palette: Palette::Sequential((*name == "periodic_fraction").then_some((0.0, 1.0))),
            values: vec![f64::NAN; cells],
        })
        .collect();
    let mut design = vec![None; cells];
    for row in csv.rows.iter().filter(|r| r[stage] == "grid") {
        let values: Vec<f64> = var_cols.iter().map(|&c| num(&row[c])).collect();
        let k = grid_cell(axes, &values).ok_or_else(|| {
            bad(&csv.path, format!("a grid design at ({}) is not on the grid of search_scene.toml: the files are from different searches", values.iter().map(|&v| pendulum_atlas_core::text::num(v)).collect::<Vec<_>>().join(", ")))
        })?;
        design[k] = Some(row[id].clone());
        for (c, &i) in columns.iter_mut().zip(&data_cols) {
            c.values[k] = num(&row[i]);
        }
    }
    Ok((columns, design))
}

/// `instances.csv` by (design, initial state, frequency index).
fn read_instances(
    dir: &Path,
    spec: &SearchSpec,
) -> Result<HashMap<InstanceKey, Found>, ExploreError> {
    let csv = Csv::read(dir, "instances.csv")?;
    let col = |name: &str| csv.col(name);
    let (d, s, f) = (col("design")?, col("initial_state")?, col("frequency_hz")?);
    let (p, h, per) = (col("power_w")?, col("hops")?, col("period")?);
    let freqs = &spec.band.frequencies_hz;
    Ok(csv
        .rows
        .iter()
        .filter_map(|r| {
            let fx = num(&r[f]);
            let j = freqs
                .iter()
                .position(|&g| (g - fx).abs() <= 1e-9 * g.abs().max(1e-300))?;
            let found = Found {
                power_w: num(&r[p]),
                hops: num(&r[h]),
                period: num(&r[per]),
            };
            Some(((r[d].clone(), r[s].clone(), j), found))
        })
        .collect())
}

/// Variant `v` as (initial state index, frequency index).
pub(crate) fn split_variant(spec: &SearchSpec, v: usize) -> (usize, usize) {
    let nf = spec.band.frequencies_hz.len();
    (v / nf, v % nf)
}
