//! What only the CPU engine's SIMD loop has to show: a lane computes what the scalar loop
//! computes (the same operations in the same order; only `sin`/`cos` come from another
//! implementation, a few ulp apart), and its results do not depend on the thread count.

use pendulum_atlas_core::config::{MapSpec, map_from_toml};
use pendulum_atlas_core::engine::{
    CpuLoop, Engine, EngineRun, EnsemblePlan, Precision, Readback, no_progress,
};
use pendulum_atlas_core::model::{
    Chain, ContactLaw, F32x8, F32x16, F64x4, F64x8, Lane, ModelParams, Real,
};
use pendulum_atlas_core::reduce::ReduceOptions;

/// A map of `count` frequencies × 3 amplitudes at N segments (the frequencies give the
/// instances different steps and step counts; 3·count is not a multiple of 4 or 8 when
/// count is odd, so the last lane group is padded).
fn spec(n: usize, count: usize, method: &str, extra: &str) -> MapSpec {
    let text = format!(
        "[beam]\nsegments = {n}\n[integration]\nmethod = \"{method}\"\nduration_s = 0.8\ntransient_s = 0.1\ndt_safety = 0.5\n{extra}\n[map]\nmetrics = [\"R\", \"hops\", \"impacts_per_s\", \"alpha_range\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nstart = 6.0\nend = 10.0\ncount = {count}\n[[map.axes]]\nkey = \"excitation.amplitude_m\"\nstart = 0.009\nend = 0.015\ncount = 3\n"
    );
    map_from_toml(&text, "<test>", &[]).expect("valid test map")
}

fn run(engine: &Engine, spec: &MapSpec) -> EngineRun {
    let plan = EnsemblePlan::new(spec).expect("plan");
    let readback = Readback {
        strobe: false,
        r_series: true,
        ..Readback::default()
    };
    engine
        .run(
            &plan,
            &ReduceOptions::from_spec(spec),
            readback,
            &no_progress,
        )
        .expect("run")
}

/// States with every angle and rate of each lane different, some of them pressing a bumper.
fn state<V: Lane>(n: usize, lane_angle: impl Fn(usize) -> f64) -> Vec<V> {
    (0..2 * n + 1)
        .map(|k| {
            V::gather(|i| match k {
                k if k < n => lane_angle(i) + 0.01 * k as f64,
                k if k < 2 * n => 0.3 * (i as f64 - 1.5) - 0.1 * (k - n) as f64,
                _ => 0.0,
            })
        })
        .collect()
}

/// The instances of a map, one per lane (cycled).
fn lane_params(spec: &MapSpec, lanes: usize) -> Vec<ModelParams> {
    let plan = EnsemblePlan::new(spec).expect("plan");
    (0..lanes)
        .map(|i| plan.instances[i % plan.instances.len()].params.clone())
        .collect()
}

/// The chain's rates at `y` with the cart at −3 m/s², by the exact bumper law.
fn rates_at<V: Lane>(chain: &Chain<V>, y: &[V]) -> Vec<V> {
    let mut dy = y.to_vec();
    chain.rates(
        &mut chain.workspace(),
        V::splat(-3.0),
        y,
        &mut dy,
        ContactLaw::Exact,
    );
    dy
}

/// The largest |lane − scalar| of the chain's rates over the lanes, relative to the rate.
fn rates_gap<V: Lane>(n: usize) -> f64
where
    V::Scalar: Real,
{
    let params = lane_params(&spec(n, 5, "rk4", ""), V::LANES);
    let vector: Chain<V> = Chain::from_lanes(&params);
    // Angles from 0.30 to 0.44 rad: every lane near or past the 20° bumper.
    let y: Vec<V> = state(n, |i| 0.30 + 0.02 * i as f64);
    let dy = rates_at(&vector, &y);
    let mut worst = 0.0f64;
    for (i, p) in params.iter().enumerate() {
        let chain: Chain<V::Scalar> = Chain::new(p);
        let yi: Vec<V::Scalar> = y.iter().map(|v| v.lane(i)).collect();
        let mut di = yi.clone();
        let acc = <V::Scalar as Real>::of(-3.0);
        chain.derivative(&mut chain.workspace(), acc, &yi, &mut di, ContactLaw::Exact);
        for (a, b) in dy.iter().map(|v| v.lane(i)).zip(&di) {
            let (a, b) = (a.wide(), b.wide());
            worst = worst.max((a - b).abs() / b.abs().max(1.0));
        }
    }
    worst
}

#[test]
fn a_lane_computes_the_scalar_chain_rates_within_rounding() {
    for n in [3, 9, 17] {
        let g64 = rates_gap::<F64x4>(n);
        assert!(
            g64 < 1e-12,
            "N = {n}: f64 lanes differ from the scalar by {g64:e}"
        );
        // An ulp of sin in f32 (6e-8) comes out of the N = 17 recursion amplified ~3000 times
        // (1.8e-4 measured); in f64 the same amplification stays below 1e-12.
        let g32 = rates_gap::<F32x8>(n);
        assert!(
            g32 < 1e-3,
            "N = {n}: f32 lanes differ from the scalar by {g32:e}"
        );
    }
}

