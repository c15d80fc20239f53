//! `explore` on the folders of `calibrate` and `search`: the grid of the unknowns or of the
//! design variables, the quantities of their CSV files, and a cell run in a case (or at a
//! frequency from an initial state) that is what `simulate` gives on the downloaded scene.

use super::{Server, bin, json, request, scratch, simulate, wait_job};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A calibration over a 3 × 2 grid (clearance × contact arc) in two cases, N = 3, short runs.
const CALIBRATION: &str = r#"
[beam]
segments = 3
[integration]
duration_s = 22.0
transient_s = 2.0
[calibrate]
initial_states = 1
phase_convention = "standard"
refine = { rounds = 0, top = 1, shrink = 0.5 }
[[calibrate.unknowns]]
key = "limiter.clearance_deg"
values = [10.0, 15.0, 20.0]
[[calibrate.unknowns]]
key = "limiter.contact_arc_m"
values = [0.1, 0.3]
[[calibrate.cases]]
name = "8 Hz"
set = { "excitation.frequency_hz" = 8.0, "excitation.amplitude_m" = 0.009 }
k_class = "chaotic"
r = { value = 0.1, tol = 0.2 }
[[calibrate.cases]]
name = "5 Hz"
set = { "excitation.frequency_hz" = 5.0, "excitation.amplitude_m" = 0.012 }
hops = true
"#;

fn calibration() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let work = scratch("calibration");
        std::fs::create_dir_all(&work).unwrap();
        let scene = work.join("calibration.toml");
        std::fs::write(&scene, CALIBRATION).unwrap();
        let out = work.join("out");
        let o = bin()
            .arg("calibrate")
            .arg(&scene)
            .args(["--backend", "cpu", "--quiet", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    })
}

fn search() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let out = scratch("search");
        let o = bin()
            .args(["search", "--backend", "cpu", "--quiet", "--out"])
            .arg(&out)
            .args([
                "--set",
                "integration.duration_s=8.0",
                "--set",
                "integration.transient_s=4.0",
                "--set",
                "search.band={start_hz=6.0,end_hz=26.0,count=3,base_acceleration_m_s2=2.0}",
                "--set",
                "search.variables=[{key=\"limiter.clearance_deg\",values=[5.0,10.0]},{key=\"tip.mass_kg\",values=[0.0,0.01]}]",
                "--set",
                "search.refine={rounds=0,top=1,shrink=0.5}",
                "--set",
                "search.baseline.zoom_count=3",
                "--set",
                "search.verify=false",
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    })
}

/// Run cell `k` as `variant`, check it against `simulate` on its downloaded scene; the result.
fn run_and_check(s: &Server, k: usize, variant: usize, tag: &str) -> serde_json::Value {
    let job = json(
        s,
        "POST",
        &format!("/api/cell/{k}/run?variant={variant}"),
        202,
    );
    let done = wait_job(s, job["job"].as_u64().unwrap());
    assert_eq!(done["state"], "done", "{done}");
    let r = done["result"].clone();
    let (st, toml) = request(
        s,
        "GET",
        &format!("/api/cell/{k}/scene.toml?variant={variant}"),
    );
    assert_eq!(st, 200, "{toml}");
    let work = scratch(tag);
    std::fs::create_dir_all(&work).unwrap();
    std::fs::write(work.join("cell.toml"), &toml).unwrap();
    let (sk, sr, sp) = simulate(&work.join("cell.toml"), &work.join("sim"));
    assert_eq!(r["simulated"]["K"].as_f64(), sk, "{tag}");
    assert_eq!(r["simulated"]["R"].as_f64(), sr, "{tag}");
    assert_eq!(r["simulated"]["period"].as_f64(), sp, "{tag}");
    assert!(sr.is_some(), "{tag}: R of the run");
    r
}

