//! The API: every answer checked against the map's own files, every bad request answered with
//! its status and a message naming the accepted range, and bad folders refused at start.

use super::{Server, bin, fetch, json, npy, request, scratch, simulate, small_map, wait_job};
use pendulum_atlas_map::render::{Palette, cell_colour, colour_range};
use std::path::Path;
use std::time::{Duration, Instant};

#[test]
fn the_map_and_its_fields_are_the_files_of_the_folder() {
    let dir = small_map();
    let s = Server::start(dir, &[]);
    let m = json(&s, "GET", "/api/map", 200);
    assert_eq!(m["shape"], serde_json::json!([6, 4]));
    assert_eq!(m["cells"], 24);
    assert_eq!(m["axes"][0]["key"], "excitation.frequency_hz");
    let names: Vec<&str> = m["metrics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "regime",
            "verdict_confidence",
            "K",
            "R",
            "period",
            "hops",
            "impacts_per_s",
            "alpha_range",
            "lyapunov",
            "start_sensitivity",
            "transient_s"
        ]
    );
    // The verdict first, with its confidence as stored (NaN where undecided, shown as null).
    let conf = npy(dir, "verdict_confidence");
    let c = json(&s, "GET", "/api/field?metric=verdict_confidence", 200);
    let cells: Vec<usize> = serde_json::from_value(c["cells"].clone()).unwrap();
    for (at, &cell) in cells.iter().enumerate() {
        let want = conf[cell];
        match c["values"][at].as_f64() {
            Some(v) => assert_eq!(v, want, "confidence of cell {cell}"),
            None => assert!(want.is_nan(), "cell {cell}: {want} shown as no data"),
        }
    }
    assert_eq!(c["range"], serde_json::json!([0.0, 1.0]));
    // Its values are the confidence stage's, counted again over this 6 × 4 map's neighbours.
    let (_, codes) =
        pendulum_atlas_map::output::npy::read_npy::<i8>(&dir.join("regime.npy")).unwrap();
    crate::map::check_verdict_confidence(dir, &codes, (6, 4));
    // The transient stage's marks on the regime: a hatch bit where the start decides, a dot
    // bit where a periodic verdict follows a chaotic transient, as the files say.
    let (s_, tau) = (npy(dir, "start_sensitivity"), npy(dir, "transient_s"));
    let r = json(&s, "GET", "/api/field?metric=regime", 200);
    let cells: Vec<usize> = serde_json::from_value(r["cells"].clone()).unwrap();
    let marks: Vec<u8> = serde_json::from_value(r["marks"].clone()).unwrap();
    assert_eq!(marks.len(), cells.len());
    for (at, &cell) in cells.iter().enumerate() {
        let decides = s_[cell] > 0.0;
        let after = tau[cell].is_finite() && codes[cell] == 1;
        assert_eq!(
            marks[at],
            u8::from(decides) | (u8::from(after) << 1),
            "cell {cell}"
        );
    }
    let k_field = json(&s, "GET", "/api/field?metric=K", 200);
    assert_eq!(
        k_field["marks"],
        serde_json::json!([]),
        "marks on the verdict only"
    );

    let k = npy(dir, "K");
    let f = json(&s, "GET", "/api/field?metric=K", 200);
    assert_eq!((f["nx"].as_u64(), f["ny"].as_u64()), (Some(6), Some(4)));
    let cells: Vec<usize> = serde_json::from_value(f["cells"].clone()).unwrap();
    // Page cell (ix, iy) at iy*nx + ix is grid cell ix*ny + iy (C order, 2-D).
    for iy in 0..4 {
        for ix in 0..6 {
            let at = iy * 6 + ix;
            assert_eq!(cells[at], ix * 4 + iy);
            assert_eq!(f["values"][at].as_f64(), Some(k[cells[at]]), "cell {at}");
            let c = cell_colour(k[cells[at]], false, (0.0, 1.0));
            let hex = format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2);
            assert_eq!(f["colours"][at], hex.as_str(), "colour of cell {at}");
        }
    }
    // A metric without fixed range is coloured over its own values, as its PNG is.
    let hops = npy(dir, "hops");
    let h = json(&s, "GET", "/api/field?metric=hops", 200);
    let (lo, hi) = colour_range(&hops, &[], None);
    assert_eq!(h["range"], serde_json::json!([lo, hi]));
    // alpha_range is the difference of two stored arrays.
    let (amin, amax) = (npy(dir, "alpha_min_rad"), npy(dir, "alpha_max_rad"));
    let a = json(&s, "GET", "/api/field?metric=alpha_range", 200);
    assert_eq!(a["values"][0].as_f64(), Some(amax[0] - amin[0]));

    // λ1 on blue-white-red symmetric about 0, as lyapunov.png.
    let lambda = npy(dir, "lyapunov");
    let l = json(&s, "GET", "/api/field?metric=lyapunov", 200);
    let diverging = Palette::Diverging(None);
    let range = diverging.range(&lambda, &[]);
    assert_eq!(l["range"], serde_json::json!([range.0, range.1]));
    assert_eq!(range.0, -range.1);
    let at = 7;
    let c = diverging.colour(lambda[cells[at]], false, range);
    assert_eq!(
        l["colours"][at],
        format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
    );
    // The regime in categories named in the legend (no colour bar), periodic cells in the
    // shade of their period, and the codes of regime.npy.
    let r = json(&s, "GET", "/api/field?metric=regime", 200);
    assert_eq!(r["bar"], serde_json::json!([]));
    let (_, codes) =
        pendulum_atlas_map::output::npy::read_npy::<i8>(&dir.join("regime.npy")).unwrap();
    let period = npy(dir, "period");
    let names: Vec<String> = r["categories"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c[1].as_str().unwrap().to_string())
        .collect();
    assert!(!names.is_empty());
    for at in 0..24 {
        let k = cells[at];
        let want = match codes[k] {
            1 => 10.0 + period[k],
            c => f64::from(c),
        };
        assert_eq!(r["values"][at].as_f64(), Some(want), "cell {k}");
    }
    if codes.contains(&3) {
        assert!(names.contains(&"chaotic".to_string()), "{names:?}");
    }

    let c = json(&s, "GET", "/api/cell/5", 200);
    // Cell 5 = (ix 1, iy 1): the second value of each axis, in axis order.
    let second = |i: usize| m["axes"][i]["values"][1].clone();
    assert_eq!(
        c["values"],
        serde_json::json!([
            ["excitation.frequency_hz", second(0)],
            ["excitation.amplitude_m", second(1)]
        ])
    );
    assert_eq!(second(0), 6.0);
    assert_eq!(c["columns"]["K"].as_f64(), Some(k[5]));
    assert_eq!(c["status"], "ok");
    let (status, png) = fetch(&s, "GET", "/files/K.png");
    assert_eq!(status, 200);
    assert_eq!(
        png,
        std::fs::read(dir.join("K.png")).unwrap(),
        "K.png served whole"
    );
    let (status, page) = request(&s, "GET", "/");
    assert_eq!(status, 200);
    assert!(page.contains("<canvas id=\"map\""), "{page}");
}