/// The chain's rates and `sin`/`cos` of the first angle, as bits, of lanes `first .. first +
/// V::LANES` of sixteen (lane `k`: instance `params[k]` at a state of its own).
fn lane_bits<V: Lane>(n: usize, params: &[ModelParams], first: usize) -> Vec<Vec<u64>>
where
    V::Scalar: Real,
{
    let vector: Chain<V> = Chain::from_lanes(&params[first..first + V::LANES]);
    // Every lane's angles from 0.30 + 0.02 k rad (near or past the bumper), its rates apart.
    let y: Vec<V> = (0..2 * n + 1)
        .map(|j| {
            V::gather(|i| {
                let k = (first + i) as f64;
                match j {
                    j if j < n => 0.30 + 0.02 * k + 0.01 * j as f64,
                    j if j < 2 * n => 0.3 * (k - 1.5) - 0.1 * (j - n) as f64,
                    _ => 0.0,
                }
            })
        })
        .collect();
    let dy = rates_at(&vector, &y);
    let (s, c) = y[0].v_sin_cos();
    (0..V::LANES)
        .map(|i| {
            let values = dy.iter().chain([&s, &c]).map(|v| v.lane(i).wide());
            values.map(f64::to_bits).collect()
        })
        .collect()
}

/// The lanes of sixteen instances computed `V::LANES` at a time.
fn all_lanes<V: Lane>(n: usize, params: &[ModelParams]) -> Vec<Vec<u64>>
where
    V::Scalar: Real,
{
    (0..16)
        .step_by(V::LANES)
        .flat_map(|first| lane_bits::<V>(n, params, first))
        .collect()
}

/// The wider vectors the engine takes where AVX-512 is compiled in (`F64Lanes`, `F32Lanes`)
/// compute, lane for lane, what the narrower ones compute, bit for bit: the chain's rates and
/// the vector `sin`/`cos`. So a map's numbers do not depend on the vector width.
#[test]
fn a_wider_vector_computes_what_a_narrower_one_does_bit_for_bit() {
    for n in [3, 9, 17] {
        let params = lane_params(&spec(n, 5, "rk4", ""), 16);
        let f64x8 = all_lanes::<F64x8>(n, &params);
        assert_eq!(f64x8, all_lanes::<F64x4>(n, &params), "N = {n}, f64");
        let f32x16 = all_lanes::<F32x16>(n, &params);
        assert_eq!(f32x16, all_lanes::<F32x8>(n, &params), "N = {n}, f32");
        assert_eq!(f32x16.len(), 16);
    }
}

/// The largest |Δα| (rad) between the loops' R series, and whether their tallies agree.
fn loops_gap(precision: Precision, spec: &MapSpec) -> f64 {
    let scalar = run(&Engine::cpu_with(precision, CpuLoop::Scalar), spec);
    let simd = run(&Engine::cpu_with(precision, CpuLoop::Simd), spec);
    let mut worst = 0.0f64;
    for (i, (a, b)) in scalar.r_series.iter().zip(&simd.r_series).enumerate() {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            worst = worst.max((x - y).abs());
        }
        let (ra, rb) = (&scalar.results[i], &simd.results[i]);
        assert_eq!((ra.status, ra.steps), (rb.status, rb.steps), "instance {i}");
        assert_eq!(ra.hops, rb.hops, "instance {i}: hops");
    }
    assert_eq!(scalar.r_series.len(), spec.instances());
    worst
}

#[test]
fn simd_and_scalar_loops_agree_over_a_short_horizon_with_impacts() {
    // 0.8 s with bumper impacts, 15 instances of 5 different steps (3 lane groups of 4 in
    // f64, the last padded; 2 groups of 8 in f32), RK4 and the IMEX method.
    for method in ["rk4", "imex"] {
        let s = spec(3, 5, method, "");
        let g64 = loops_gap(Precision::F64, &s);
        assert!(g64 < 1e-9, "{method} f64: |Δα| up to {g64:e} rad");
        let g32 = loops_gap(Precision::F32, &s);
        assert!(g32 < 2e-3, "{method} f32: |Δα| up to {g32:e} rad");
    }
}

/// Adaptive steps of both pairs in the lanes: each lane climbs its own ladder (IMEX with its
/// own S⁻¹ at its level), and gets the scalar loop's sub-steps and results (15 instances
/// through impacts, groups padded; IMEX's groups are one frequency's, 3 lanes of 4 or 8).
#[test]
fn simd_lanes_take_the_scalar_loops_adaptive_steps() {
    for method in ["rk4", "imex"] {
        let s = spec(3, 5, method, "step = \"adaptive\"");
        let g64 = loops_gap(Precision::F64, &s);
        assert!(g64 < 1e-9, "adaptive {method} f64: |Δα| up to {g64:e} rad");
        let g32 = loops_gap(Precision::F32, &s);
        assert!(g32 < 2e-3, "adaptive {method} f32: |Δα| up to {g32:e} rad");
    }
    let s = spec(5, 3, "imex", "step = \"adaptive\"");
    let g = loops_gap(Precision::F64, &s);
    assert!(g < 1e-9, "adaptive imex N = 5 f64: |Δα| up to {g:e} rad");
}

