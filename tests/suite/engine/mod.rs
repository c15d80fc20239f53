//! One suite for every engine and method: the same test bodies ([`cases`]) run on the CPU
//! engine's scalar loop in f64 (the reference), its SIMD loop in f64 and in f32, and on the GPU
//! engine, each with RK4 and with the IMEX method, so parity is a property of the suite, not a
//! special test. [`lanes`] adds what only the SIMD loop has to show (lane-for-lane agreement
//! with the scalar loop, results independent of the thread count).
//!
//! The GPU needs a wgpu adapter (lavapipe is enough). Without one its tests print a skip
//! message, unless PENDULUM_ATLAS_REQUIRE_GPU=1 (as `.ci/run` sets), which makes them fail.

mod attractors;
mod batches;
mod cases;
mod continuation;
mod faults;
mod lanes;
mod layout;
mod runtime_checks;
mod skip;
pub(crate) mod verdict;

use pendulum_atlas_core::config::MapSpec;
use pendulum_atlas_core::engine::gpu::REQUIRE_GPU_ENV;
use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_core::engine::{Backend, CpuLoop, Engine, Precision, no_progress};
use pendulum_atlas_map::map::{MapRun, run_map};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// The engines the suite runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Eng {
    /// The CPU engine's scalar loop in f64: the reference of the others.
    CpuF64,
    /// The CPU engine's SIMD loop in f64 (4 lanes).
    SimdF64,
    /// The CPU engine's SIMD loop in f32 (8 lanes).
    SimdF32,
    /// The GPU engine (f32).
    Gpu,
}

/// An engine, an integration method and a step control.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Under {
    /// The engine.
    pub eng: Eng,
    /// The method every scene of the case asks for.
    pub method: Method,
    /// Adaptive steps (`integration.step = "adaptive"`) instead of fixed ones.
    pub adaptive: bool,
}

impl Under {
    /// The engine, or `None` (skip) for the GPU when there is no adapter and none is required.
    pub fn engine(self) -> Option<&'static Engine> {
        static CPU64: OnceLock<Engine> = OnceLock::new();
        static SIMD64: OnceLock<Engine> = OnceLock::new();
        static SIMD32: OnceLock<Engine> = OnceLock::new();
        match self.eng {
            Eng::CpuF64 => {
                Some(CPU64.get_or_init(|| Engine::cpu_with(Precision::F64, CpuLoop::Scalar)))
            }
            Eng::SimdF64 => Some(SIMD64.get_or_init(|| Engine::cpu(Precision::F64))),
            Eng::SimdF32 => Some(SIMD32.get_or_init(|| Engine::cpu(Precision::F32))),
            Eng::Gpu => gpu(),
        }
    }

    /// Single precision: the looser parity tolerances apply.
    pub fn is_f32(self) -> bool {
        matches!(self.eng, Eng::SimdF32 | Eng::Gpu)
    }

    /// The CPU engine in f64 with the same method and step control: the reference of the
    /// comparisons.
    pub fn reference(self) -> Under {
        Under {
            eng: Eng::CpuF64,
            ..self
        }
    }

    /// The map of `spec` on this engine, or `None` (skip) as [`Under::engine`], run once per
    /// suite process: the parity cases of every engine compare themselves with the same
    /// reference maps, and several cases read the same map of one engine. A case that asks
    /// for a map another case is running waits for it. The key is the engine and method with
    /// the whole validated spec (its `Debug` text), so two cases share a map only when it is
    /// the same map on the same engine. On the reference engine a parity case therefore
    /// compares the reference with itself: there it checks only its own conditions (enough
    /// cells robust to the twins), where before it also met a second run of the scalar loop.
    pub fn map(self, spec: &MapSpec) -> Option<Arc<MapRun>> {
        type Memo = Mutex<HashMap<String, Arc<OnceLock<Arc<MapRun>>>>>;
        static MEMO: OnceLock<Memo> = OnceLock::new();
        let engine = self.engine()?;
        let key = format!("{self:?}|{spec:?}");
        let slot = MEMO
            .get_or_init(Memo::default)
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(key)
            .or_default()
            .clone();
        let run = slot.get_or_init(|| Arc::new(run_map(spec, engine, &no_progress).expect("map")));
        Some(run.clone())
    }

    /// The map of `spec` on the reference engine ([`Under::reference`]), shared as
    /// [`Under::map`].
    pub fn reference_map(self, spec: &MapSpec) -> Arc<MapRun> {
        self.reference().map(spec).expect("the CPU engine")
    }

    /// The scene overrides that select the method and the step control.
    pub fn sets(self) -> Vec<String> {
        let mut sets = vec![format!("integration.method={}", self.method.name())];
        let step = if self.adaptive { "adaptive" } else { "fixed" };
        sets.push(format!("integration.step=\"{step}\""));
        sets
    }
}

