//! GPU faults (issue 44): a lost device and an out-of-memory allocation, injected by the
//! `PENDULUM_ATLAS_GPU_FAULT` failpoint on whatever adapter there is (lavapipe in CI), end a
//! map within seconds with a non-zero exit, one error line that names the fault and the map's
//! size, no lock held and no output folder left behind.

use super::gpu;
use pendulum_atlas_core::engine::gpu::fault::GPU_FAULT_ENV;
use std::process::Command;
use std::time::{Duration, Instant};

const AXES: &str = r#"map.axes=[{key="excitation.frequency_hz",start=11.0,end=12.0,count=4},{key="excitation.amplitude_m",start=0.004,end=0.025,count=4}]"#;

/// `map --backend gpu` of 16 cells with the failpoint at `fault`: (exit code, stderr, seconds,
/// the output folder).
fn faulted_map(fault: &str) -> (Option<i32>, String, Duration, std::path::PathBuf) {
    let out = std::env::temp_dir().join(format!(
        "pendulum-atlas-fault-{fault}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&out);
    let started = Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
        .args(["map", "--backend", "gpu", "--quiet", "--set", AXES, "--out"])
        .arg(&out)
        .env(GPU_FAULT_ENV, fault)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    (o.status.code(), err, started.elapsed(), out)
}

#[test]
fn a_lost_device_or_an_out_of_memory_ends_the_run_with_one_clear_error() {
    if gpu().is_none() {
        return;
    }
    for (fault, says) in [("lose_device", "was lost"), ("oom", "ran out of memory")] {
        let (code, err, took, out) = faulted_map(fault);
        assert!(
            matches!(code, Some(c) if c != 0),
            "{fault}: exit {code:?}: {err}"
        );
        let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error")).collect();
        assert_eq!(errors.len(), 1, "{fault}: one error line: {err}");
        let line = errors[0];
        assert!(line.contains(says), "{fault}: {line}");
        assert!(line.contains("16 instances at N = 3"), "{fault}: {line}");
        assert!(line.contains("--backend cpu"), "{fault}: {line}");
        assert!(!err.contains("panicked"), "{fault}: {err}");
        assert!(took < Duration::from_secs(60), "{fault}: took {took:?}");
        assert!(!out.exists(), "{fault}: {} was left behind", out.display());
    }
}

/// The files of `dir` (the lock aside) with their bytes, sorted by name.
fn files_of(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_name() != ".pendulum-atlas.lock")
        .map(|e| {
            let bytes = std::fs::read(e.path()).unwrap_or_default();
            (e.file_name().to_string_lossy().into_owned(), bytes)
        })
        .collect();
    files.sort();
    files
}

/// A map run with `--force` over an earlier map that fails on a lost device leaves the earlier
/// map whole: every file as it was, none of the new run's, nothing set aside (issue 61).
#[test]
fn a_forced_map_that_fails_keeps_the_earlier_map_whole() {
    if gpu().is_none() {
        return;
    }
    let out = std::env::temp_dir().join(format!("pendulum-atlas-keep-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let map = |backend: &str, fault: &str, force: bool| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"));
        c.args([
            "map",
            "--backend",
            backend,
            "--quiet",
            "--set",
            AXES,
            "--out",
        ])
        .arg(&out)
        .env(GPU_FAULT_ENV, fault);
        if force {
            c.arg("--force");
        }
        c.output().unwrap()
    };
    assert!(map("cpu", "", false).status.success());
    std::fs::write(out.join("notes.txt"), "the user's").unwrap();
    let before = files_of(&out);
    assert!(before.iter().any(|(n, _)| n == "map.json"));
    let o = map("gpu", "lose_device", true);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(matches!(o.status.code(), Some(c) if c != 0), "{err}");
    assert!(err.contains("kept as they were"), "{err}");
    assert_eq!(
        files_of(&out),
        before,
        "the earlier map and the user's file, as they were"
    );
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn an_unknown_fault_is_refused_with_the_accepted_values() {
    if gpu().is_none() {
        return;
    }
    let (code, err, _, out) = faulted_map("melt");
    assert!(matches!(code, Some(c) if c != 0), "exit {code:?}: {err}");
    assert!(
        err.contains("melt") && err.contains("lose_device and oom"),
        "{err}"
    );
    assert!(!out.exists());
}