#[test]
fn a_calibration_is_its_grid_of_unknowns_and_a_cell_runs_in_a_case() {
    let dir = calibration();
    let s = Server::start(dir, &[]);
    let m = json(&s, "GET", "/api/map", 200);
    assert_eq!(m["kind"], "calibrate");
    assert_eq!(m["shape"], serde_json::json!([3, 2]));
    assert_eq!(m["variants"], serde_json::json!(["8 Hz", "5 Hz"]));
    // The matched counts are the grid rows of candidates.csv.
    let f = json(&s, "GET", "/api/field?metric=matched", 200);
    assert_eq!(f["range"], serde_json::json!([0.0, 3.0]));
    let csv = std::fs::read_to_string(dir.join("candidates.csv")).unwrap();
    for line in csv.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        let (clearance, arc, matched): (f64, f64, f64) = (
            cols[2].parse().unwrap(),
            cols[3].parse().unwrap(),
            cols[4].parse().unwrap(),
        );
        let k = [10.0, 15.0, 20.0]
            .iter()
            .position(|&c| c == clearance)
            .unwrap()
            * 2
            + [0.1, 0.3].iter().position(|&a| a == arc).unwrap();
        let at = f["cells"]
            .as_array()
            .unwrap()
            .iter()
            .position(|c| c == k)
            .unwrap();
        assert_eq!(f["values"][at].as_f64(), Some(matched), "{line}");
    }
    json(&s, "GET", "/api/field?metric=matched:%205%20Hz", 200);
    let e = json(&s, "POST", "/api/cell/0/run?variant=2", 400)["error"].to_string();
    assert!(e.contains("0 to 1"), "{e}");
    // Cell 3 = clearance 15, arc 0.3, run in the 5 Hz case.
    let r = run_and_check(&s, 3, 1, "calibration-cell");
    assert_eq!(r["variant"], "5 Hz");
    let notes = r["notes"].to_string();
    assert!(
        notes.contains("hops"),
        "the case's observation is reported: {notes}"
    );
    assert!(r["map"].as_object().unwrap().is_empty());
    let (_, toml) = request(&s, "GET", "/api/cell/3/scene.toml?variant=1");
    assert!(
        toml.contains("clearance_deg = 15.0") && toml.contains("frequency_hz = 5.0"),
        "{toml}"
    );
}

#[test]
fn a_search_is_its_grid_of_designs_and_a_cell_runs_at_a_frequency() {
    let dir = search();
    let s = Server::start(dir, &[]);
    let m = json(&s, "GET", "/api/map", 200);
    assert_eq!(m["kind"], "search");
    assert_eq!(m["shape"], serde_json::json!([2, 2]));
    let variants = m["variants"].as_array().unwrap();
    assert_eq!(
        variants.len(),
        3 * 2,
        "3 frequencies × 2 initial states: {variants:?}"
    );
    let f = json(&s, "GET", "/api/field?metric=bandwidth_robust_hz", 200);
    assert!(
        f["values"]
            .as_array()
            .unwrap()
            .iter()
            .all(|v| v.is_number()),
        "{f}"
    );
    // Variant 4: the second initial state at the second frequency (16 Hz).
    let r = run_and_check(&s, 1, 4, "search-cell");
    assert!(
        r["variant"].as_str().unwrap().starts_with("16 Hz"),
        "{}",
        r["variant"]
    );
    let notes = r["notes"].to_string();
    assert!(
        notes.contains("power"),
        "the search's power there is reported: {notes}"
    );
}

#[test]
fn a_calibration_without_its_scene_is_refused() {
    let d = scratch("calibration-no-scene");
    std::fs::create_dir_all(&d).unwrap();
    for e in std::fs::read_dir(calibration()).unwrap() {
        let e = e.unwrap();
        if e.file_name() != "calibrate_scene.toml" {
            std::fs::copy(e.path(), d.join(e.file_name())).unwrap();
        }
    }
    super::api::refused(&d, &[], "calibrate_scene.toml");
}
