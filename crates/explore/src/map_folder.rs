//! A map folder: `map.json`, `map_scene.toml`, `status.npy` and one `.npy` per metric array,
//! each shaped like the grid.

use super::error::ExploreError;
use super::folder::{
    Axis, CellAttractor, Column, MARK_AFTER_TRANSIENT, MARK_START_DECIDES, RunFolder, Source, bad,
    read_json, read_manifest, read_text,
};
use pendulum_atlas_core::config::{MapSpec, Metric, map_from_toml};
use pendulum_atlas_core::reduce::attractors::Family;
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::output::manifest::MapManifest;
use pendulum_atlas_map::output::map::{
    attractor_style, metric_style, regime_shade, shown_label, shown_value, value_fields,
};
use pendulum_atlas_map::output::npy::read_npy;
use pendulum_atlas_map::render::Palette;
use std::path::Path;

/// Read a map folder.
pub fn open(dir: &Path) -> Result<RunFolder, ExploreError> {
    let manifest: MapManifest = read_manifest(dir)?;
    let text = read_text(
        dir,
        "map_scene.toml",
        "the map's scene is needed to rerun a cell; maps written before map_scene.toml was \
         added have none: run the map again",
    )?;
    let path = dir.join("map_scene.toml");
    let spec = map_from_toml(&text, &path.display().to_string(), &[])
        .map_err(|e| bad(&path, e.to_string()))?;
    check_shape(dir, &spec, &manifest)?;
    let mut columns = metric_columns(dir, &spec, "")?;
    if let Some(c) = spec.continuation() {
        let first = c.sweep.directions()[0].name();
        for col in &mut columns {
            col.label = format!("{}, sweeping {first}", col.label);
        }
    }
    columns.extend(continuation_columns(dir, &spec)?);
    let families = read_families(dir, &manifest)?;
    columns.extend(attractor_columns(dir, &spec, families.as_deref())?);
    let status = read_array::<u8>(dir, "status.npy", &spec)?;
    let flags = |name: &str| -> Result<Vec<bool>, ExploreError> {
        if !manifest.files.iter().any(|f| f == name) {
            return Ok(Vec::new());
        }
        let flags = read_array::<u8>(dir, name, &spec)?;
        Ok(flags.into_iter().map(|f| f == 1).collect())
    };
    let inferred = flags("inferred.npy")?;
    let ran_on = flags("ran_on.npy")?;
    let (marks, copies, copy_columns) = transient_marks(dir, &spec, &manifest)?;
    columns.extend(copy_columns);
    let starts = if manifest.files.iter().any(|f| f == "start.npy") {
        read_array::<i32>(dir, "start.npy", &spec)?
            .into_iter()
            .map(|s| usize::try_from(s).unwrap_or(usize::MAX))
            .collect()
    } else {
        Vec::new()
    };
    if let Some(bad_start) = starts.iter().find(|&&s| s >= spec.starts_per_cell()) {
        return Err(bad(
            &dir.join("start.npy"),
            format!(
                "start {bad_start} is not one of the map's {} starts: the files are from different maps",
                spec.starts_per_cell()
            ),
        ));
    }
    let cell_attractors = match &families {
        Some(f) if spec.starts_per_cell() > 1 => cell_attractors(dir, &spec, f)?,
        _ => Vec::new(),
    };
    let variants = match (spec.starts(), cell_attractors.is_empty()) {
        (Some(set), false) => start_variants(set),
        _ => Vec::new(),
    };
    Ok(RunFolder {
        dir: dir.to_path_buf(),
        product: Product::Map,
        starts,
        cell_attractors,
        files: manifest.files.clone(),
        axes: spec
            .axes
            .iter()
            .map(|a| Axis {
                key: a.key.clone(),
                label: a.label(),
                values: a.values.clone(),
                scale: a.scale,
            })
            .collect(),
        columns,
        status,
        inferred,
        ran_on,
        marks,
        copies,
        variants,
        segments: spec.scene.beam.segments,
        source: Source::Map(Box::new(spec), Box::new(manifest)),
    })
}

/// Per cell, its marks and whether it ran copies; and the copies' arrays as columns.
type CopyMarks = (Vec<u8>, Vec<bool>, Vec<Column>);