#[test]
fn bad_requests_get_their_status_and_the_accepted_range() {
    let s = Server::start(small_map(), &[]);
    let err = |method: &str, path: &str, want: u16| {
        json(&s, method, path, want)["error"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let e = err("GET", "/api/field?metric=lyapunov_exponent", 404);
    assert!(
        e.contains("lyapunov_exponent") && e.contains("K, R, period"),
        "{e}"
    );
    let e = err("GET", "/api/field?metric=K&slice=1", 400);
    assert!(e.contains("slice") && e.contains("has 0 such axes"), "{e}");
    let e = err("POST", "/api/cell/3/run?variant=1", 400);
    assert!(e.contains("variant") && e.contains("0 to 0"), "{e}");
    for bad in ["24", "-1", "abc", "1e3", "99999999999999999999999"] {
        let e = err("GET", &format!("/api/cell/{bad}"), 400);
        assert!(e.contains("0 to 23"), "{bad}: {e}");
        let e = err("POST", &format!("/api/cell/{bad}/run"), 400);
        assert!(e.contains("0 to 23"), "{bad}: {e}");
        err("GET", &format!("/api/cell/{bad}/scene.toml"), 400);
    }
    let e = err("GET", "/api/job/4242", 404);
    assert!(e.contains("4242"), "{e}");
    err("GET", "/api/job/x", 400);
    let e = err("GET", "/api/cell/3/run", 405);
    assert!(e.contains("POST"), "{e}");
    // Only the map's pictures are served, looked up by name.
    for bad in [
        "..%2Fmap.json",
        "map.json",
        "grid.csv",
        "map_scene.toml",
        "..%2F..%2Fetc%2Fpasswd",
        "nope.png",
    ] {
        let e = err("GET", &format!("/files/{bad}"), 404);
        assert!(e.contains("not a picture of this map"), "{bad}: {e}");
    }
    err("GET", "/etc/passwd", 404);
    err("GET", "/files/../../etc/passwd", 404);
}

#[test]
fn a_cell_run_is_what_simulate_gives_on_the_cell_scene() {
    let dir = small_map();
    let s = Server::start(dir, &[]);
    let cell = 9;
    let job = json(&s, "POST", &format!("/api/cell/{cell}/run"), 202);
    let again = json(&s, "POST", &format!("/api/cell/{cell}/run"), 202);
    assert_eq!(job["job"], again["job"], "a cell asked twice is one job");
    let done = wait_job(&s, job["job"].as_u64().unwrap());
    assert_eq!(done["state"], "done", "{done}");
    let r = &done["result"];
    assert_eq!(r["status"], "ok");
    assert_eq!(r["map"]["K"].as_f64(), Some(npy(dir, "K")[cell]));
    for curve in ["alpha", "cart", "phase", "strobe", "spectrum"] {
        let n = r[curve]["x"].as_array().unwrap().len();
        assert!(n > 10, "{curve}: {n} points");
        assert_eq!(n, r[curve]["y"].as_array().unwrap().len(), "{curve}");
    }
    assert!(!r["scalogram"]["log2_power"].as_array().unwrap().is_empty());

    let (status, toml) = request(&s, "GET", &format!("/api/cell/{cell}/scene.toml"));
    assert_eq!(status, 200);
    let work = scratch("cell-run");
    std::fs::create_dir_all(&work).unwrap();
    let scene = work.join("cell.toml");
    std::fs::write(&scene, toml).unwrap();
    let (k, rr, period) = simulate(&scene, &work.join("sim"));
    assert_eq!(r["simulated"]["K"].as_f64(), k);
    assert_eq!(r["simulated"]["R"].as_f64(), rr);
    assert_eq!(r["simulated"]["period"].as_f64(), period);
    // The cell's scene has the map's step: the map's K within the spread of K itself, unless
    // the map ran the cell on (settling); the run as the map computes it is the map's K.
    let k = k.expect("K of a 20-s run after the transient");
    let ran_on: Vec<u8> = npyz::NpyFile::new(&std::fs::read(dir.join("ran_on.npy")).unwrap()[..])
        .unwrap()
        .into_vec()
        .unwrap();
    if ran_on[cell] == 0 {
        assert!(
            (k - npy(dir, "K")[cell]).abs() < 0.2,
            "K {k} vs map {}",
            npy(dir, "K")[cell]
        );
    }
    assert_eq!(r["rerun"]["K"].as_f64(), Some(npy(dir, "K")[cell]));
}

#[test]
fn a_full_queue_refuses_more_cells_and_the_server_keeps_answering() {
    let s = Server::start(small_map(), &["--workers", "1", "--queue", "2"]);
    let answers: Vec<(u16, String)> = (0..12)
        .map(|k| request(&s, "POST", &format!("/api/cell/{k}/run")))
        .collect();
    let refused: Vec<&String> = answers
        .iter()
        .filter(|a| a.0 == 503)
        .map(|a| &a.1)
        .collect();
    assert!(
        !refused.is_empty(),
        "12 clicks on a queue of 2 must be refused in part"
    );
    assert!(refused[0].contains("try again"), "{}", refused[0]);
    let accepted: Vec<u64> = answers
        .iter()
        .filter(|a| a.0 == 202)
        .map(|a| {
            serde_json::from_str::<serde_json::Value>(&a.1).unwrap()["job"]
                .as_u64()
                .unwrap()
        })
        .collect();
    assert!(
        accepted.len() <= 3,
        "1 running + 2 waiting at most, got {}",
        accepted.len()
    );
    json(&s, "GET", "/api/map", 200);
    for id in accepted {
        assert_eq!(wait_job(&s, id)["state"], "done");
    }
    // Room again once the queue has drained.
    json(&s, "POST", "/api/cell/20/run", 202);
}

/// `explore` on `dir` must exit with status 2 and a message containing `want`.
pub fn refused(dir: &Path, extra: &[&str], want: &str) {
    let mut child = bin()
        .arg("explore")
        .arg(dir)
        .args(["--port", "0"])
        .args(extra)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if started.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!(
                "explore {} {extra:?} served instead of refusing",
                dir.display()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(2), "{err}");
    assert!(err.contains(want), "wanted `{want}` in: {err}");
}

fn copy_without(name: &str, missing: &str) -> std::path::PathBuf {
    let d = scratch(name);
    std::fs::create_dir_all(&d).unwrap();
    for e in std::fs::read_dir(small_map()).unwrap() {
        let e = e.unwrap();
        if e.file_name() != missing {
            std::fs::copy(e.path(), d.join(e.file_name())).unwrap();
        }
    }
    d
}

#[test]
fn a_folder_that_is_not_a_complete_map_is_refused_at_start() {
    refused(&copy_without("no-status", "status.npy"), &[], "status.npy");
    refused(&copy_without("no-k", "K.npy"), &[], "K.npy");
    refused(
        &copy_without("no-scene", "map_scene.toml"),
        &[],
        "map_scene.toml",
    );
    refused(
        &copy_without("no-manifest", "map.json"),
        &[],
        "not a finished map folder",
    );
    // A `--force` run killed outright: the earlier map set aside whole, nothing in its place
    // yet; explore says where it is and that the next run puts it back (issue 71).
    let killed = scratch("killed-force");
    let aside = killed.join(".pendulum-atlas.earlier");
    std::fs::create_dir_all(&aside).unwrap();
    for e in std::fs::read_dir(small_map()).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), aside.join(e.file_name())).unwrap();
    }
    refused(&killed, &[], "set aside in");
    refused(&killed, &[], "the next run into this folder puts it back");
    let other = copy_without("other-shape", "");
    let text = std::fs::read_to_string(other.join("map_scene.toml")).unwrap();
    std::fs::write(
        other.join("map_scene.toml"),
        text.replace("count = 4", "count = 5"),
    )
    .unwrap();
    refused(&other, &[], "different maps");
    refused(&scratch("nowhere"), &[], "finished `pendulum-atlas map`");
    // map.json is read by the type the command writes it with: a damaged one, or one that
    // lists a path out of the folder, is refused in words.
    let damaged = copy_without("damaged-manifest", "");
    let text = std::fs::read_to_string(damaged.join("map.json")).unwrap();
    std::fs::write(damaged.join("map.json"), &text[..text.len() / 2]).unwrap();
    refused(&damaged, &[], "is not complete JSON");
    let foreign = copy_without("foreign-manifest", "");
    let text = std::fs::read_to_string(foreign.join("map.json")).unwrap();
    std::fs::write(
        foreign.join("map.json"),
        text.replace("\"K.npy\"", "\"../../K.npy\""),
    )
    .unwrap();
    refused(&foreign, &[], "which is not a file name of its folder");
    refused(small_map(), &["--workers", "0"], "--workers 0: give 1 to");
    refused(small_map(), &["--queue", "0"], "--queue 0: give 1 to 1000");
}

