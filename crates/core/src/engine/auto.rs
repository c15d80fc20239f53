//! What `--backend auto` runs when the only GPU adapter is a software one (lavapipe, on the
//! same CPU cores as the CPU engine): the faster of the two, measured on this machine at
//! open time, not assumed.
//!
//! The probe is a slice of the embedded default map ([`probe_plan`]: 128 of its instances at
//! 11–12 Hz over 10 s, every metric) timed end to end on each engine after one warm-up run; the CPU
//! engine is tried in `f64` first (the more accurate, kept when it is at least as fast), then
//! in `f32` unless `f64` was asked for. A hardware GPU is taken without a probe.

use crate::config::{DEFAULT_MAP_TOML, map_from_toml};
use crate::engine::{Engine, EnsemblePlan, Precision, Readback, no_progress};
use crate::reduce::ReduceOptions;
use std::time::Instant;

/// Instances of the probe.
const PROBE_INSTANCES: usize = 128;

/// The probe: 128 instances of the default map with every one of its metrics (lavapipe's cost
/// is mostly its reductions), on the plane's fast end (11–12 Hz) so that 10 s give K its 95
/// stroboscopic samples.
fn probe_plan() -> Option<EnsemblePlan> {
    let text = DEFAULT_MAP_TOML.replace("start = 4.0", "start = 11.0");
    let sets = [
        "integration.duration_s=10.0".to_string(),
        "integration.transient_s=0.5".to_string(),
        // λ1 over the probe's whole run: the default map's 12 s window does not fit in 10 s.
        "map.lyapunov_window_s=\"whole\"".to_string(),
    ];
    let spec = map_from_toml(&text, "configs/maps/default.toml", &sets).ok()?;
    let plan = EnsemblePlan::new(&spec).ok()?;
    let total = plan.instances.len();
    let members: Vec<usize> = (0..PROBE_INSTANCES.min(total))
        .map(|i| i * total / PROBE_INSTANCES)
        .collect();
    Some(plan.select(&members))
}

/// Wall time (s) of the probe on `engine`, after a warm-up run; `None` if it fails.
fn probe_s(engine: &Engine, plan: &EnsemblePlan) -> Option<f64> {
    let opts = ReduceOptions::default();
    let run = || engine.run(plan, &opts, Readback::default(), &no_progress);
    run().ok()?;
    let t0 = Instant::now();
    run().ok()?;
    Some(t0.elapsed().as_secs_f64())
}

/// The faster of the software adapter `gpu` and the CPU engine (in `f64` if it is as fast,
/// else `f32`, unless `precision` fixes it), with the measured times in its reason.
pub(super) fn faster_of(gpu: Engine, precision: Option<Precision>) -> Engine {
    let Some(plan) = probe_plan() else {
        let mut gpu = gpu;
        gpu.info.reason = format!(
            "auto: software adapter `{}` (the probe against the CPU engine could not be planned)",
            gpu.info.device
        );
        return gpu;
    };
    let Some(gpu_s) = probe_s(&gpu, &plan) else {
        return Engine::cpu_because(
            precision.unwrap_or(Precision::F64),
            format!(
                "auto: the software adapter `{}` failed the probe: CPU engine",
                gpu.info().device
            ),
        );
    };
    let tries: &[Precision] = match precision {
        Some(p) => &[p][..],
        None => &[Precision::F64, Precision::F32],
    };
    for &p in tries {
        let cpu = Engine::cpu(p);
        if let Some(cpu_s) = probe_s(&cpu, &plan)
            && cpu_s <= gpu_s
        {
            let why = format!(
                "auto: measured here, the CPU engine ({} SIMD) ran a probe of {} instances in {:.3} s, the software adapter `{}` in {:.3} s",
                p.name(),
                plan.instances.len(),
                cpu_s,
                gpu.info().device,
                gpu_s
            );
            return Engine::cpu_because(p, why);
        }
    }
    let mut gpu = gpu;
    gpu.info.reason = format!(
        "auto: no hardware GPU; measured here, the software adapter `{}` ran a probe of {} instances in {:.3} s, faster than the CPU engine",
        gpu.info.device,
        plan.instances.len(),
        gpu_s
    );
    gpu
}