/// The marks of a map whose cells ran nudged copies (`start_sensitivity.npy`,
/// `transient_s.npy`), which cells ran them, and both arrays as columns; nothing for other
/// maps.
fn transient_marks(
    dir: &Path,
    spec: &MapSpec,
    manifest: &MapManifest,
) -> Result<CopyMarks, ExploreError> {
    let listed = |name: &str| manifest.files.iter().any(|f| f == name);
    if !listed("start_sensitivity.npy") || !listed("transient_s.npy") {
        return Ok((Vec::new(), Vec::new(), Vec::new()));
    }
    let s = read_array::<f64>(dir, "start_sensitivity.npy", spec)?;
    let tau = read_array::<f64>(dir, "transient_s.npy", spec)?;
    let regime = read_array::<i8>(dir, "regime.npy", spec)?;
    let periodic = pendulum_atlas_core::reduce::Regime::Periodic.code();
    let marks = (0..s.len())
        .map(|k| {
            let decides = if s[k] > 0.0 { MARK_START_DECIDES } else { 0 };
            let after = tau[k].is_finite() && regime[k] == periodic;
            decides | if after { MARK_AFTER_TRANSIENT } else { 0 }
        })
        .collect();
    let copies = s.iter().map(|v| v.is_finite()).collect();
    let column = |name: &str, label: &str, values: Vec<f64>, range| Column {
        name: name.into(),
        label: label.into(),
        palette: Palette::Sequential(range),
        values,
    };
    let columns = vec![
        column(
            "start_sensitivity",
            "share of nudged copies that disagree with the cell (0–1; grey: firm, none ran)",
            s,
            Some((0.0, 1.0)),
        ),
        column(
            "transient_s",
            "chaotic transient's mean lifetime (s; grey: no escape seen)",
            tau,
            None,
        ),
    ];
    Ok((marks, copies, columns))
}

/// Every metric of the map as stored in `NAME{suffix}.npy` (`suffix` "_down" for the down
/// sweep of a map run both ways).
fn metric_columns(dir: &Path, spec: &MapSpec, suffix: &str) -> Result<Vec<Column>, ExploreError> {
    let stored: Vec<(&str, Metric, Vec<f64>)> = value_fields()
        .filter_map(|f| Some((f.name, f.metric?)))
        .filter(|&(_, m)| spec.wants(m))
        // Maps written before the confidence stage have no verdict_confidence.npy.
        .filter(|(stem, _)| {
            *stem != "verdict_confidence" || dir.join(format!("{stem}{suffix}.npy")).is_file()
        })
        .map(|(stem, m)| {
            let values = read_array::<f64>(dir, &format!("{stem}{suffix}.npy"), spec)?;
            Ok((stem, m, values))
        })
        .collect::<Result<_, ExploreError>>()?;
    let regime = if spec.wants(Metric::Regime) {
        read_array::<i8>(dir, &format!("regime{suffix}.npy"), spec)?
    } else {
        Vec::new()
    };
    let mut columns: Vec<Column> = spec
        .metrics
        .iter()
        .map(|&m| metric_column(spec, m, &stored, &regime))
        .collect();
    verdict_first(&mut columns, &stored);
    Ok(columns)
}

/// The verdict first, where the map has one: the regime column, then its confidence
/// (`verdict_confidence.npy`: the chance that the verdict is the converged one, from the map's
/// confidence stage; `regime_confidence.npy`, the λ1 probability, for maps written before it),
/// then the other metrics in the map's order. The page opens on the first column.
fn verdict_first(columns: &mut Vec<Column>, stored: &[(&str, Metric, Vec<f64>)]) {
    let Some(at) = columns.iter().position(|c| c.name == Metric::Regime.name()) else {
        return;
    };
    let regime = columns.remove(at);
    let of = |stem: &str| stored.iter().find(|s| s.0 == stem);
    let confidence = match of("verdict_confidence") {
        Some(s) => Some((
            s,
            "chance the verdict is the converged one (0–1; grey: undecided)",
        )),
        None => of("regime_confidence")
            .map(|s| (s, "λ1 confidence of the verdict (0.5–1; grey: undecided)")),
    }
    .map(|(s, label)| Column {
        name: s.0.into(),
        label: label.into(),
        palette: Palette::Sequential(Some((0.0, 1.0))),
        values: s.2.clone(),
    });
    columns.splice(0..0, std::iter::once(regime).chain(confidence));
}