#[test]
fn the_folder_of_another_command_is_named() {
    let d = scratch("simulate");
    let o = bin()
        .args([
            "simulate",
            "--set",
            "integration.duration_s=2",
            "--set",
            "integration.transient_s=1",
            "--out",
        ])
        .arg(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    refused(&d, &[], "`pendulum-atlas simulate`");
}

/// The listed pictures of the small map other than `K.png` and `R.png`, sorted.
fn other_pictures(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png") && n != "K.png" && n != "R.png")
        .collect();
    names.sort();
    names
}

/// A listed picture replaced by a symlink, a hard link to a file outside the folder, or a
/// FIFO is never served: the file is opened without following links or blocking, and its
/// handle checked (a regular file with one name).
#[test]
fn a_listed_picture_that_is_a_link_or_a_fifo_is_not_served() {
    let dir = scratch("linked_map");
    std::fs::create_dir_all(&dir).unwrap();
    for entry in std::fs::read_dir(small_map()).unwrap() {
        let p = entry.unwrap().path();
        std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
    }
    // K.png (listed in map.json) now points at a file outside the run folder.
    let secret = scratch("secret");
    std::fs::create_dir_all(&secret).unwrap();
    let outside = secret.join("secret.png");
    std::fs::write(&outside, b"not for the browser").unwrap();
    std::fs::remove_file(dir.join("K.png")).unwrap();
    std::os::unix::fs::symlink(&outside, dir.join("K.png")).unwrap();
    let others = other_pictures(&dir);
    assert!(others.len() >= 2, "{others:?}");
    std::fs::remove_file(dir.join(&others[0])).unwrap();
    std::fs::hard_link(&outside, dir.join(&others[0])).unwrap();
    std::fs::remove_file(dir.join(&others[1])).unwrap();
    let made = std::process::Command::new("mkfifo")
        .arg(dir.join(&others[1]))
        .status()
        .unwrap();
    assert!(made.success());
    let s = Server::start(&dir, &[]);
    for name in ["K.png", &others[0], &others[1]] {
        let (status, body) = request(&s, "GET", &format!("/files/{name}"));
        assert_eq!(status, 404, "{name}: {body}");
        assert!(!body.contains("not for the browser"), "{name}");
    }
    let (status, _) = fetch(&s, "GET", "/files/R.png");
    assert_eq!(status, 200, "the folder's own pictures are still served");
}

/// A one-cell map of long runs (3000 s of N = 3 at 100 rows/s), made once: its cell's run in
/// `explore` integrates for seconds, long enough to be cancelled or stopped.
fn long_cell_map() -> &'static Path {
    static DIR: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let out = scratch("long-map");
        let o = super::bin()
            .args(["map", "--backend", "cpu", "--quiet", "--out"])
            .arg(&out)
            .args([
                "--set",
                "map.axes=[{key=\"excitation.frequency_hz\",start=8.0,end=8.0,count=1}]",
                "--set",
                "integration.duration_s=3000.0",
                "--set",
                "output.sample_rate_hz=100.0",
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    })
}