/// λ1's twins in adaptive lanes follow their lane's sub-steps with the lane's pair (IMEX: its
/// S⁻¹ at the lane's level) and get the scalar loop's λ1: impacting periodic orbits near the
/// engine suite's 4 Hz / 4 mm cell (on a chaotic cell a few ulp of sin grow e^(λ1 t)).
#[test]
fn adaptive_lanes_twins_give_the_scalar_loops_lyapunov_exponent() {
    for method in ["rk4", "imex"] {
        let text = format!(
            "[beam]\nsegments = 3\n[integration]\nmethod = \"{method}\"\nstep = \"adaptive\"\nduration_s = 12.0\ntransient_s = 4.0\n[map]\nmetrics = [\"period\", \"lyapunov\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [4.0]\n[[map.axes]]\nkey = \"excitation.amplitude_m\"\nstart = 0.0032\nend = 0.0040\ncount = 5\n"
        );
        let s = map_from_toml(&text, "<test>", &[]).expect("valid test map");
        let scalar = run(&Engine::cpu_with(Precision::F64, CpuLoop::Scalar), &s);
        let simd = run(&Engine::cpu_with(Precision::F64, CpuLoop::Simd), &s);
        for (i, (a, b)) in scalar.results.iter().zip(&simd.results).enumerate() {
            assert!(a.lyapunov_per_s < 0.0, "{method} instance {i}: {a:?}");
            // Measured: 5e-8 of λ1 at most (sin/cos a few ulp apart).
            let gap = (a.lyapunov_per_s - b.lyapunov_per_s).abs();
            assert!(
                gap <= 1e-6 * a.lyapunov_per_s.abs(),
                "{method} instance {i}: λ1 {} on the scalar loop, {} in lanes",
                a.lyapunov_per_s,
                b.lyapunov_per_s
            );
        }
    }
}

#[test]
fn simd_loop_handles_the_piezo_and_nine_segments() {
    let piezo = "[piezo]\nenabled = true";
    let g = loops_gap(Precision::F64, &spec(9, 3, "imex", piezo));
    assert!(g < 1e-9, "N = 9 with the piezo: |Δα| up to {g:e} rad");
}

#[test]
fn simd_results_do_not_depend_on_the_thread_count() {
    let s = spec(3, 7, "rk4", "");
    let engine = Engine::cpu(Precision::F32);
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| run(&engine, &s))
    };
    let (one, three) = (on(1), on(3));
    for (a, b) in one.results.iter().zip(&three.results) {
        assert_eq!(a.r.to_bits(), b.r.to_bits());
        assert_eq!((a.status, a.steps, a.hops), (b.status, b.steps, b.hops));
    }
    for (a, b) in one.r_series.iter().zip(&three.r_series) {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(a), bits(b));
    }
}

/// `auto` without a hardware GPU is the CPU engine in f64 by rule, never a timing against the
/// software adapter (issue 71: a probe let a loaded machine switch a map to f32 lanes, so the
/// same command gave other numbers from one run to the next); f32 only when asked for, and a
/// tolerance f32 does not resolve keeps f64 even where a GPU is.
#[test]
fn auto_without_a_hardware_gpu_is_the_cpu_engine_in_f64_by_rule() {
    use pendulum_atlas_core::config::StepControl;
    use pendulum_atlas_core::engine::{Backend, EngineKind};
    let Some(gpu) = super::gpu() else { return };
    if !gpu.gpu_context().is_some_and(|c| c.is_software) {
        eprintln!("SKIPPED: the adapter is hardware; auto takes it");
        return;
    }
    for _ in 0..3 {
        let auto = Engine::open(Backend::Auto, None).expect("auto");
        assert_eq!(auto.info().kind, EngineKind::Cpu, "{}", auto.info().reason);
        assert_eq!(auto.info().precision, Precision::F64);
        assert!(
            auto.info().reason.contains("no hardware GPU"),
            "{}",
            auto.info().reason
        );
    }
    let f32 = Engine::open(Backend::Auto, Some(Precision::F32)).expect("auto f32");
    assert_eq!(
        (f32.info().kind, f32.info().precision),
        (EngineKind::Cpu, Precision::F32)
    );
    let fine = StepControl::Adaptive {
        rtol: 1e-6,
        atol: 1e-9,
    };
    let auto = Engine::open_for(Backend::Auto, None, fine).expect("auto, fine tolerance");
    assert_eq!(
        (auto.info().kind, auto.info().precision),
        (EngineKind::Cpu, Precision::F64)
    );
    assert!(
        auto.info().reason.contains("needs f64"),
        "{}",
        auto.info().reason
    );
}
