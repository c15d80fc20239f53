//! `bench --throughput`: the ladder, the counted flop, the K-only rows and the report, on a
//! small grid (N = 3, 1000 instances); the command's refusals.

use crate::engine::gpu;
use pendulum_atlas_core::engine::EngineKind;
use pendulum_atlas_core::engine::gpu::kernels::GpuKernel;
use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_studies::bench::cost::step_flops;
use pendulum_atlas_studies::bench::gpu_report::write_throughput;
use pendulum_atlas_studies::bench::gpu_throughput::{
    ThroughputOptions, ThroughputScene, run_throughput, workload,
};
use std::process::Command;

/// A rung still running at the row budget is stopped there with the rate of the steps it
/// took, and the larger rungs of its ladder are skipped (CPU engine: 10⁵ instances take about
/// a second, far over a budget of 0.05 s).
#[test]
fn a_rung_over_the_budget_is_stopped_and_the_larger_ones_skipped() {
    let opts = ThroughputOptions {
        gpu: None,
        cpu: true,
        max_instances: 100_000,
        row_budget_s: 0.05,
        peak_flop_per_s: None,
        peers: None,
        segments: vec![3],
        kernels: vec![GpuKernel::Thread],
    };
    let r = run_throughput(&opts, &|_| {}).unwrap();
    assert_eq!(r.rows.len(), 4 * 3, "2 methods × 2 scenes × 3 rungs");
    for ladder in r.rows.chunks(3) {
        let stopped: Vec<usize> = (0..3).filter(|&i| ladder[i].stopped_at.is_some()).collect();
        assert_eq!(stopped.len(), 1, "one rung reaches the budget: {ladder:?}");
        let s = &ladder[stopped[0]];
        let share = s.stopped_at.unwrap();
        assert!(share > 0.0 && share < 1.0, "{share}");
        let rate = s.instance_steps_per_s.unwrap();
        assert!((rate * s.integrate_s.unwrap() - s.instance_steps as f64).abs() < 1e-6 * rate);
        assert!(s.instance_steps < (s.steps_per_instance * s.instances as f64) as u64);
        for (i, row) in ladder.iter().enumerate() {
            assert_eq!(row.skipped.is_some(), i > stopped[0], "{row:?}");
        }
    }
}