/// A map run by continuation both ways: the down sweep's metrics (`NAME_down`) and where the
/// two sweeps differ (`hysteresis`); nothing for any other map.
fn continuation_columns(dir: &Path, spec: &MapSpec) -> Result<Vec<Column>, ExploreError> {
    let Some(c) = spec.continuation() else {
        return Ok(Vec::new());
    };
    if c.sweep != pendulum_atlas_core::config::Sweep::Both {
        return Ok(Vec::new());
    }
    let mut out: Vec<Column> = metric_columns(dir, spec, "_down")?
        .into_iter()
        .map(|col| Column {
            name: format!("{}_down", col.name),
            label: format!("{}, sweeping down", col.label),
            ..col
        })
        .collect();
    let differs = read_array::<u8>(dir, "hysteresis.npy", spec)?;
    out.push(Column {
        name: "hysteresis".into(),
        label: "up and down differ (1: on different attractors)".into(),
        palette: pendulum_atlas_map::render::Palette::Sequential(Some((0.0, 1.0))),
        values: differs.iter().map(|&d| f64::from(d)).collect(),
    });
    Ok(out)
}

/// Metric `m` as shown: its label and palette from the PNGs' rule, `alpha_range` as the
/// difference of its two arrays, period 0 as no data, the regime (codes of `regime.npy`) in
/// its shades.
fn metric_column(
    spec: &MapSpec,
    m: Metric,
    stored: &[(&str, Metric, Vec<f64>)],
    regime: &[i8],
) -> Column {
    let of = |stem: &str| stored.iter().find(|s| s.0 == stem).map(|s| &s.2);
    let raw: Vec<f64> = match m {
        Metric::AlphaRange => match (of("alpha_max_rad"), of("alpha_min_rad")) {
            (Some(hi), Some(lo)) => hi.iter().zip(lo).map(|(a, b)| a - b).collect(),
            _ => Vec::new(),
        },
        Metric::Regime => match of("period") {
            Some(period) => regime
                .iter()
                .zip(period)
                .map(|(&c, &p)| regime_shade(f64::from(c), p))
                .collect(),
            None => Vec::new(),
        },
        _ => stored
            .iter()
            .find(|s| s.1 == m)
            .map(|s| s.2.clone())
            .unwrap_or_default(),
    };
    let style = metric_style(m, spec);
    Column {
        name: m.name().into(),
        label: style.label,
        palette: style.palette,
        values: raw.iter().map(|&v| shown_value(m, v)).collect(),
    }
}

/// The attractor families of a map that labels attractors (`None` for any other map).
fn read_families(dir: &Path, manifest: &MapManifest) -> Result<Option<Vec<Family>>, ExploreError> {
    if !manifest.files.iter().any(|f| f == "attractors.json") {
        return Ok(None);
    }
    let path = dir.join("attractors.json");
    serde_json::from_value(read_json(&path)?["attractors"]["families"].clone())
        .map(Some)
        .map_err(|e| {
            bad(
                &path,
                pendulum_atlas_core::text::json_damage("attractors.json", &e),
            )
        })
}

/// The ways a cell of a map with several starts runs: its representative start (variant 0),
/// then each start (variant `s + 1`).
fn start_variants(set: &pendulum_atlas_core::config::StartSet) -> Vec<String> {
    let each = set.states.iter().enumerate().map(|(s, st)| {
        format!(
            "start {}: {} deg, {} deg/s",
            s + 1,
            pendulum_atlas_core::text::num(st.angle_deg),
            pendulum_atlas_core::text::num(st.rate_deg_s)
        )
    });
    std::iter::once("the cell's representative start".to_string())
        .chain(each)
        .collect()
}

