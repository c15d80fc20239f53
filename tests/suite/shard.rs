//! Sharded maps: shards run separately and merged give the files of one unsharded run (bit for
//! bit on the CPU engine), and merge refuses shards that do not make one map.

use std::path::{Path, PathBuf};
use std::process::Command;

pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
}

pub fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "pendulum-atlas-shard-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The bifurcation map at 7 frequencies, short runs: every metric plus the diagram.
pub const SETS: [&str; 6] = [
    "--set",
    "map.axes=[{key=\"excitation.frequency_hz\",start=5.0,end=11.0,count=7}]",
    "--set",
    "integration.duration_s=24.0",
    "--set",
    "integration.transient_s=4.0",
];

pub fn map(extra: &[&str]) -> std::process::Output {
    bin()
        .args([
            "map",
            "configs/maps/bifurcation_f.toml",
            "--backend",
            "cpu",
            "--quiet",
        ])
        .args(SETS)
        .args(extra)
        .output()
        .unwrap()
}

pub fn ok(o: &std::process::Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn shard(root: &Path, i: u32, n: u32) -> PathBuf {
    let d = root.join(format!("shard{i}"));
    ok(&map(&[
        "--shard",
        &format!("{i}/{n}"),
        "--out",
        d.to_str().unwrap(),
    ]));
    d
}

fn merge(dirs: &[&Path], out: &Path) -> std::process::Output {
    bin()
        .arg("merge")
        .args(dirs)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// map.json without what may differ between a merged and a whole run: timings, throughput,
/// the list of shards and the GPU's dispatch count.
fn manifest(dir: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("map.json")).unwrap()).unwrap();
    let m = v.as_object_mut().unwrap();
    for k in ["timings_s", "wall_share", "throughput", "shards"] {
        m.remove(k);
    }
    // GPU dispatches are sized by wall time: a scheduling count, like a timing.
    m["steps"].as_object_mut().unwrap().remove("dispatches");
    if let Some(settle) = m["settle"].as_object_mut() {
        settle.remove("wall_s");
    }
    if let Some(orbits) = m["orbits"].as_object_mut() {
        orbits.remove("wall_s");
        orbits.remove("timings_s");
    }
    if let Some(transients) = m["transients"].as_object_mut() {
        transients.remove("wall_s");
    }
    v
}

#[test]
fn three_shards_merged_equal_the_unsharded_map_bit_for_bit() {
    let root = out_dir("three");
    let whole = root.join("whole");
    ok(&map(&["--out", whole.to_str().unwrap()]));
    let shards: Vec<PathBuf> = [2, 0, 1].iter().map(|&i| shard(&root, i, 3)).collect();
    let merged = root.join("merged");
    let refs: Vec<&Path> = shards.iter().map(PathBuf::as_path).collect();
    ok(&merge(&refs, &merged));
    assert_same_map(&whole, &merged);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(merged.join("map.json")).unwrap()).unwrap();
    let listed: Vec<u64> = json["shards"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["shard"]["index"].as_u64().unwrap())
        .collect();
    assert_eq!(listed, vec![0, 1, 2]);
    // Shard 1 of 3 holds instances 1 and 4.
    let s1 = std::fs::read_to_string(shards[2].join("shard.json")).unwrap();
    assert!(s1.contains("\"members\": 2"), "{s1}");
}

/// Every file of the map in `whole` is in `merged` with the same bytes, `map.json` apart from
/// its timings and list of shards.
pub fn assert_same_map(whole: &Path, merged: &Path) {
    let mut names: Vec<String> = std::fs::read_dir(whole)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "map.json")
        .collect();
    names.sort();
    for must in [
        "bifurcation.png",
        "line_ratio.npy",
        "lyapunov.npy",
        "regime.npy",
        "regime.png",
    ] {
        assert!(names.iter().any(|n| n == must), "{must} missing");
    }
    for n in &names {
        let (a, b) = (
            std::fs::read(whole.join(n)).unwrap(),
            std::fs::read(merged.join(n)),
        );
        assert!(
            b.as_ref().is_ok_and(|b| *b == a),
            "{n} differs or is missing"
        );
    }
    assert_eq!(manifest(whole), manifest(merged));
}