/// Wait until job `id` is running and has made some progress.
fn wait_running(s: &Server, id: u64) {
    for _ in 0..600 {
        let j = json(s, "GET", &format!("/api/job/{id}"), 200);
        if j["state"] == "running" && j["progress"].as_f64().unwrap() > 0.0 {
            return;
        }
        assert_ne!(
            j["state"], "done",
            "the long cell finished before it was cancelled"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    panic!("job {id} did not start in 30 s");
}

#[test]
fn a_running_or_waiting_cell_run_is_cancelled_and_a_new_click_runs_it_again() {
    let s = Server::start(long_cell_map(), &["--workers", "1"]);
    let limits = json(&s, "GET", "/api/map", 200)["cell_limits"].clone();
    assert_eq!(limits["wall_s"].as_f64(), Some(300.0), "{limits}");
    assert_eq!(limits["memory"], "2.0 GB", "{limits}");
    let running = json(&s, "POST", "/api/cell/0/run", 202)["job"]
        .as_u64()
        .unwrap();
    wait_running(&s, running);
    let cancel = json(&s, "POST", &format!("/api/job/{running}/cancel"), 200);
    assert!(
        ["running", "failed"].contains(&cancel["state"].as_str().unwrap()),
        "{cancel}"
    );
    let end = wait_job(&s, running);
    assert_eq!(end["state"], "failed", "{end}");
    assert!(
        end["error"].as_str().unwrap().contains("was cancelled"),
        "{end}"
    );
    // A new click is a new run, not the cancelled one.
    let again = json(&s, "POST", "/api/cell/0/run", 202)["job"]
        .as_u64()
        .unwrap();
    assert_ne!(again, running);
    wait_running(&s, again);
    json(&s, "POST", &format!("/api/job/{again}/cancel"), 200);
    assert_eq!(wait_job(&s, again)["state"], "failed");
    // Cancelling a finished job leaves it as it was; an unknown or malformed id is refused.
    assert_eq!(
        json(&s, "POST", &format!("/api/job/{again}/cancel"), 200)["state"],
        "failed"
    );
    json(&s, "POST", "/api/job/4242/cancel", 404);
    let bad = json(&s, "POST", "/api/job/x/cancel", 400);
    assert!(
        bad["error"].as_str().unwrap().contains("not a job id"),
        "{bad}"
    );
}

#[test]
fn a_waiting_cell_run_is_cancelled_at_once() {
    let s = Server::start(small_map(), &["--workers", "1"]);
    let ids: Vec<u64> = (0..3)
        .map(|k| {
            json(&s, "POST", &format!("/api/cell/{k}/run"), 202)["job"]
                .as_u64()
                .unwrap()
        })
        .collect();
    let last = ids[2];
    let view = json(&s, "POST", &format!("/api/job/{last}/cancel"), 200);
    // Two runs ahead of it on one worker: it was still waiting and is failed at once.
    assert_eq!(view["state"], "failed", "{view}");
    assert!(
        view["error"].as_str().unwrap().contains("cancelled"),
        "{view}"
    );
    assert_eq!(wait_job(&s, ids[0])["state"], "done");
    assert_eq!(wait_job(&s, ids[1])["state"], "done");
}

#[test]
fn a_cell_run_past_the_time_limit_is_stopped_and_one_too_large_is_refused() {
    let s = Server::start(long_cell_map(), &["--cell-time-limit-s", "0.5"]);
    let id = json(&s, "POST", "/api/cell/0/run", 202)["job"]
        .as_u64()
        .unwrap();
    let end = wait_job(&s, id);
    assert_eq!(end["state"], "failed", "{end}");
    let e = end["error"].as_str().unwrap();
    assert!(e.contains("limit of 0.5 s"), "{e}");
    assert!(e.contains("pendulum-atlas simulate"), "{e}");
    drop(s);
    // 300 000 rows of about 112 bytes, 18 times over: far above 1 MB.
    let s = Server::start(long_cell_map(), &["--cell-memory-mb", "1"]);
    let id = json(&s, "POST", "/api/cell/0/run", 202)["job"]
        .as_u64()
        .unwrap();
    let end = wait_job(&s, id);
    assert_eq!(end["state"], "failed", "{end}");
    let e = end["error"].as_str().unwrap();
    assert!(
        e.contains("would hold about") && e.contains("1.0 MB"),
        "{e}"
    );
}

#[test]
fn cell_limits_outside_their_range_are_refused() {
    let dir = small_map();
    refused(dir, &["--cell-time-limit-s", "0"], "--cell-time-limit-s 0");
    refused(
        dir,
        &["--cell-time-limit-s", "nan"],
        "above 0 and at most 86400",
    );
    refused(dir, &["--cell-memory-mb", "0"], "give 1 to 1000000 MB");
}

#[test]
fn a_clicked_cell_of_a_map_with_starts_reruns_its_representative_start() {
    let out = scratch("starts-map");
    crate::map_cli(&out, &crate::STARTS_MAP_SETS);
    let starts: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("attractors.json")).unwrap())
            .unwrap();
    let bytes = std::fs::read(out.join("start.npy")).unwrap();
    let start: Vec<i32> = npyz::NpyFile::new(&bytes[..]).unwrap().into_vec().unwrap();
    let s = Server::start(&out, &[]);
    for (cell, &st) in start.iter().enumerate() {
        let (status, toml) = request(&s, "GET", &format!("/api/cell/{cell}/scene.toml"));
        assert_eq!(status, 200, "{toml}");
        let scene: toml::Table = toml.parse().unwrap();
        let want = &starts["starts"]["states"][st as usize];
        let got = &scene["initial"];
        assert_eq!(
            got["angle_deg"].as_float(),
            want["angle_deg"].as_f64(),
            "cell {cell}"
        );
        assert_eq!(
            got["rate_deg_s"].as_float(),
            want["rate_deg_s"].as_f64(),
            "cell {cell}"
        );
    }
    // The attractor arrays are quantities of the page too, as the map stored them.
    let f = json(&s, "GET", "/api/field?metric=attractor", 200);
    let bytes = std::fs::read(out.join("attractor.npy")).unwrap();
    let labels: Vec<i32> = npyz::NpyFile::new(&bytes[..]).unwrap().into_vec().unwrap();
    let cells: Vec<usize> = serde_json::from_value(f["cells"].clone()).unwrap();
    for (at, &cell) in cells.iter().enumerate() {
        assert_eq!(
            f["values"][at].as_f64(),
            Some(f64::from(labels[cell])),
            "cell {cell}"
        );
    }
    let count = json(&s, "GET", "/api/field?metric=attractors", 200);
    assert!(
        count["values"]
            .as_array()
            .unwrap()
            .iter()
            .all(|v| v.as_f64() == Some(2.0)),
        "{count}"
    );
    // The rerun of the representative start runs to its end.
    let job = json(&s, "POST", "/api/cell/1/run", 202);
    let done = wait_job(&s, job["job"].as_u64().unwrap());
    assert_eq!(done["state"], "done", "{done}");
    assert_eq!(done["result"]["status"], "ok");
    // The cell lists both wells' attractors, and running each one's start lands in its well.
    let info = json(&s, "GET", "/api/cell/1", 200);
    let attractors = info["attractors"]
        .as_array()
        .expect("the cell's attractors");
    assert_eq!(attractors.len(), 2, "{info}");
    let total: f64 = attractors
        .iter()
        .map(|a| a["fraction"].as_f64().unwrap())
        .sum();
    assert!((total - 1.0).abs() < 1e-12, "{info}");
    for a in attractors {
        let start = a["start"].as_u64().unwrap() as usize;
        let (status, toml) = request(
            &s,
            "GET",
            &format!("/api/cell/1/scene.toml?variant={}", start + 1),
        );
        assert_eq!(status, 200, "{toml}");
        let scene: toml::Table = toml.parse().unwrap();
        let want = &starts["starts"]["states"][start];
        assert_eq!(
            scene["initial"]["angle_deg"].as_float(),
            want["angle_deg"].as_f64()
        );
        let job = json(
            &s,
            "POST",
            &format!("/api/cell/1/run?variant={}", start + 1),
            202,
        );
        let done = wait_job(&s, job["job"].as_u64().unwrap());
        assert_eq!(done["state"], "done", "{done}");
        let r = &done["result"];
        let transient = r["transient_s"].as_f64().unwrap();
        let settled: Vec<f64> = r["alpha"]["x"]
            .as_array()
            .unwrap()
            .iter()
            .zip(r["alpha"]["y"].as_array().unwrap())
            .filter(|(t, _)| t.as_f64().unwrap() > transient)
            .map(|(_, a)| a.as_f64().unwrap())
            .collect();
        let name = a["name"].as_str().unwrap();
        let positive = name.contains('+');
        assert!(
            settled.iter().all(|&x| (x > 0.0) == positive),
            "start {start} reached `{name}` in the map"
        );
        assert!(
            r["notes"][0]
                .as_str()
                .unwrap()
                .contains(&format!("start {}", start + 1))
        );
    }
    let bad = json(&s, "POST", "/api/cell/1/run?variant=7", 400);
    assert!(bad.to_string().contains("variant"), "{bad}");
}

