//! The GPU ensemble engine against the CPU engine and the analysis library.
//!
//! These tests need a wgpu adapter (lavapipe is enough). Without one they print a skip
//! message, unless PENDULUM_ATLAS_REQUIRE_GPU=1 (as `.ci/run` sets), which makes them fail.

use pendulum_atlas::config::{MapSpec, map_from_toml};
use pendulum_atlas::integrate::ensemble::{EnsemblePlan, run_instance};
use pendulum_atlas::integrate::gpu::{
    AdapterChoice, GpuContext, GpuReadback, GpuRun, REQUIRE_GPU_ENV, run_gpu,
};
use pendulum_atlas::reduce::ReduceOptions;
use std::sync::OnceLock;

/// The shared GPU context, or `None` (skip) when there is no adapter and none is required.
pub fn gpu() -> Option<&'static GpuContext> {
    static CTX: OnceLock<Option<GpuContext>> = OnceLock::new();
    let ctx = CTX.get_or_init(|| match GpuContext::new(AdapterChoice::Any) {
        Ok(c) => Some(c),
        Err(e) => {
            if std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1") {
                panic!("{REQUIRE_GPU_ENV}=1 but no GPU adapter: {e}");
            }
            None
        }
    });
    if ctx.is_none() {
        eprintln!(
            "SKIPPED: no GPU adapter (install mesa-vulkan-drivers for lavapipe; set {REQUIRE_GPU_ENV}=1 to fail instead)"
        );
    }
    ctx.as_ref()
}

/// A small map scene over (f, A) with the given extra TOML.
pub fn tiny_map(extra: &str, axes: &str) -> MapSpec {
    let integration = if extra.contains("[integration]") {
        String::new()
    } else {
        "[integration]\nduration_s = 6.0\ntransient_s = 2.0\n".to_string()
    };
    let text = format!("[beam]\nsegments = 3\n{integration}{extra}\n[map]\n{axes}");
    map_from_toml(&text, "<test>", &[]).expect("valid test map")
}

fn run(ctx: &GpuContext, spec: &MapSpec) -> (EnsemblePlan, GpuRun) {
    let plan = EnsemblePlan::new(spec).expect("plan");
    let opts = ReduceOptions::from_spec(spec);
    let run = run_gpu(
        ctx,
        &plan,
        &opts.for_gpu(),
        GpuReadback {
            strobe: true,
            r_series: true,
        },
        &|_, _| {},
    )
    .expect("gpu run");
    (plan, run)
}

const AXES: &str = r#"
[[map.axes]]
key = "excitation.frequency_hz"
start = 5.0
end = 10.0
count = 3
[[map.axes]]
key = "excitation.amplitude_m"
start = 0.009
end = 0.012
count = 2
"#;

fn cpu_raw<T: pendulum_atlas::model::Real>(
    plan: &EnsemblePlan,
) -> Vec<pendulum_atlas::integrate::ensemble::RawInstance> {
    plan.instances
        .iter()
        .map(|p| run_instance::<T>(p, true, true))
        .collect()
}

#[test]
fn holder_angle_over_a_short_horizon_matches_the_cpu_engine() {
    let Some(ctx) = gpu() else { return };
    // 1.3 s with bumper impacts; R's uniform series records α at 16 samples per period.
    let spec = tiny_map(
        "[integration]\nduration_s = 1.3\ntransient_s = 0.2",
        &format!("metrics = [\"R\"]\n{AXES}"),
    );
    let (plan, run) = run(ctx, &spec);
    let stride = plan.r_stride as usize;
    for (name, cpu) in [
        ("f32", cpu_raw::<f32>(&plan)),
        ("f64", cpu_raw::<f64>(&plan)),
    ] {
        for (i, c) in cpu.iter().enumerate() {
            let g = &run.r_series[i * stride..i * stride + c.r_alpha.len()];
            let worst = c
                .r_alpha
                .iter()
                .zip(g)
                .map(|(a, b)| (a - f64::from(*b)).abs())
                .fold(0.0, f64::max);
            assert!(
                worst < 2e-3,
                "instance {i}: GPU α differs from the CPU {name} engine by {worst} rad"
            );
        }
    }
}

