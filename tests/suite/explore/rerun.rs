//! A map cell run again gives the map's numbers (issue 61): on every cell of a small plane
//! mapped on the CPU engine in f64, at adaptive and at fixed steps, the explorer's rerun and
//! `simulate` on the cell's downloaded scene give each of the cell's stored values bit for
//! bit (the regime and status by name; the verdict's confidence, which needs the neighbours,
//! is not rerun).

use super::{Server, bin, cpu_map, json, npy, request, scratch, small_map, wait_job};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_core::schema::Regime;
use serde_json::{Map, Value};
use std::path::Path;

/// A stored code array (`regime.npy`, `status.npy`) as whole numbers.
fn codes(dir: &Path, stem: &str) -> Vec<i64> {
    let bytes = std::fs::read(dir.join(format!("{stem}.npy"))).unwrap();
    let file = npyz::NpyFile::new(&bytes[..]).unwrap();
    match file.dtype().descr().trim_matches('\'') {
        "|i1" => file
            .into_vec::<i8>()
            .unwrap()
            .into_iter()
            .map(i64::from)
            .collect(),
        "|u1" => file
            .into_vec::<u8>()
            .unwrap()
            .into_iter()
            .map(i64::from)
            .collect(),
        other => panic!("{stem}.npy: dtype {other}"),
    }
}

/// Each of `values` (a cell's values by name, as `run.json`'s `map_cell` holds them) is the
/// map's stored value of cell `k`.
fn holds_the_maps_values(dir: &Path, k: usize, values: &Map<String, Value>, who: &str) {
    assert!(
        values.contains_key("K") && values.contains_key("period"),
        "{who}: {values:?}"
    );
    for (name, v) in values {
        match name.as_str() {
            "regime" => {
                let want = Regime::from_code(codes(dir, "regime")[k]).unwrap().name();
                assert_eq!(v.as_str(), Some(want), "{who}: cell {k} regime");
            }
            "status" => {
                let want = Status::from_code(codes(dir, "status")[k] as u32)
                    .unwrap()
                    .as_str();
                assert_eq!(v.as_str(), Some(want), "{who}: cell {k} status");
            }
            "ran_on" => {
                let want = codes(dir, "ran_on")[k];
                assert_eq!(v.as_f64(), Some(want as f64), "{who}: cell {k} ran_on");
            }
            _ => {
                let want = npy(dir, name)[k];
                let got = v.as_f64().unwrap_or(f64::NAN);
                assert!(
                    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "{who}: cell {k} {name}: {got} rerun, {want} in the map"
                );
            }
        }
    }
}

/// Every cell of the map in `dir`, rerun by the explorer and by `simulate` on its scene.
fn every_cell_reruns_as_its_map(dir: &Path, tag: &str) {
    let manifest: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("map.json")).unwrap()).unwrap();
    assert_eq!(
        manifest["precision"], "f64",
        "a map of the CPU engine in f64"
    );
    let s = Server::start(dir, &[]);
    let cells = json(&s, "GET", "/api/map", 200)["cells"].as_u64().unwrap() as usize;
    let work = scratch(&format!("rerun-{tag}"));
    std::fs::create_dir_all(&work).unwrap();
    for k in 0..cells {
        let job = json(&s, "POST", &format!("/api/cell/{k}/run"), 202);
        let done = wait_job(&s, job["job"].as_u64().unwrap());
        assert_eq!(done["state"], "done", "{done}");
        let rerun = done["result"]["rerun"].as_object().unwrap();
        holds_the_maps_values(dir, k, rerun, "explore");
        let (status, toml) = request(&s, "GET", &format!("/api/cell/{k}/scene.toml"));
        assert_eq!(status, 200, "{toml}");
        let scene = work.join(format!("cell_{k}.toml"));
        std::fs::write(&scene, toml).unwrap();
        let out = work.join(format!("sim_{k}"));
        let o = bin()
            .arg("simulate")
            .arg(&scene)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(err.contains("as its map computes this cell"), "{err}");
        let run: Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
        let values = run["map_cell"]["values"].as_object().unwrap();
        holds_the_maps_values(dir, k, values, "simulate");
    }
    let _ = std::fs::remove_dir_all(&work);
}

#[test]
fn every_cell_of_an_adaptive_map_reruns_as_its_map() {
    // Cells whose nudged copies ran are among them (the rerun must run them too).
    let copies = npy(small_map(), "start_sensitivity");
    assert!(copies.iter().any(|s| s.is_finite()), "no cell ran copies");
    every_cell_reruns_as_its_map(small_map(), "adaptive");
}

#[test]
fn every_cell_of_a_fixed_step_map_reruns_as_its_map() {
    let out = cpu_map(
        "fixed-map",
        &[
            "map.axes=[{key=\"excitation.frequency_hz\",start=6.0,end=10.0,count=3},\
             {key=\"excitation.amplitude_m\",start=0.008,end=0.02,count=2}]",
            "integration.duration_s=24.0",
            "integration.transient_s=4.0",
            "integration.dt_s=2e-4",
        ],
    );
    let manifest: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
    assert!(
        manifest["steps"]["sub_steps_tried"].is_null(),
        "a fixed-step map: {manifest}"
    );
    every_cell_reruns_as_its_map(&out, "fixed");
}
