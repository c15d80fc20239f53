//! The GPU kernels are built without wgpu's runtime checks; built with them, they give the
//! same bits.

use super::{EVERY_METHOD_AND_STEP, gpu, gpu_checked};
use pendulum_atlas_core::config::map_from_toml;
use pendulum_atlas_core::engine::{EnsemblePlan, Readback, no_progress};
use pendulum_atlas_core::reduce::{InstanceResult, ReduceOptions};
/// Every number of a result as its bits (NaN for a metric not asked for compares equal).
pub(super) fn bits(r: &InstanceResult) -> Vec<u64> {
    [
        r.k,
        r.r,
        r.period,
        r.line,
        r.alpha_min_rad,
        r.alpha_max_rad,
        r.impacts_per_s,
        r.lyapunov_per_s,
        r.lyapunov_se_per_s,
        r.regime_confidence,
    ]
    .iter()
    .map(|v| v.to_bits())
    .collect()
}

/// The kernels are built without wgpu's runtime checks (every index in range by construction:
/// `GpuContext::module`); built with them, every result and series is the same, bit for bit,
/// on maps that run the twin, the early stop and both methods at fixed and adaptive steps.
#[test]
fn the_kernels_give_the_same_bits_with_and_without_runtime_checks() {
    let (Some(trusted), Some(checked)) = (gpu(), gpu_checked()) else {
        return;
    };
    for (method, step) in EVERY_METHOD_AND_STEP {
        let text = format!(
            "[beam]\nsegments = 3\n[integration]\nduration_s = 20.0\ntransient_s = 2.0\n\
method = \"{method}\"\nstep = \"{step}\"\n[map]\nsettle = false\nlyapunov_window_s = 6.0\n\
[[map.axes]]\nkey = \"excitation.frequency_hz\"\nstart = 6.0\nend = 11.0\ncount = 3\n\
[[map.axes]]\nkey = \"excitation.amplitude_m\"\nvalues = [0.001, 0.012]\n"
        );
        let spec = map_from_toml(&text, "<test>", &[]).expect("map");
        let plan = EnsemblePlan::new(&spec).expect("plan");
        let readback = Readback {
            strobe: true,
            r_series: true,
            ..Readback::default()
        };
        let opts = ReduceOptions::from_spec(&spec);
        let a = trusted
            .run(&plan, &opts, readback, &no_progress)
            .expect("unchecked");
        let b = checked
            .run(&plan, &opts, readback, &no_progress)
            .expect("checked");
        for (i, (x, y)) in a.results.iter().zip(&b.results).enumerate() {
            assert_eq!(
                (x.status, x.regime, x.steps),
                (y.status, y.regime, y.steps),
                "{method} {step} {i}"
            );
            assert_eq!(bits(x), bits(y), "{method} {step} {i}: {x:?} vs {y:?}");
        }
        assert_eq!(a.strobe, b.strobe, "{method} {step}: stroboscopic samples");
        assert_eq!(a.r_series, b.r_series, "{method} {step}: R series");
    }
}