#[test]
fn a_map_run_both_ways_shows_both_sweeps_and_says_a_rerun_starts_afresh() {
    let out = scratch("both-ways-map");
    crate::map_cli(&out, &crate::HYSTERESIS_MAP_SETS);
    let s = Server::start(&out, &[]);
    let m = json(&s, "GET", "/api/map", 200);
    let names: Vec<&str> = m["metrics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    for want in ["period", "period_down", "regime_down", "hysteresis"] {
        assert!(names.contains(&want), "{want} not in {names:?}");
    }
    let f = json(&s, "GET", "/api/field?metric=hysteresis", 200);
    let shown: Vec<f64> = f["values"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(shown, vec![0.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
    let job = json(&s, "POST", "/api/cell/3/run", 202);
    let done = wait_job(&s, job["job"].as_u64().unwrap());
    assert_eq!(done["state"], "done", "{done}");
    let note = done["result"]["notes"][0].as_str().unwrap();
    assert!(
        note.contains("ran by continuation") && note.contains("scene's own state"),
        "{note}"
    );
}

/// Copy the plain files of `from` into a new folder `to`.
fn copy_folder(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_file() && e.file_name() != ".pendulum-atlas.lock" {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// A folder replaced while it is served (deleted and made again, as a rerun with --force
/// into a fresh copy would) is no longer served as the earlier run: every request answers
/// 409 with what to do, instead of the old data beside the new pictures (issue 61).
#[test]
fn a_folder_replaced_while_served_is_refused_with_what_to_do() {
    let dir = scratch("replaced");
    copy_folder(small_map(), &dir);
    let server = Server::start(&dir, &[]);
    json(&server, "GET", "/api/map", 200);
    let old = dir.with_extension("old");
    let _ = std::fs::remove_dir_all(&old);
    std::fs::rename(&dir, &old).unwrap();
    copy_folder(&old, &dir);
    for path in ["/api/map", "/api/cell/0", "/files/K.png"] {
        let (status, body) = request(&server, "GET", path);
        assert_eq!(status, 409, "{path}: {body}");
        assert!(
            body.contains("replaced or rerun") && body.contains("start it again"),
            "{body}"
        );
    }
    drop(server);
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&old);
}

/// The axes carry the PNG maps' round ticks (5, 6, ... 10 over cells centred at 5 ... 10),
/// not cell centres, each within the cell edges the page draws (issue 61).
#[test]
fn the_axes_carry_the_round_ticks_of_the_png_maps() {
    let s = Server::start(small_map(), &[]);
    let m = json(&s, "GET", "/api/map", 200);
    let labels = |axis: &serde_json::Value| -> Vec<String> {
        axis["ticks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t["label"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(labels(&m["axes"][0]), ["5", "6", "7", "8", "9", "10"]);
    for axis in m["axes"].as_array().unwrap() {
        let edges: Vec<f64> = serde_json::from_value(axis["edges"].clone()).unwrap();
        let values: Vec<f64> = serde_json::from_value(axis["values"].clone()).unwrap();
        assert_eq!(edges.len(), values.len() + 1);
        let ticks = axis["ticks"].as_array().unwrap();
        assert!(ticks.len() >= 2, "{axis}");
        for t in ticks {
            let v = t["value"].as_f64().unwrap();
            assert!(
                v >= edges[0] && v <= edges[values.len()],
                "{v} outside {edges:?}"
            );
        }
    }
}
