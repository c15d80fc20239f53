//! The HTTP side: the embedded page and a small JSON API over one map folder.
//!
//! | request                        | answer                                               |
//! |--------------------------------|------------------------------------------------------|
//! | `GET /`, `/app.js`, `/style.css` | the page (embedded in the binary)                  |
//! | `GET /api/map`                 | axes, units, quantities, variants, how it was run     |
//! | `GET /api/field?metric=M&slice=I,J` | quantity M over a slice: values and colours      |
//! | `GET /api/cell/K`              | cell K's axis values, status, quantities, attractors |
//! | `GET /api/cell/K/scene.toml?variant=V` | cell K's scene run as V, as `simulate` takes it |
//! | `POST /api/cell/K/run?variant=V` | queue a run of cell K as V; its job                |
//! | `GET /api/job/J`               | where job J stands, its result when done             |
//! | `POST /api/job/J/cancel`       | stop job J (waiting or running); where it stands     |
//! | `GET /files/NAME`              | a PNG the manifest lists (`bifurcation.png`, ...)    |
//!
//! Every request first checks that the folder is still the one opened (`seal`): `409` once it
//! was replaced or rerun. Every index is checked (`400` with the accepted range), an unknown quantity is `404` with
//! the ones there are, a full queue is `503`. Only files listed in the manifest with a `.png`
//! name are served, looked up by name, so no path reaches outside the folder.