/// Each integration method with each step control, as `integration.method` and
/// `integration.step` name them.
pub const EVERY_METHOD_AND_STEP: [(&str, &str); 4] = [
    ("rk4", "fixed"),
    ("imex", "fixed"),
    ("rk4", "adaptive"),
    ("imex", "adaptive"),
];

/// The shared GPU engine, or `None` (skip) when there is no adapter and none is required.
pub fn gpu() -> Option<&'static Engine> {
    static GPU: OnceLock<Option<Engine>> = OnceLock::new();
    let e = GPU.get_or_init(|| match Engine::open(Backend::Gpu, None) {
        Ok(e) => Some(e),
        Err(e) => {
            if std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1") {
                panic!("{REQUIRE_GPU_ENV}=1 but no GPU adapter: {e}");
            }
            None
        }
    });
    if e.is_none() {
        eprintln!(
            "SKIPPED: no GPU adapter (install mesa-vulkan-drivers for lavapipe; set {REQUIRE_GPU_ENV}=1 to fail instead)"
        );
    }
    e.as_ref()
}

/// A GPU engine of its own whose kernels are built with wgpu's runtime checks, or `None` as
/// [`gpu`].
pub fn gpu_checked() -> Option<&'static Engine> {
    static GPU: OnceLock<Option<Engine>> = OnceLock::new();
    gpu()?;
    GPU.get_or_init(|| {
        let mut e = Engine::open(Backend::Gpu, None).ok()?;
        e.set_gpu_runtime_checks(true);
        Some(e)
    })
    .as_ref()
}