#[test]
fn gpu_reductions_equal_the_analysis_library_on_the_same_samples() {
    let Some(ctx) = gpu() else { return };
    let spec = tiny_map("", AXES);
    let (plan, run) = run(ctx, &spec);
    let opts = ReduceOptions::from_spec(&spec);
    let (ss, rs) = (plan.strobe_stride as usize, plan.r_stride as usize);
    for (i, p) in plan.instances.iter().enumerate() {
        let a = &run.accum[i];
        assert_eq!(a.status, 0);
        let strobe: Vec<f64> = run.strobe[i * ss..i * ss + p.strobe_count as usize]
            .iter()
            .map(|&v| f64::from(v))
            .collect();
        let k = pendulum_atlas::reduce::k_of(&strobe, &opts);
        assert!(
            (k - f64::from(a.k)).abs() < 2e-3,
            "instance {i}: K on the GPU {} vs analysis library {k}",
            a.k
        );
        let period = pendulum_atlas::analysis::detect_period(
            &strobe,
            opts.period_max as usize,
            opts.period_window as usize,
            opts.period_tol_rad,
        );
        assert_eq!(a.period as usize, period, "instance {i}: period");
        let alpha: Vec<f64> = run.r_series[i * rs..i * rs + p.r_count as usize]
            .iter()
            .map(|&v| f64::from(v))
            .collect();
        let r = pendulum_atlas::reduce::r_of(p, &alpha, &opts);
        assert!(
            (r - f64::from(a.r)).abs() < 1e-3,
            "instance {i}: R on the GPU {} vs analysis library {r}",
            a.r
        );
    }
}

#[test]
fn gpu_and_cpu_maps_agree_on_classes_and_r() {
    let Some(_) = gpu() else { return };
    let axes = r#"
[[map.axes]]
key = "excitation.frequency_hz"
start = 4.0
end = 12.0
count = 5
[[map.axes]]
key = "excitation.amplitude_m"
start = 0.004
end = 0.02
count = 3
"#;
    let spec = tiny_map("[integration]\nduration_s = 12.0\ntransient_s = 4.0", axes);
    let cpu = pendulum_atlas::map::run_map(
        &spec,
        pendulum_atlas::map::Backend::Cpu,
        pendulum_atlas::map::Precision::F64,
        &|_, _, _| {},
    )
    .expect("cpu map");
    let gpu = pendulum_atlas::map::run_map(
        &spec,
        pendulum_atlas::map::Backend::Gpu,
        pendulum_atlas::map::Precision::F32,
        &|_, _, _| {},
    )
    .expect("gpu map");
    let n = cpu.results.len();
    let same_class = cpu
        .results
        .iter()
        .zip(&gpu.results)
        .filter(|(a, b)| (a.k > 0.5) == (b.k > 0.5))
        .count();
    assert!(
        same_class * 10 >= n * 9,
        "K class agrees on {same_class} of {n} cells"
    );
    let mut dr: Vec<f64> = cpu
        .results
        .iter()
        .zip(&gpu.results)
        .map(|(a, b)| (a.r - b.r).abs())
        .collect();
    dr.sort_by(f64::total_cmp);
    assert!(dr[n / 2] <= 0.05, "median |ΔR| = {}", dr[n / 2]);
    for (a, b) in cpu.results.iter().zip(&gpu.results) {
        assert_eq!(a.status, b.status);
    }
}

