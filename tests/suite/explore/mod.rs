//! `explore`: the API on a small map (every request checked), on calibration and search
//! folders, and the page driven in a real browser through WebDriver.

mod api;
mod browser;
mod folders;
mod rerun;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;

pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
}

pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "pendulum-atlas-explore-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// A 6 × 4 map of the default scene (N = 3, short runs) on the CPU, made once per test run.
pub fn small_map() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        cpu_map(
            "map",
            &[
                "map.axes=[{key=\"excitation.frequency_hz\",start=5.0,end=10.0,count=6},\
                 {key=\"excitation.amplitude_m\",start=0.006,end=0.02,count=4}]",
                "integration.duration_s=24.0",
                "integration.transient_s=4.0",
            ],
        )
    })
}

/// A map of the default scene with `sets` on the CPU engine (its default precision, f64),
/// in the scratch folder `name`.
pub fn cpu_map(name: &str, sets: &[&str]) -> PathBuf {
    let out = scratch(name);
    let mut cmd = bin();
    cmd.args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// A running `explore` server, stopped when dropped.
pub struct Server {
    child: Child,
    /// `http://127.0.0.1:PORT` (no trailing slash).
    pub url: String,
}

impl Server {
    /// Serve `dir` on a free port with `extra` options; waits for the address line.
    pub fn start(dir: &Path, extra: &[&str]) -> Server {
        let mut child = bin()
            .arg("explore")
            .arg(dir)
            .args(["--port", "0"])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let url = line
            .split_whitespace()
            .find(|w| w.starts_with("http://"))
            .unwrap_or_else(|| panic!("no address in `{line}`"))
            .trim_end_matches('/')
            .to_string();
        Server { child, url }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// GET or POST `path` of `server`: the status and the body as text.
pub fn request(server: &Server, method: &str, path: &str) -> (u16, String) {
    let (status, body) = fetch(server, method, path);
    (status, String::from_utf8_lossy(&body).into_owned())
}

/// GET or POST `path` of `server`: the status and the body's bytes.
pub fn fetch(server: &Server, method: &str, path: &str) -> (u16, Vec<u8>) {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .http_status_as_error(false)
        .build()
        .into();
    let url = format!("{}{path}", server.url);
    let mut r = match method {
        "POST" => agent.post(&url).send_empty(),
        _ => agent.get(&url).call(),
    }
    .unwrap_or_else(|e| panic!("{method} {url}: {e}"));
    let status = r.status().as_u16();
    (status, r.body_mut().read_to_vec().unwrap())
}

/// The JSON body of a request that must answer `want`.
pub fn json(server: &Server, method: &str, path: &str, want: u16) -> serde_json::Value {
    let (status, body) = request(server, method, path);
    assert_eq!(status, want, "{method} {path}: {body}");
    serde_json::from_str(&body).unwrap_or_else(|e| panic!("{path}: not JSON ({e}): {body}"))
}

/// Wait for job `id` to finish; its final state.
pub fn wait_job(server: &Server, id: u64) -> serde_json::Value {
    for _ in 0..1200 {
        let j = json(server, "GET", &format!("/api/job/{id}"), 200);
        if j["state"] == "done" || j["state"] == "failed" {
            return j;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    panic!("job {id} did not finish in 120 s");
}

/// K, R and period of `simulate` on a scene file (its run.json's analysis; `None` where it
/// skipped one).
pub fn simulate(scene: &Path, out: &Path) -> (Option<f64>, Option<f64>, Option<f64>) {
    let o = bin()
        .arg("simulate")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .arg("--force")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    let a = &run["analysis"];
    (
        a["zero_one"]["K"].as_f64(),
        a["phase_sync"]["R"].as_f64(),
        a["statistics"]["period"].as_f64(),
    )
}

/// The stored metric array `stem.npy` of a map folder, in C order.
pub fn npy(dir: &Path, stem: &str) -> Vec<f64> {
    let bytes = std::fs::read(dir.join(format!("{stem}.npy"))).unwrap();
    npyz::NpyFile::new(&bytes[..]).unwrap().into_vec().unwrap()
}