#[test]
fn the_ladder_measures_or_skips_every_rung_and_the_report_shows_it() {
    let gpu = gpu();
    let opts = ThroughputOptions {
        gpu,
        cpu: true,
        max_instances: 1000,
        row_budget_s: 5.0,
        peak_flop_per_s: None,
        peers: None,
        segments: vec![3],
        kernels: GpuKernel::ALL.to_vec(),
    };
    let r = run_throughput(&opts, &|_| {}).unwrap();
    // The CPU engine, and the GPU's kernel.
    let ladders = 1 + usize::from(gpu.is_some());
    // 2 methods × 2 scenes × one rung per engine and kernel.
    assert_eq!(r.rows.len(), 4 * ladders);
    for k in GpuKernel::ALL {
        let on_k = r.rows.iter().filter(|x| x.kernel == Some(k)).count();
        assert_eq!(on_k, if gpu.is_some() { 4 } else { 0 }, "{k:?}");
    }
    assert_eq!(r.rows.iter().filter(|x| x.kernel.is_none()).count(), 4);
    let plan = workload(ThroughputScene::Default, 3, Method::Rk4, 1).unwrap();
    let p = &plan.instances[0].params;
    for row in &r.rows {
        assert_eq!(row.flop_per_step, step_flops(row.method, p).flop_per_step);
        match &row.skipped {
            Some(why) => assert!(why.contains("row budget"), "{why}"),
            None => {
                let rate = row.instance_steps_per_s.unwrap();
                let t = row.integrate_s.unwrap();
                assert!((rate * t - row.instance_steps as f64).abs() < 1e-6 * rate * t);
                let flop = row.flop_per_s.unwrap();
                assert!((flop - rate * row.flop_per_step as f64).abs() < 1e-6 * flop);
                assert_eq!(row.segment_steps_per_s, Some(rate * 3.0));
                // One forcing period at 11-12 Hz (default) or 7.5-8.5 Hz (paper) per instance.
                assert!(row.steps_per_instance > 50.0, "{}", row.steps_per_instance);
                if row.kind == EngineKind::Gpu {
                    // 1000 instances: at least the state (7 f32) and parameters of each (a
                    // run stopped at the budget reports none).
                    let whole = row.stopped_at.is_none();
                    assert!(!whole || row.device_bytes.unwrap() > 1000 * 28, "{row:?}");
                } else {
                    assert!(row.device_bytes.is_none() && row.share_of_peak.is_none());
                }
            }
        }
    }
    assert_eq!(r.metrics.len(), 1 + usize::from(gpu.is_some()));
    for m in &r.metrics {
        match (&m.all, &m.k_only, &m.skipped) {
            (Some(a), Some(k), None) => {
                assert!(a.integrate_s > 0.0 && k.integrate_s > 0.0);
                assert!(a.total_s() > 0.0 && k.total_s() > 0.0);
            }
            (None, None, Some(why)) => assert!(why.contains("row budget"), "{why}"),
            other => panic!("a metric row is half measured: {other:?}"),
        }
    }
    let dir = std::env::temp_dir().join(format!("pa-throughput-{}", std::process::id()));
    let files = write_throughput(&dir, &r).unwrap();
    assert_eq!(files.len(), 2);
    let md = std::fs::read_to_string(dir.join("GPU.md")).unwrap();
    for heading in [
        "## Counted work per step",
        "## Integration throughput",
        "## Metrics a scene does not need",
        "## Peers on the same device",
    ] {
        assert!(md.contains(heading), "GPU.md lacks {heading}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("gpu_throughput.json")).unwrap())
            .unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), r.rows.len());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn throughput_refuses_bad_options_with_the_accepted_range() {
    let bin = env!("CARGO_BIN_EXE_pendulum-atlas");
    let cases: [(&[&str], &str); 4] = [
        (&["--throughput", "--max-instances", "10"], "1000..=1000000"),
        (&["--throughput", "--row-budget-s", "0"], "0.1 to 3600"),
        (&["--throughput", "--peak-tflops=-1"], "(0, 10000]"),
        (
            &["--peers", "/tmp"],
            "--peers needs --cpu-throughput or --throughput",
        ),
    ];
    for (args, expect) in cases {
        let out = Command::new(bin)
            .arg("bench")
            .args(args)
            .args(["--out", "/nonexistent/never-written"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} was accepted");
        assert!(err.contains(expect), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// `benches/gpu_lease.sh run --dry`, the device call's script on whatever adapter there is
/// (lavapipe here): every step runs and packs its results.
#[test]
fn the_gpu_lease_script_runs_dry_on_this_adapter() {
    if crate::engine::gpu().is_none() {
        return;
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = std::env::temp_dir().join(format!("pa-gpu-lease-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let out = tmp.join("out");
    let o = Command::new("bash")
        .arg(root.join("benches/gpu_lease.sh"))
        .args(["run", "--dry"])
        .env("OUT", &out)
        .env("GPU_LEASE_WORK", tmp.join("work"))
        .env(
            "PENDULUM_ATLAS_KIT_BIN",
            env!("CARGO_BIN_EXE_pendulum-atlas"),
        )
        // The base build's study runs last; this build stands in for it.
        .env(
            "PENDULUM_ATLAS_KIT_BASE",
            env!("CARGO_BIN_EXE_pendulum-atlas"),
        )
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{log}");
    for f in ["log.txt", "gpu_lease.tar.gz", "GPU.md", "GPU_base.md"] {
        assert!(out.join(f).is_file(), "{f} missing: {log}");
    }
    let study = std::fs::read_to_string(out.join("GPU.md")).unwrap();
    assert!(
        study.contains("| rk4 |") && study.contains("| imex |"),
        "{study}"
    );
    let maps = [
        "map",
        "plane17_thread",
        "parity_gpu",
        "parity_cpu",
        "parity_fixed_thread",
    ];
    for d in maps {
        assert!(
            tmp.join("work").join(d).join("map.json").is_file(),
            "{d}: {log}"
        );
    }
    assert!(
        log.contains("N = 17 plane:") && !log.contains(": rc "),
        "{log}"
    );
    assert!(study.contains("| thread |"), "{study}");
    std::fs::remove_dir_all(&tmp).ok();
}