#[test]
fn diverging_instances_get_the_same_status_on_both_engines() {
    let Some(ctx) = gpu() else { return };
    // A fixed step that is stable for soft bumpers and far beyond the limit for stiff ones.
    let axes = r#"
[[map.axes]]
key = "limiter.stiffness_n_per_m"
values = [1e3, 1e4, 1e6, 1e7]
"#;
    let spec = tiny_map(
        "[integration]\nduration_s = 4.0\ntransient_s = 1.0\ndt_s = 8e-4",
        &format!("metrics = [\"K\", \"R\", \"hops\"]\n{axes}"),
    );
    let (plan, run) = run(ctx, &spec);
    let cpu = cpu_raw::<f64>(&plan);
    let statuses: Vec<u32> = run.accum.iter().map(|a| a.status).collect();
    for (i, c) in cpu.iter().enumerate() {
        let g = match run.accum[i].status {
            0 => pendulum_atlas::integrate::Status::Ok,
            1 => pendulum_atlas::integrate::Status::Diverged,
            3 => pendulum_atlas::integrate::Status::Escaped,
            _ => pendulum_atlas::integrate::Status::NonFinite,
        };
        assert_eq!(c.status, g, "instance {i}: statuses {statuses:?}");
    }
    assert!(
        statuses[0] == 0 && statuses[3] != 0,
        "statuses {statuses:?}"
    );
    assert!(run.accum[3].k.is_nan() && run.accum[3].r.is_nan());
}

/// Member offsets of a Rust struct, by name.
macro_rules! offsets {
    ($t:ty; $($f:ident),* $(,)?) => {
        vec![$((stringify!($f), std::mem::offset_of!($t, $f))),*]
    };
}

/// (member name, offset) of a WGSL struct, and its size.
fn wgsl_layout(module: &naga::Module, name: &str) -> (Vec<(String, usize)>, usize) {
    for (_, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(name)
            && let naga::TypeInner::Struct { members, span } = &ty.inner
        {
            let m = members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
                .collect();
            return (m, *span as usize);
        }
    }
    panic!("struct {name} not found in the shader");
}

fn assert_same_layout(wgsl: &str, rust: Vec<(&str, usize)>, rust_size: usize) {
    let module = naga::front::wgsl::parse_str(pendulum_atlas::integrate::gpu::ENSEMBLE_WGSL)
        .expect("ensemble.wgsl parses");
    let (members, span) = wgsl_layout(&module, wgsl);
    let names: Vec<&str> = members.iter().map(|(n, _)| n.as_str()).collect();
    let rust_names: Vec<&str> = rust.iter().map(|(n, _)| *n).collect();
    assert_eq!(names, rust_names, "{wgsl}: member names and order");
    for ((n, wo), (_, ro)) in members.iter().zip(&rust) {
        assert_eq!(wo, ro, "{wgsl}.{n}: WGSL offset {wo}, Rust offset {ro}");
    }
    assert_eq!(span, rust_size, "{wgsl}: size");
}

#[test]
fn parameter_structs_have_the_same_layout_in_rust_and_wgsl() {
    use pendulum_atlas::integrate::gpu::layout::{GpuAccum, GpuControl, GpuInstanceParams};
    assert_same_layout(
        "InstanceParams",
        offsets!(GpuInstanceParams; seg_len, seg_mass, seg_inertia, tip_mass, holder_inertia, g,
            k, k0, b, b0, gap, kc, cc, piezo_inv_c, piezo_inv_r, piezo_theta, pos_amp, vel_amp,
            acc_amp, dt, guard_energy, guard_bend, theta0, omega0, volt0, half_clearance,
            guard_holder, pad1, n_levers, piezo_last, spp, transient_periods, total_periods, strobe_offset,
            strobe_count, r_every, r_count, r_start, pad2, pad3, levers),
        std::mem::size_of::<GpuInstanceParams>(),
    );
    assert_same_layout(
        "Accum",
        offsets!(GpuAccum; step, status, touch, well, hops, impacts, period, pad0, alpha_min,
            alpha_max, power_sum, power_comp, k, r, pad1, pad2),
        std::mem::size_of::<GpuAccum>(),
    );
    assert_same_layout(
        "Control",
        offsets!(GpuControl; n_inst, steps_per_dispatch, strobe_stride, rwork_stride,
            period_max, period_window, period_tol, c_index),
        std::mem::size_of::<GpuControl>(),
    );
}

#[test]
fn every_shader_parses_and_validates_without_an_adapter() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).expect("shaders/") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "wgsl") {
            let src = std::fs::read_to_string(&path).expect("readable");
            let module = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&src)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
            seen += 1;
        }
    }
    assert!(seen >= 1, "no .wgsl files in {}", dir.display());
}