#[test]
fn merge_names_missing_duplicate_and_foreign_shards() {
    let root = out_dir("refuse");
    let a = shard(&root, 0, 2);
    let err = |o: std::process::Output| {
        assert_eq!(o.status.code(), Some(2));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let e = err(merge(&[&a], &root.join("m1")));
    assert!(
        e.contains("1 of 2 shards are missing: 1") && e.contains("--shard I/2"),
        "{e}"
    );
    let e = err(merge(&[&a, &a], &root.join("m2")));
    assert!(
        e.contains("1 of 2 shards are given more than once: shard 0 in"),
        "{e}"
    );
    // The same shard index of another map (a different amplitude).
    let other = root.join("other");
    ok(&map(&[
        "--set",
        "excitation.amplitude_m=0.012",
        "--shard",
        "1/2",
        "--out",
        other.to_str().unwrap(),
    ]));
    let e = err(merge(&[&a, &other], &root.join("m3")));
    assert!(
        e.contains("not a shard of the same map") && e.contains("map hash"),
        "{e}"
    );
    // A shard that was killed before its manifest.
    let killed = root.join("killed");
    std::fs::create_dir_all(&killed).unwrap();
    let e = err(merge(&[&a, &killed], &root.join("m4")));
    assert!(e.contains("shard.json") && e.contains("rerun it"), "{e}");
    // Bad --shard values never start.
    for bad in ["2/2", "x", "0/0"] {
        let e = err(map(&[
            "--shard",
            bad,
            "--out",
            root.join("bad").to_str().unwrap(),
        ]));
        assert!(e.contains("0 <= I < N"), "{bad}: {e}");
    }
    let e = err(map(&[
        "--shard",
        "0/8",
        "--out",
        root.join("bad").to_str().unwrap(),
    ]));
    assert!(
        e.contains("8 shards of a map of 7 instances; use at most 7"),
        "{e}"
    );
    let slurm = |extra: &[&str]| {
        bin()
            .args(["slurm", "configs/maps/bifurcation_f.toml"])
            .args(SETS)
            .args(extra)
            .arg("--out")
            .arg(root.join("job"))
            .output()
            .unwrap()
    };
    let e = err(slurm(&["--shards", "4", "--time", "1h"]));
    assert!(e.contains("--time `1h`") && e.contains("HH:MM:SS"), "{e}");
    let e = err(slurm(&["--shards", "9"]));
    assert!(e.contains("use at most 7 shards"), "{e}");
    assert!(!root.join("job").exists(), "a refused job wrote its folder");
}

#[test]
fn a_map_split_over_two_devices_equals_the_map_on_one() {
    if crate::engine::gpu().is_none() {
        return;
    }
    let root = out_dir("devices");
    let (one, two) = (root.join("one"), root.join("two"));
    let gpu = |extra: &[&str], out: &Path| {
        bin()
            .args(["map", "configs/maps/bifurcation_f.toml", "--quiet"])
            .args(SETS)
            .args(extra)
            .arg("--out")
            .arg(out)
            .output()
            .unwrap()
    };
    ok(&gpu(&["--adapter", "0"], &one));
    // The same adapter opened twice: two devices, each integrating one interleaved half.
    ok(&gpu(&["--devices", "0,0"], &two));
    assert_same_map(&one, &two);
    let e = gpu(&["--devices", "0,7"], &root.join("bad"));
    let msg = String::from_utf8_lossy(&e.stderr);
    assert!(
        e.status.code() == Some(2) && msg.contains("there is no adapter 7"),
        "{msg}"
    );
    let e = gpu(&["--devices", "0,x"], &root.join("bad"));
    assert!(String::from_utf8_lossy(&e.stderr).contains("adapter indices separated by commas"));
}

#[test]
fn merge_refuses_shard_rows_no_engine_could_have_written() {
    use pendulum_atlas_map::output::npy::{read_npy, write_npy_f64};
    use pendulum_atlas_map::shard::files::shard_columns;
    let root = out_dir("tampered");
    let (a, b) = (shard(&root, 0, 2), shard(&root, 1, 2));
    let path = b.join("shard_results.npy");
    let (shape, clean): (Vec<usize>, Vec<f64>) = read_npy(&path).unwrap();
    let columns = shard_columns();
    let col = |name: &str| columns.iter().position(|c| *c == name).unwrap();
    let width = columns.len();
    // Row 0 is an ok instance (the bifurcation map's cells all end ok).
    assert_eq!(clean[col("status")], 0.0);
    // A plausible K written over the shard's own is refused by the values' hash.
    let mut rows = clean.clone();
    rows[col("K")] = if clean[col("K")] > 0.5 { 0.1 } else { 0.9 };
    write_npy_f64(&path, &shape, &rows).unwrap();
    let o = merge(&[&a, &b], &root.join("merged"));
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("SHA-256 differs"), "{e}");
    // Beyond the hash (a forger who rewrites it too), every rule below still holds.
    let write = |rows: &[f64]| {
        write_npy_f64(&path, &shape, rows).unwrap();
        rehash(&b, rows);
    };
    let cases: [(&str, f64, &str); 6] = [
        ("K", 7.5, "K = 7.5"),
        ("R", f64::NAN, "R = NaN"),
        ("period", 2.5, "period = 2.5"),
        ("steps", -3.0, "steps is -3"),
        ("status", 1.0, "status `diverged` but K"),
        ("index", 2.5, "index is 2.5"),
    ];
    for (name, value, says) in cases {
        let mut rows = clean.clone();
        rows[col(name)] = value;
        write(&rows);
        let o = merge(&[&a, &b], &root.join("merged"));
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name} = {value}: {e}");
        assert!(e.contains(says), "{name}: {e}");
        assert!(e.lines().count() <= 3, "{e}");
        assert_eq!(width, shape[1]);
    }
    // Rows that pass every range but break the rule that ties them to their map and to their
    // own numbers: a chaotic row (λ1 > 0, no period; every cell of this map is one) is edited.
    let row = (0..shape[0])
        .find(|&i| clean[i * width + col("regime")] == 3.0)
        .expect("a chaotic row");
    let at = |name: &str| row * width + col(name);
    let rule_cases: [(&[(&str, f64)], &str); 7] = [
        (&[("K", 1e308)], "K = 1e308 is outside"),
        (&[("hops", 2.5)], "hops = 2.5"),
        (&[("period", 40.0)], "above map.period_max = 8"),
        (&[("lyapunov", 1e300)], "lambda1 = 1e300"),
        (&[("period", 2.0)], "regime `chaotic` with period 2"),
        (
            &[("K", 1.0), ("regime", 2.0)],
            "regime `regular`, but its own lambda1, period and K give `chaotic`",
        ),
        (&[("regime_confidence", f64::NAN)], "regime confidence NaN"),
    ];
    for (edits, says) in rule_cases {
        let mut rows = clean.clone();
        for (name, value) in edits {
            rows[at(name)] = *value;
        }
        write(&rows);
        let o = merge(&[&a, &b], &root.join("merged"));
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{edits:?}: {e}");
        assert!(e.contains(says), "{edits:?}: {e}");
    }
    write(&clean);
    ok(&merge(&[&a, &b], &root.join("merged")));
}

