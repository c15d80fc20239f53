//! Every refusal reads as a sentence for a person: a sweep of bad inputs across the commands,
//! each of which must exit 2 with one short `error:` message that holds no Rust internals
//! (Debug forms such as `Some([7, 3])`, serde's type names such as `struct PeerRow` or
//! `i128`) and no number of twenty digits or more (`1e300` written out, `u64::MAX`).

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "pendulum-atlas-messages-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// What a message must not hold, and why.
fn internals(msg: &str) -> Option<&'static str> {
    let digits = msg
        .split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0);
    if digits >= 20 {
        return Some("a number of 20 digits or more");
    }
    let debug = [
        ("Some(", "a Debug Option"),
        ("None)", "a Debug Option"),
        ("Error(", "a Debug error"),
        ("Custom {", "a Debug io error"),
        ("kind: ", "a Debug io error"),
        ("expected struct", "a serde type name"),
        ("expected enum", "a serde type name"),
        ("expected usize", "a Rust integer type"),
        ("expected u32", "a Rust integer type"),
        ("expected u64", "a Rust integer type"),
        ("expected i64", "a Rust integer type"),
        ("i128", "a Rust integer type"),
        ("f64::", "a Rust constant"),
        ("panicked", "a panic"),
    ];
    debug
        .iter()
        .find(|(pat, _)| msg.contains(pat))
        .map(|(_, why)| *why)
}

/// Run `args` (with `--out` for the commands that write); the refusal must exit 2 with a
/// short, readable message.
fn refused(args: &[&str], cwd: &Path) -> String {
    let mut cmd = bin();
    cmd.args(args).current_dir(cwd);
    if ["simulate", "map"].contains(&args[0]) {
        cmd.args(["--out", "never_written"]);
    }
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(errors.len(), 1, "{args:?}: one error line, got: {err}");
    let msg = errors[0];
    assert!(
        err.lines().count() <= 6 && msg.len() <= 600,
        "{args:?}: a message of a few lines, got {} lines, {} characters: {err}",
        err.lines().count(),
        msg.len()
    );
    if let Some(why) = internals(msg) {
        panic!("{args:?}: the message holds {why}: {msg}");
    }
    msg.to_string()
}

#[test]
fn scene_refusals_are_short_and_hold_no_internals() {
    let dir = scratch("scene");
    let long_map = "[map]\naxes = [{ key = \"excitation.frequency_hz\", start = 1e301, end = 1e300, count = 3 }]\n";
    std::fs::write(dir.join("backwards.toml"), long_map).unwrap();
    let seed = "[map]\nk_seed = -1\naxes = [{ key = \"excitation.frequency_hz\", start = 4, end = 8, count = 3 }]\n";
    std::fs::write(dir.join("seed.toml"), seed).unwrap();
    let probes: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["simulate", "--set", "beam.damping_ratio=1e300"],
            "1e300",
        ),
        (
            vec!["simulate", "--set", "beam.damping_ratio=-1e-300"],
            "-1e-300",
        ),
        (
            vec![
                "simulate",
                "--set",
                "beam.length_m=1e300",
                "--set",
                "limiter.contact_arc_m=-1",
            ],
            "limiter.contact_arc_m",
        ),
        (
            vec![
                "simulate",
                "--set",
                "beam.outer_diameter_m=1e300",
                "--set",
                "beam.inner_diameter_m=2e300",
            ],
            "beam.inner_diameter_m",
        ),
        (
            vec!["simulate", "--set", "integration.duration_s=1e-300"],
            "integration.duration_s",
        ),
        (
            vec!["simulate", "--set", "beam.segments=1e3"],
            "beam.segments",
        ),
        (
            vec!["simulate", "--set", "beam.segments=99999999999999999"],
            "beam.segments",
        ),
        (vec!["modes", "--set", "beam.mass_kg=1e-20"], "beam.mass_kg"),
        (vec!["map", "backwards.toml"], "below start"),
        (vec!["map", "seed.toml"], "map.k_seed"),
    ];
    for (args, names) in probes {
        let msg = refused(&args, &dir);
        assert!(msg.contains(names), "{args:?} names {names}: {msg}");
    }
    assert!(
        !dir.join("never_written").exists(),
        "refused before any file"
    );
}

#[test]
fn damaged_files_of_ours_are_described_in_words() {
    let dir = scratch("files");
    // A shard folder whose manifest is not ours: no serde type names in the refusal.
    let shard = dir.join("shard");
    std::fs::create_dir_all(&shard).unwrap();
    for (i, text) in ["[1, 2, 3]", "{\"members\": -1}", "{\"members\": 3"]
        .iter()
        .enumerate()
    {
        std::fs::write(shard.join("shard.json"), text).unwrap();
        let out = format!("merged{i}");
        let msg = refused(&["merge", "shard", "--out", &out], &dir);
        assert!(msg.contains("shard.json"), "{msg}");
    }
}

/// Numbers in analysis messages and warnings are written compactly (1e300, not 301 digits),
/// the step-limit refusal of adaptive steps advises what changes base steps (not
/// `integration.dt_s`, which would switch to fixed steps), and `slurm` refuses, before writing
/// a job, a settled map and a basin map, naming the key that makes each unshardable.
#[test]
fn refusals_name_what_to_change_and_write_numbers_compactly() {
    let dir = scratch("compact");
    let rec: String = std::iter::once("t,a\n".to_string())
        .chain((0..2000).map(|i| format!("{},{}\n", i as f64 / 100.0, (i as f64 / 10.0).sin())))
        .collect();
    std::fs::write(dir.join("rec.csv"), rec).unwrap();
    let analyze = |extra: &[&str]| {
        let mut args = vec![
            "analyze", "rec.csv", "--signal", "a", "--out", "an", "--force",
        ];
        args.extend_from_slice(extra);
        args.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let a = analyze(&["--time", "t", "--forcing-hz", "1e300"]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let msg = refused(&a, &dir);
    assert!(msg.contains("1e300 Hz"), "{msg}");
    // A warning of a run that goes through.
    let a = analyze(&["--sample-rate-hz", "1e300", "--forcing-hz", "2"]);
    let o = bin().args(&a).current_dir(&dir).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("4e297 samples per s"), "{err}");
    assert_eq!(internals(&err), None, "{err}");
    // Adaptive steps: the base steps, and what changes them.
    let msg = refused(
        &[
            "simulate",
            "--set",
            "integration.duration_s=1e9",
            "--set",
            "beam.segments=3",
        ],
        &dir,
    );
    assert!(
        msg.contains("base steps") && msg.contains("output.sample_rate_hz"),
        "{msg}"
    );
    assert!(!msg.contains("integration.dt_s"), "{msg}");
    let slurm = |sets: &[&str], names: &str| {
        let mut args = vec!["slurm", "--shards", "2", "--out", "jobs"];
        for s in sets {
            args.extend(["--set", s]);
        }
        let msg = refused(&args, &dir);
        assert!(msg.contains(names), "{names}: {msg}");
        assert!(!dir.join("jobs").exists(), "refused before writing a job");
    };
    slurm(
        &[
            "map.axes=[{key=\"initial.angle_deg\",values=[-10.0,10.0]},{key=\"initial.rate_deg_s\",values=[0.0,5.0]}]",
        ],
        "key `map.axes`",
    );
}
