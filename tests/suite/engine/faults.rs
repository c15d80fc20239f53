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