/// Set shard `dir`'s `values_sha256` to the hash of `rows` and its stroboscopic tails.
fn rehash(dir: &Path, rows: &[f64]) {
    use pendulum_atlas_map::output::npy::read_npy;
    use pendulum_atlas_map::shard::files::values_sha256;
    let values = |name: &str| -> Vec<f64> {
        let path = dir.join(name);
        if path.exists() {
            read_npy(&path).unwrap().1
        } else {
            Vec::new()
        }
    };
    let (tails, states) = (values("shard_strobe.npy"), values("shard_state.npy"));
    let manifest = dir.join("shard.json");
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest).unwrap()).unwrap();
    m["values_sha256"] = values_sha256(&[rows, &tails, &states]).into();
    std::fs::write(&manifest, serde_json::to_string_pretty(&m).unwrap()).unwrap();
}

#[test]
fn merge_holds_every_manifest_count_to_its_range_and_adds_without_wrapping() {
    let root = out_dir("counts");
    let (a, b) = (shard(&root, 0, 2), shard(&root, 1, 2));
    let path = |d: &Path| d.join("shard.json");
    let read = |d: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(path(d)).unwrap()).unwrap()
    };
    let (clean_a, clean_b) = (read(&a), read(&b));
    let write = |d: &Path, v: &serde_json::Value| {
        std::fs::write(path(d), serde_json::to_string_pretty(v).unwrap()).unwrap()
    };
    let refused = |says: &str| {
        let o = merge(&[&a, &b], &root.join("merged"));
        let e = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{says}: {e}");
        assert!(e.contains(says), "{says}: {e}");
    };
    // Two counts that each fit but whose sum would wrap.
    let (mut ma, mut mb) = (clean_a.clone(), clean_b.clone());
    ma["sub_steps"] = u64::MAX.into();
    mb["sub_steps"] = u64::MAX.into();
    write(&a, &ma);
    write(&b, &mb);
    refused("sub_steps values add up beyond");
    write(&b, &clean_b);
    // Fewer sub-steps than base steps, a negative time, more early stops than members.
    let cases: [(&str, serde_json::Value, &str); 3] = [
        ("sub_steps", 3.into(), "fewer than the"),
        ("stopped_early", 1_000_000.into(), "more than its"),
        (
            "timings_s",
            serde_json::json!({"plan_s": 0.0, "device_s": 0.0, "integrate_s": 0.0,
            "reduce_s": 0.0, "total_s": -1e308, "gpu": null}),
            "not a time from 0",
        ),
    ];
    for (field, value, says) in cases {
        let mut m = clean_a.clone();
        m[field] = value;
        write(&a, &m);
        refused(says);
    }
    // A shard index past the count is named as such, not as a missing field.
    let mut m = clean_a.clone();
    m["shard"]["index"] = 7.into();
    write(&a, &m);
    refused("the index must be below the count");
    // The values' hash is hex in either case.
    let mut m = clean_a.clone();
    m["values_sha256"] = m["values_sha256"].as_str().unwrap().to_uppercase().into();
    write(&a, &m);
    ok(&merge(&[&a, &b], &root.join("merged")));
    let _ = std::fs::remove_dir_all(&root);
}