/// The same tests of `cases` (a module of this suite) for one engine and one method.
macro_rules! engine_method {
    ($cases:ident, $module:ident, $eng:ident, $method:ident, [$($case:ident),*]) => {
        mod $module {
            use super::{Eng, Under};
            use pendulum_atlas_core::engine::method::Method;
            const UNDER: Under = Under { eng: Eng::$eng, method: Method::$method, adaptive: false };
            $(#[test] fn $case() { super::$cases::$case(UNDER) })*
        }
    };
}

/// The same tests as [`engine_suite`] on every engine but the GPU with IMEX, for the cases
/// whose subject sits above the integration (λ1's run-length and separation checks, the early
/// stop): on lavapipe the cases took 726 s of test time with IMEX against 62 s with RK4 (the
/// CPU engine: 264 s against 72 s), and the five cases this set then held (refinement and
/// the basin picture with these three) took 417 s of the suite's 1965 s of test time on the
/// GPU with IMEX. The GPU's IMEX numbers are held to
/// the f64 CPU engine's by the parity cases that stay on it (`maps_agree_…`,
/// `lyapunov_agrees_…`, the adaptive suite's early stop and bistable cell), and the subjects
/// themselves to every other engine by these.
macro_rules! engine_suite_but_gpu_imex {
    ($cases:ident: $($case:ident),* $(,)?) => {
        engine_method!($cases, cpu_f64_rk4, CpuF64, Rk4, [$($case),*]);
        engine_method!($cases, simd_f64_rk4, SimdF64, Rk4, [$($case),*]);
        engine_method!($cases, simd_f32_rk4, SimdF32, Rk4, [$($case),*]);
        engine_method!($cases, gpu_rk4, Gpu, Rk4, [$($case),*]);
        engine_method!($cases, cpu_f64_imex, CpuF64, Imex, [$($case),*]);
        engine_method!($cases, simd_f64_imex, SimdF64, Imex, [$($case),*]);
        engine_method!($cases, simd_f32_imex, SimdF32, Imex, [$($case),*]);
    };
}

/// The same tests on the SIMD loops with both methods and on the GPU with RK4, for the cases
/// whose subject is the map's planner (refinement, the basin picture, continuation's
/// hysteresis): what they check is where the planner puts the cells and what it makes of
/// their results, the same on every engine. The scalar f64 loop is left out as well as the
/// GPU with IMEX: a SIMD lane computes what the scalar loop computes (`lanes`), and the
/// scalar loop is the slowest engine (on 2 cores these cases took 133 s of test time on it,
/// and sweeping down 28 s on lavapipe with IMEX). The scalar loop and the GPU's IMEX are held
/// to the others by the parity cases and by the cases above the step that stay on them (the
/// early stop, λ1's run-length and separation checks, the state a continued cell starts from).
macro_rules! engine_suite_of_the_planner {
    ($cases:ident: $($case:ident),* $(,)?) => {
        engine_method!($cases, simd_f64_rk4, SimdF64, Rk4, [$($case),*]);
        engine_method!($cases, simd_f32_rk4, SimdF32, Rk4, [$($case),*]);
        engine_method!($cases, gpu_rk4, Gpu, Rk4, [$($case),*]);
        engine_method!($cases, simd_f64_imex, SimdF64, Imex, [$($case),*]);
        engine_method!($cases, simd_f32_imex, SimdF32, Imex, [$($case),*]);
    };
}

/// The same tests of `cases`, one module per engine and method.
macro_rules! engine_suite {
    ($cases:ident: $($case:ident),* $(,)?) => {
        engine_suite_but_gpu_imex!($cases: $($case),*);
        engine_method!($cases, gpu_imex, Gpu, Imex, [$($case),*]);
    };
}

/// The same tests of `cases` (a module of this suite) with adaptive steps, for one engine and
/// one method.
macro_rules! engine_adaptive_method {
    ($cases:ident, $module:ident, $eng:ident, $method:ident, [$($case:ident),*]) => {
        mod $module {
            use super::{Eng, Under};
            use pendulum_atlas_core::engine::method::Method;
            const UNDER: Under = Under { eng: Eng::$eng, method: Method::$method, adaptive: true };
            $(#[test] fn $case() { super::$cases::$case(UNDER) })*
        }
    };
}

/// The same tests of `cases` with adaptive steps, one module per engine and pair (IMEX, and
/// RK4 with its embedded third-order solution): the scalar loop in f64 (the reference), the
/// SIMD lanes in f32 (each lane its own ladder), and the GPU.
macro_rules! engine_adaptive {
    ($cases:ident: $($case:ident),* $(,)?) => {
        engine_adaptive_method!($cases, cpu_f64_adaptive_imex, CpuF64, Imex, [$($case),*]);
        engine_adaptive_method!($cases, cpu_f32_adaptive_imex, SimdF32, Imex, [$($case),*]);
        engine_adaptive_method!($cases, gpu_adaptive_imex, Gpu, Imex, [$($case),*]);
        engine_adaptive_method!($cases, cpu_f64_adaptive_rk4, CpuF64, Rk4, [$($case),*]);
        engine_adaptive_method!($cases, cpu_f32_adaptive_rk4, SimdF32, Rk4, [$($case),*]);
        engine_adaptive_method!($cases, gpu_adaptive_rk4, Gpu, Rk4, [$($case),*]);
    };
}

/// The parity cases and the features that ride on the step loop, with adaptive steps.
mod adaptive_suite {
    use super::{Eng, Under};
    mod general {
        use super::super::cases;
        use super::{Eng, Under};
        engine_adaptive!(cases:
            holder_angle_over_a_short_horizon_matches_the_reference_integrator,
            reductions_equal_the_analysis_library_on_the_engines_own_series,
            maps_agree_with_the_f64_cpu_engine_on_classes_r_and_statuses,
            metrics_not_requested_are_not_computed,
            a_map_runs_end_to_end_into_its_files,
        );
    }
    mod skip {
        use super::super::skip;
        use super::{Eng, Under};
        engine_adaptive!(skip: a_map_with_the_early_stop_equals_the_map_without_it);
    }
    mod continuation {
        use super::super::continuation;
        use super::{Eng, Under};
        engine_adaptive!(continuation: a_continued_cell_starts_exactly_where_its_neighbour_ended);
    }
    mod verdict {
        use super::super::verdict;
        use super::{Eng, Under};
        engine_adaptive!(verdict:
            lyapunov_of_a_linear_response_is_the_least_damped_eigenvalue,
            lyapunov_agrees_with_the_f64_cpu_engine,
        );
    }
    mod attractors {
        use super::super::attractors;
        use super::{Eng, Under};
        engine_adaptive!(attractors: a_bistable_cell_shows_the_attractor_of_each_well);
    }
}

/// The λ1 and verdict cases, in modules of their own beside the general cases.
mod verdict_suite {
    use super::verdict;
    use super::{Eng, Under};
    engine_suite!(verdict:
        lyapunov_of_a_linear_response_is_the_least_damped_eigenvalue,
        lyapunov_of_an_impacting_periodic_orbit_is_its_floquet_exponent,
        lyapunov_agrees_with_the_f64_cpu_engine,
        the_verdict_follows_the_rule_on_the_engines_own_numbers,
    );
    mod long {
        use super::verdict;
        use super::{Eng, Under};
        engine_suite_but_gpu_imex!(verdict:
            lyapunov_of_a_chaotic_cell_is_positive_and_keeps_when_the_run_doubles,
            lyapunov_does_not_depend_on_the_separation_across_decades,
        );
    }
}

/// Several starts per cell: attractors, basins.
mod attractor_suite {
    use super::attractors;
    use super::{Eng, Under};
    engine_suite!(attractors:
        a_bistable_cell_shows_the_attractor_of_each_well,
        a_mirrored_start_with_half_a_period_of_phase_lands_on_the_mirrored_attractor,
    );
    mod long {
        use super::attractors;
        use super::{Eng, Under};
        engine_suite_of_the_planner!(attractors: a_basin_picture_agrees_with_the_starts_estimate);
    }
}

/// Continuation: the state carried from cell to cell, hysteresis.
mod continuation_suite {
    use super::continuation;
    use super::{Eng, Under};
    engine_suite!(continuation: a_continued_cell_starts_exactly_where_its_neighbour_ended);
    mod hysteresis {
        use super::continuation;
        use super::{Eng, Under};
        engine_suite_of_the_planner!(continuation:
            sweeping_down_keeps_a_period_two_orbit_that_sweeping_up_never_reaches,
        );
    }
}

/// The early stop and refinement cases.
mod skip_suite {
    use super::skip;
    use super::{Eng, Under};
    engine_suite_but_gpu_imex!(skip: a_map_with_the_early_stop_equals_the_map_without_it);
    mod refinement {
        use super::skip;
        use super::{Eng, Under};
        engine_suite_of_the_planner!(skip:
            a_refined_map_keeps_its_computed_cells_and_fills_only_uniform_blocks,
        );
    }
}

engine_suite!(cases:
    holder_angle_over_a_short_horizon_matches_the_reference_integrator,
    reductions_equal_the_analysis_library_on_the_engines_own_series,
    maps_agree_with_the_f64_cpu_engine_on_classes_r_and_statuses,
    diverging_instances_are_flagged_like_on_the_f64_cpu_engine,
    step_beyond_the_stability_limit_is_flagged_not_returned,
    violent_forcing_up_to_a_tenth_of_a_metre_and_fifty_hertz,
    clearances_from_half_a_degree_to_sixty_and_stiff_bumpers,
    sixty_four_segments_integrate,
    ten_thousand_forcing_periods_keep_the_phase_and_the_energy,
    metrics_not_requested_are_not_computed,
    a_map_runs_end_to_end_into_its_files,
    a_cancel_from_the_progress_callback_stops_the_map,
);

/// The search end to end on every engine with RK4, and with IMEX in the SIMD lanes: the
/// search sits above the engines, whose parity with both methods the cases above hold. The
/// IMEX searches of the scalar loop and of lavapipe took 84 s and 80 s of CI between them.
mod search_suite {
    use super::cases;
    use super::{Eng, Under};
    engine_method!(
        cases,
        cpu_f64_rk4,
        CpuF64,
        Rk4,
        [a_search_runs_end_to_end_and_agrees_with_single_runs]
    );
    engine_method!(
        cases,
        simd_f64_rk4,
        SimdF64,
        Rk4,
        [a_search_runs_end_to_end_and_agrees_with_single_runs]
    );
    engine_method!(
        cases,
        simd_f32_rk4,
        SimdF32,
        Rk4,
        [a_search_runs_end_to_end_and_agrees_with_single_runs]
    );
    engine_method!(
        cases,
        gpu_rk4,
        Gpu,
        Rk4,
        [a_search_runs_end_to_end_and_agrees_with_single_runs]
    );
    engine_method!(
        cases,
        simd_f64_imex,
        SimdF64,
        Imex,
        [a_search_runs_end_to_end_and_agrees_with_single_runs]
    );
}