/// Per cell, the attractors its starts reached, from `basin_fraction.npy` and
/// `attractor_start.npy` (labels × grid each).
fn cell_attractors(
    dir: &Path,
    spec: &MapSpec,
    families: &[Family],
) -> Result<Vec<Vec<CellAttractor>>, ExploreError> {
    let labels = families.len();
    let fractions = read_labelled::<f64>(dir, "basin_fraction.npy", spec, labels)?;
    let firsts = read_labelled::<i32>(dir, "attractor_start.npy", spec, labels)?;
    let cells = spec.instances();
    let k = spec.starts_per_cell();
    (0..cells)
        .map(|c| {
            (0..labels)
                .filter(|&l| fractions[l * cells + c] > 0.0)
                .map(|l| {
                    let start = usize::try_from(firsts[l * cells + c])
                        .ok()
                        .filter(|&s| s < k)
                        .ok_or_else(|| {
                            bad(
                                &dir.join("attractor_start.npy"),
                                format!("cell {c} holds label {l} but names no start of the map's {k} that reached it: the files are from different maps"),
                            )
                        })?;
                    Ok(CellAttractor {
                        label: l,
                        name: pendulum_atlas_map::output::map::family_words(&families[l].fingerprint),
                        fraction: fractions[l * cells + c],
                        start,
                    })
                })
                .collect()
        })
        .collect()
}

/// A map that labels attractors: its most likely attractor per cell (`attractor`, a colour
/// per family of `attractors.json`) and, with several starts, the count (`attractors`).
fn attractor_columns(
    dir: &Path,
    spec: &MapSpec,
    families: Option<&[Family]>,
) -> Result<Vec<Column>, ExploreError> {
    let Some(families) = families else {
        return Ok(Vec::new());
    };
    let labels = read_array::<i32>(dir, "attractor.npy", spec)?;
    let several = spec.starts_per_cell() > 1;
    let what = if several {
        "most likely attractor"
    } else {
        "attractor reached"
    };
    let style = attractor_style(what, families);
    let mut out = vec![Column {
        name: "attractor".into(),
        label: style.label,
        palette: style.palette,
        values: labels.iter().map(|&l| shown_label(l)).collect(),
    }];
    if several {
        let count = read_array::<i32>(dir, "attractors.npy", spec)?;
        out.push(Column {
            name: "attractors".into(),
            label: format!(
                "distinct attractors among {} starts",
                spec.starts_per_cell()
            ),
            palette: pendulum_atlas_map::render::Palette::Sequential(None),
            values: count.iter().map(|&n| f64::from(n)).collect(),
        });
    }
    Ok(out)
}

/// The grid of `map_scene.toml` is the grid of `map.json`.
fn check_shape(dir: &Path, spec: &MapSpec, manifest: &MapManifest) -> Result<(), ExploreError> {
    let stated = Some(&manifest.shape[..]);
    if stated != Some(&spec.shape()[..]) {
        return Err(bad(
            &dir.join("map.json"),
            format!(
                "its shape ({}) is not the grid of map_scene.toml ({}): the files are from different maps",
                stated.map_or_else(|| "none given".into(), pendulum_atlas_core::text::shape),
                pendulum_atlas_core::text::shape(&spec.shape())
            ),
        ));
    }
    Ok(())
}

/// An array shaped like the grid.
fn read_array<T: npyz::Deserialize>(
    dir: &Path,
    name: &str,
    spec: &MapSpec,
) -> Result<Vec<T>, ExploreError> {
    read_shaped(dir, name, &spec.shape())
}

/// An array with one value per (label, cell): shape (labels, *grid).
fn read_labelled<T: npyz::Deserialize>(
    dir: &Path,
    name: &str,
    spec: &MapSpec,
    labels: usize,
) -> Result<Vec<T>, ExploreError> {
    let shape: Vec<usize> = std::iter::once(labels).chain(spec.shape()).collect();
    read_shaped(dir, name, &shape)
}

/// The array `name` of `dir`, refused unless its shape is `want`.
fn read_shaped<T: npyz::Deserialize>(
    dir: &Path,
    name: &str,
    want: &[usize],
) -> Result<Vec<T>, ExploreError> {
    let path = dir.join(name);
    if !path.is_file() {
        return Err(ExploreError::MissingFile {
            path: path.display().to_string(),
            hint:
                "map.json lists it: the folder is incomplete (copied in part?); run the map again"
                    .into(),
        });
    }
    let (shape, data) = read_npy::<T>(&path).map_err(|e| bad(&path, e))?;
    if shape != want {
        return Err(bad(
            &path,
            format!(
                "shape {}, this map's is {}: the files are from different maps",
                pendulum_atlas_core::text::shape(&shape),
                pendulum_atlas_core::text::shape(want)
            ),
        ));
    }
    Ok(data)
}