use super::cell::cell_scene;
use super::error::ExploreError;
use super::field::{field, page_shape, slice_index, status_name};
use super::folder::Source;
use super::folder::{Axis, RunFolder};
use super::jobs::Jobs;
use axum::Router;
use axum::extract::{Path, Query, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use pendulum_atlas_map::render::grid_axis;
use serde_json::json;
use std::collections::HashMap;
use std::sync::Arc;

const INDEX_HTML: &str = include_str!("assets/index.html");
const APP_JS: &str = include_str!("assets/app.js");
const STYLE_CSS: &str = include_str!("assets/style.css");

/// What every handler shares.
pub(crate) struct App {
    /// The map folder.
    pub folder: Arc<RunFolder>,
    /// The queue of cell runs.
    pub jobs: Arc<Jobs>,
    /// The folder as opened, checked before every request.
    pub seal: super::seal::Seal,
}

type Shared = State<Arc<App>>;

impl IntoResponse for ExploreError {
    fn into_response(self) -> Response {
        let status = match &self {
            ExploreError::UnknownMetric { .. }
            | ExploreError::UnknownJob(_)
            | ExploreError::NotServed(_) => StatusCode::NOT_FOUND,
            ExploreError::OutOfRange { .. }
            | ExploreError::BadSlice { .. }
            | ExploreError::BadJobId(_) => StatusCode::BAD_REQUEST,
            ExploreError::QueueFull { .. } => StatusCode::SERVICE_UNAVAILABLE,
            ExploreError::Replaced(_) => StatusCode::CONFLICT,
            ExploreError::Cell(_)
            | ExploreError::TooLarge { .. }
            | ExploreError::TooLong { .. }
            | ExploreError::Cancelled(_) => StatusCode::UNPROCESSABLE_ENTITY,
            ExploreError::MissingFile { .. } | ExploreError::BadFile { .. } => {
                StatusCode::INTERNAL_SERVER_ERROR
            }
        };
        (status, axum::Json(json!({ "error": self.to_string() }))).into_response()
    }
}

/// The router of the page and the API.
pub(crate) fn router(app: Arc<App>) -> Router {
    Router::new()
        .route("/", get(|| async { asset("text/html; charset=utf-8", INDEX_HTML) }))
        .route("/app.js", get(|| async { asset("text/javascript; charset=utf-8", APP_JS) }))
        .route("/style.css", get(|| async { asset("text/css; charset=utf-8", STYLE_CSS) }))
        .route("/api/map", get(map_info))
        .route("/api/field", get(field_of))
        .route("/api/cell/{k}", get(cell_info))
        .route("/api/cell/{k}/scene.toml", get(cell_toml))
        .route("/api/cell/{k}/run", post(cell_run))
        .route("/api/job/{j}", get(job))
        .route("/api/job/{j}/cancel", post(job_cancel))
        .route("/files/{name}", get(file))
        .method_not_allowed_fallback(|| async {
            (
                StatusCode::METHOD_NOT_ALLOWED,
                axum::Json(json!({ "error": "wrong method: runs are started with POST, everything else is GET" })),
            )
        })
        .fallback(|| async {
            (
                StatusCode::NOT_FOUND,
                axum::Json(json!({ "error": "no such page: the API is under /api (see `explore`'s help)" })),
            )
        })
        .layer(axum::middleware::from_fn_with_state(app.clone(), unchanged))
        .with_state(app)
}

/// Answer a request only while the folder is the one opened (`seal`).
async fn unchanged(
    State(app): Shared,
    request: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    match app.seal.check() {
        Ok(()) => next.run(request).await,
        Err(e) => e.into_response(),
    }
}

/// An axis as the page draws it, with the PNG maps' own cell edges and ticks
/// ([`grid_axis`]): its `scale` (`linear` or `log`), `edges`, labelled `ticks` (value, label
/// and `at`, the position in cells from the first edge, in log space on a log axis:
/// [`GridAxis::at`]) and the positions of its unlabelled `minor` ticks. The page draws equal
/// cells, so on a log axis of evenly spaced values a tick at `at` is at its place in log.
///
/// [`GridAxis::at`]: pendulum_atlas_map::render::GridAxis::at
fn axis_json(a: &Axis) -> serde_json::Value {
    let grid = grid_axis(&a.values, a.scale);
    let ticks: Vec<_> = grid
        .ticks
        .iter()
        .map(|(value, label)| json!({ "value": value, "label": label, "at": grid.at(*value) }))
        .collect();
    let minor: Vec<f64> = grid.minor.iter().map(|&v| grid.at(v)).collect();
    let scale = if grid.log { "log" } else { "linear" };
    json!({
        "key": a.key, "label": a.label, "values": a.values, "scale": scale,
        "edges": grid.edges, "ticks": ticks, "minor": minor,
    })
}

fn asset(kind: &'static str, body: &'static str) -> Response {
    ([(header::CONTENT_TYPE, kind)], body).into_response()
}

async fn map_info(State(app): Shared) -> Response {
    let f = &app.folder;
    let (nx, ny) = page_shape(f);
    let axes: Vec<_> = f.axes.iter().map(axis_json).collect();
    let metrics: Vec<_> = f
        .columns
        .iter()
        .map(|c| json!({ "name": c.name, "label": c.label }))
        .collect();
    let pictures: Vec<&String> = f.files.iter().filter(|n| n.ends_with(".png")).collect();
    let run = match &f.source {
        Source::Map(_, mm) => json!({
            "segments": f.segments, "method": mm.method, "backend": mm.backend,
            "adapter": mm.adapter, "precision": mm.precision,
        }),
        Source::Calibrate(c) => {
            let e = &c.manifest.about.engine;
            json!({
                "segments": f.segments, "backend": e.kind, "adapter": e.device,
                "precision": e.precision,
            })
        }
        Source::Search(s) => {
            let m = &s.manifest;
            json!({
                "segments": f.segments, "backend": m.backend, "adapter": m.adapter,
                "precision": m.precision,
            })
        }
    };
    axum::Json(json!({
        "kind": f.product.command(),
        "folder": f.dir.display().to_string(),
        "axes": axes,
        "shape": f.shape(),
        "page": { "nx": nx, "ny": ny },
        "metrics": metrics,
        "variants": f.variants,
        "cells": f.cells(),
        "run": run,
        "status_counts": match &f.source {
            Source::Map(_, mm) => json!(mm.status_counts),
            Source::Calibrate(_) | Source::Search(_) => serde_json::Value::Null,
        },
        "bifurcation": pictures.iter().any(|n| n.as_str() == "bifurcation.png"),
        "curves": curves_json(f),
        "pictures": pictures,
        "scalogram_bar": sequential_bar(),
        "cell_limits": {
            "wall_s": app.jobs.limits().wall_s,
            "memory": pendulum_atlas_core::text::bytes(app.jobs.limits().memory_bytes),
        },
    }))
    .into_response()
}

/// The orbit stage's bifurcation curves of a plane (`bifurcations.json`), as the page draws
/// them: each point at its place in cells from the first edges ([`GridAxis::at`], as the
/// ticks), with the PNGs' colour and legend entry; empty for other maps, or where the file
/// cannot be read.
///
/// [`GridAxis::at`]: pendulum_atlas_map::render::GridAxis::at
fn curves_json(f: &RunFolder) -> Vec<serde_json::Value> {
    if f.axes.len() != 2 || !f.files.iter().any(|n| n == "bifurcations.json") {
        return Vec::new();
    }
    std::fs::read_to_string(f.dir.join("bifurcations.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .map_or_else(Vec::new, |file| curves_on_page(&file, &f.axes))
}

/// The curves of a `bifurcations.json` over a plane of `axes`, placed in cells (a curve of
/// a kind the stage does not name is left out).
fn curves_on_page(file: &serde_json::Value, axes: &[Axis]) -> Vec<serde_json::Value> {
    use pendulum_atlas_core::reduce::orbits::BifurcationKind;
    use pendulum_atlas_map::render::curve_style;
    let (gx, gy) = (
        grid_axis(&axes[0].values, axes[0].scale),
        grid_axis(&axes[1].values, axes[1].scale),
    );
    let curves = file["curves"].as_array().cloned().unwrap_or_default();
    curves
        .iter()
        .filter_map(|c| {
            let kind = BifurcationKind::ALL
                .into_iter()
                .find(|k| c["kind"].as_str() == Some(k.name()))?;
            let (colour, label) = curve_style(kind);
            let points: Vec<[f64; 2]> = c["points"]
                .as_array()?
                .iter()
                .filter_map(|p| Some([gx.at(p[0].as_f64()?), gy.at(p[1].as_f64()?)]))
                .collect();
            Some(json!({ "kind": label, "colour": super::field::hex(colour), "points": points }))
        })
        .collect()
}

/// The colour stops of a cell's scalogram (viridis, as its PNG), whatever the map shows.
fn sequential_bar() -> Vec<String> {
    pendulum_atlas_map::render::Palette::Sequential(None)
        .bar(64)
        .into_iter()
        .map(super::field::hex)
        .collect()
}

async fn field_of(
    State(app): Shared,
    Query(q): Query<HashMap<String, String>>,
) -> Result<Response, ExploreError> {
    let f = &app.folder;
    let name = q
        .get("metric")
        .map_or_else(|| f.columns[0].name.clone(), Clone::clone);
    let slice = slice_index(f, q.get("slice").map(String::as_str))?;
    Ok(axum::Json(field(f, &name, &slice)?).into_response())
}

async fn cell_info(State(app): Shared, Path(k): Path<String>) -> Result<Response, ExploreError> {
    let f = &app.folder;
    let k = f.cell(&k)?;
    let values: Vec<(&str, f64)> = f
        .axes
        .iter()
        .zip(f.values_of(k))
        .map(|(a, v)| (a.key.as_str(), v))
        .collect();
    let columns: serde_json::Map<String, serde_json::Value> = f
        .columns
        .iter()
        .map(|c| {
            let v = c.values[k];
            (
                c.name.clone(),
                if v.is_finite() { json!(v) } else { json!(null) },
            )
        })
        .collect();
    Ok(axum::Json(json!({
        "cell": k,
        "index": f.index_of(k),
        "values": values,
        "status": status_name(f.status[k]),
        "inferred": f.inferred.get(k).copied().unwrap_or(false),
        "columns": columns,
        "attractors": f.cell_attractors.get(k),
    }))
    .into_response())
}

async fn cell_toml(
    State(app): Shared,
    Path(k): Path<String>,
    Query(q): Query<HashMap<String, String>>,
) -> Result<Response, ExploreError> {
    let f = app.folder.clone();
    let k = f.cell(&k)?;
    let v = f.variant(q.get("variant").map(String::as_str))?;
    let cs = tokio::task::spawn_blocking(move || cell_scene(&f, k, v))
        .await
        .map_err(|e| ExploreError::Cell(e.to_string()))??;
    let disposition = format!("attachment; filename=\"cell_{k}.toml\"");
    Ok((
        [
            (
                header::CONTENT_TYPE,
                "application/toml; charset=utf-8".to_string(),
            ),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        cs.toml,
    )
        .into_response())
}

async fn cell_run(
    State(app): Shared,
    Path(k): Path<String>,
    Query(q): Query<HashMap<String, String>>,
) -> Result<Response, ExploreError> {
    let k = app.folder.cell(&k)?;
    let v = app.folder.variant(q.get("variant").map(String::as_str))?;
    Ok((StatusCode::ACCEPTED, axum::Json(app.jobs.submit(k, v)?)).into_response())
}

async fn job(State(app): Shared, Path(j): Path<String>) -> Result<Response, ExploreError> {
    Ok(axum::Json(app.jobs.get(job_id(&j)?)?).into_response())
}

async fn job_cancel(State(app): Shared, Path(j): Path<String>) -> Result<Response, ExploreError> {
    Ok(axum::Json(app.jobs.cancel(job_id(&j)?)?).into_response())
}

/// A job id as the API gives them: a whole number.
fn job_id(j: &str) -> Result<u64, ExploreError> {
    j.parse::<u64>()
        .map_err(|_| ExploreError::BadJobId(j.chars().take(40).collect()))
}

async fn file(State(app): Shared, Path(name): Path<String>) -> Result<Response, ExploreError> {
    let folder = app.folder.clone();
    let asked = name.clone();
    let bytes = tokio::task::spawn_blocking(move || folder.read_picture(&asked))
        .await
        .ok()
        .flatten()
        .ok_or(ExploreError::NotServed(name))?;
    Ok(([(header::CONTENT_TYPE, "image/png")], bytes).into_response())
}

#[cfg(test)]
mod tests {
    use super::*;
    use pendulum_atlas_core::config::AxisScale;

    fn axis(values: &[f64], scale: AxisScale) -> serde_json::Value {
        axis_json(&Axis {
            key: "excitation.amplitude_m".into(),
            label: "A (m)".into(),
            values: values.to_vec(),
            scale,
        })
    }

    #[test]
    fn a_bifurcation_curve_reaches_the_page_in_cells_with_the_pictures_colour() {
        let axes = [
            Axis {
                key: "excitation.frequency_hz".into(),
                label: "f (Hz)".into(),
                values: vec![4.0, 5.0, 6.0],
                scale: AxisScale::Linear,
            },
            Axis {
                key: "excitation.amplitude_m".into(),
                label: "A (m)".into(),
                values: vec![0.001, 0.002],
                scale: AxisScale::Linear,
            },
        ];
        let file = json!({ "curves": [
            { "kind": "period_doubling", "points": [[4.5, 0.0015], [5.0, 0.002]] },
            { "kind": "no_such_kind", "points": [[4.5, 0.0015]] },
        ]});
        let curves = curves_on_page(&file, &axes);
        assert_eq!(curves.len(), 1, "{curves:?}");
        assert_eq!(curves[0]["kind"], "period doubling");
        assert_eq!(curves[0]["colour"], "#000000");
        let points: Vec<[f64; 2]> = serde_json::from_value(curves[0]["points"].clone()).unwrap();
        let close =
            |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12;
        assert!(
            close(points[0], [1.0, 1.0]) && close(points[1], [1.5, 1.5]),
            "{points:?}"
        );
    }

    #[test]
    fn a_log_axis_reaches_the_page_with_geometric_edges_and_decade_ticks_at_their_log_place() {
        let a = axis(&[0.001, 0.01, 0.1, 1.0], AxisScale::Log);
        assert_eq!(a["scale"], "log");
        let edges: Vec<f64> = serde_json::from_value(a["edges"].clone()).unwrap();
        assert!(edges.iter().all(|&e| e > 0.0), "{edges:?}");
        assert!((edges[1] - (0.001f64 * 0.01).sqrt()).abs() < 1e-15);
        let ticks = a["ticks"].as_array().unwrap();
        let labels: Vec<&str> = ticks.iter().map(|t| t["label"].as_str().unwrap()).collect();
        assert_eq!(labels, ["0.001", "0.01", "0.1", "1"]);
        // Each decade is the centre of its cell: half a cell past the previous one.
        for (k, t) in ticks.iter().enumerate() {
            let at = t["at"].as_f64().unwrap();
            assert!((at - (k as f64 + 0.5)).abs() < 1e-9, "{t}");
        }
        let minor = a["minor"].as_array().unwrap();
        assert!(
            !minor.is_empty()
                && minor
                    .iter()
                    .all(|m| (0.0..=4.0).contains(&m.as_f64().unwrap()))
        );
    }

    #[test]
    fn a_linear_axis_reaches_the_page_with_midpoint_edges_and_linear_tick_places() {
        let a = axis(&[5.0, 6.0, 7.0, 8.0], AxisScale::Linear);
        assert_eq!(a["scale"], "linear");
        assert_eq!(a["edges"], json!([4.5, 5.5, 6.5, 7.5, 8.5]));
        let ticks = a["ticks"].as_array().unwrap();
        let six = ticks.iter().find(|t| t["value"] == 6.0).unwrap();
        assert_eq!(six, &json!({ "value": 6.0, "label": "6", "at": 1.5 }));
        assert_eq!(a["minor"], json!([]));
    }
}
