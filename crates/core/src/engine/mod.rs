//! The engine layer: an ensemble plan in, per-instance results out, on the CPU or the GPU.
//!
//! Stages, in the order a run goes through them:
//! 1. [`EnsemblePlan`] ([`plan`]): every instance's step, sampling and records, from validated
//!    scenes; [`StepPlan`] does the same for a single run;
//! 2. [`Engine::open`]: the engine is chosen and opened once by the caller (a GPU device and
//!    its compiled kernels live in [`gpu::GpuContext`] and are reused by every batch);
//! 3. [`Engine::run`]: both engines implement `EnsembleEngine`: the CPU engine ([`cpu`],
//!    rayon, `f32`/`f64`) runs the shared step loop of [`stepper`] with [`rk4`]; the GPU engine ([`gpu`],
//!    WGSL, `f32`) mirrors it in `shaders/`; each reduces its instances to
//!    [`crate::reduce::InstanceResult`]s;
//! 4. single runs ([`integrate`], [`integrate_reference`]) hand every output row to an
//!    [`Observer`]: RK4, and the DOP853 reference with contact events; [`run_scene`] runs a
//!    scene with the integrator its user chose (`simulate`, the Python package).
//!
//! The health rules, status codes, check interval and cart motion are defined once in
//! [`crate::model`]; the physics is written down in `docs/model.md`.

pub mod adaptive;
pub mod cpu;
pub mod early;
mod early_rule;
mod error;
pub mod gpu;
pub mod imex;
pub mod ladder;
pub mod method;
pub mod plan;
mod reference;
pub mod rk4;
pub(crate) mod scene_run;
mod single;
pub(crate) mod state_view;
mod step_plan;
pub mod stepper;
pub mod twin;

pub use cpu::{CpuEngine, CpuLoop};
pub use early_rule::EarlyStop;
pub use error::{EngineError, GpuFaultKind};
pub use gpu::{GpuContext, GpuEngine};
pub use plan::{EnsembleOptions, EnsemblePlan, InstancePlan};
pub use reference::{ReferenceOptions, integrate_reference};
pub use scene_run::{Integrator, RunLyapunov, SceneRun, run_scene};
pub(crate) use single::integrate_with_twin;
pub use single::{
    Instance, NoObserver, Observer, Outcome, POLL_STEPS, SingleTwin, integrate, integrate_batch,
};
pub use step_plan::{DtSource, StepPlan};

use crate::reduce::{InstanceResult, ReduceOptions};
use serde::{Deserialize, Serialize};
use std::ops::ControlFlow;
use std::time::Instant;

/// Which engine a user asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// A hardware GPU if present (in f32, unless f64 is asked for); else the CPU engine, in
    /// f64 unless f32 is asked for. A rule, never a timing: the same command gives the same
    /// numbers on the same machine however loaded it is. A software adapter (lavapipe) runs
    /// only when asked for (`Gpu`).
    Auto,
    /// The GPU engine (wgpu): a hardware adapter, or lavapipe when that is all there is.
    Gpu,
    /// The CPU engine (rayon).
    Cpu,
}

/// Float type of an engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision, as the GPU integrates.
    F32,
    /// Double precision: the reference.
    F64,
}

impl Precision {
    /// "f32" or "f64".
    pub fn name(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

/// Which engine ran.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EngineKind {
    /// The CPU engine.
    Cpu,
    /// The GPU engine.
    Gpu,
}

impl EngineKind {
    /// "cpu" or "gpu".
    pub fn name(self) -> &'static str {
        match self {
            EngineKind::Cpu => "cpu",
            EngineKind::Gpu => "gpu",
        }
    }
}

/// What an opened engine is, and why it was chosen.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EngineInfo {
    /// CPU or GPU.
    pub kind: EngineKind,
    /// Float type of the integration.
    pub precision: Precision,
    /// The GPU adapter's name, or the CPU's thread count.
    pub device: String,
    /// Why this engine runs.
    pub reason: String,
    /// Wall time of opening it (the GPU device; 0 for the CPU) (s).
    pub open_s: f64,
    /// The CPU engine's loop (scalar or SIMD lanes); `None` on the GPU.
    #[serde(default)]
    pub cpu_loop: Option<CpuLoop>,
}

/// What counts as one unit of progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgressUnit {
    /// Integration steps of the longest instance (GPU dispatches at fixed steps).
    Steps,
    /// Finished instances (CPU; GPU with adaptive steps).
    Instances,
    /// Runs of a map planned (their scenes read and checked), before any integration.
    Planned,
}

impl ProgressUnit {
    /// "steps", "instances" or "planned".
    pub fn name(self) -> &'static str {
        match self {
            ProgressUnit::Steps => "steps",
            ProgressUnit::Instances => "instances",
            ProgressUnit::Planned => "planned",
        }
    }
}

/// Progress callback: `(done, total, unit)`. It answers whether the run goes on:
/// [`ControlFlow::Break`] cancels it, and the engine returns [`EngineError::Cancelled`] at its
/// next progress point (after the instance, lane group or dispatch in flight).
pub type Progress<'a> = &'a (dyn Fn(u64, u64, ProgressUnit) -> ControlFlow<()> + Sync);

/// A progress callback that shows nothing and never cancels.
pub fn no_progress(_: u64, _: u64, _: ProgressUnit) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

/// Series to bring back besides the results.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Readback {
    /// The stroboscopic α of every instance (bifurcation diagrams, tests).
    pub strobe: bool,
    /// Of those, only each instance's last this many samples (`None`: all). The GPU engine
    /// copies back only the rows that hold them.
    pub strobe_last: Option<u32>,
    /// The uniform α series of R (tests, the bench's trajectory errors).
    pub r_series: bool,
    /// Every instance's state `[θ; θ̇; v]` where it ended (continuation starts the next cell
    /// from it). A run that ended ok ended at a whole number of forcing periods (its last
    /// step, or the period end at which the early stop confirmed its orbit).
    pub final_state: bool,
}

/// Wall time of an engine's stages (s).
#[derive(Debug, Clone, Default, Serialize)]
pub struct EngineTimings {
    /// Integration (on the GPU: every dispatch, its reductions included; see `gpu`).
    pub integrate_s: f64,
    /// Reductions on the host (CPU engine: K, R, period with the analysis library).
    pub reduce_s: f64,
    /// The GPU's own stages.
    pub gpu: Option<gpu::GpuTimings>,
}

/// What an engine returns for a plan.
#[derive(Debug, Clone)]
pub struct EngineRun {
    /// Per-instance results in plan order.
    pub results: Vec<InstanceResult>,
    /// Stroboscopic α per instance (each `strobe_count` long), when read back.
    pub strobe: Vec<Vec<f64>>,
    /// The R series of α per instance (each `r_count` long), when read back.
    pub r_series: Vec<Vec<f64>>,
    /// The state `[θ; θ̇; v]` each instance ended in, when read back.
    pub final_state: Vec<Vec<f64>>,
    /// Wall time per stage.
    pub timings: EngineTimings,
    /// Integration dispatches (GPU).
    pub dispatches: u32,
    /// Instances stopped early on a confirmed periodic orbit (CPU).
    pub stopped_early: usize,
    /// Adaptive steps: the sub-steps tried by every instance together, accepted and rejected
    /// (`None` at fixed steps, where every step is a base step).
    pub sub_steps: Option<u64>,
}

/// Two optional counts added (`None` only where both are).
pub fn add_counts(a: Option<u64>, b: Option<u64>) -> Option<u64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a + b),
        (a, b) => a.or(b),
    }
}

impl EngineRun {
    /// Wall time of the integration alone (the GPU's integration dispatches, without its
    /// reductions) (s).
    pub fn integration_s(&self) -> f64 {
        match &self.timings.gpu {
            Some(g) => g.integrate_s,
            None => self.timings.integrate_s,
        }
    }

    /// Wall time of integration and reductions (s).
    pub fn engine_s(&self) -> f64 {
        match &self.timings.gpu {
            Some(g) => g.integrate_s + g.reduce_s,
            None => self.timings.integrate_s + self.timings.reduce_s,
        }
    }

    /// This run followed by `next` (a later batch of the same plan): results and series in
    /// order, times and dispatches added, the device memory of the larger batch.
    pub fn joined(mut self, next: EngineRun) -> EngineRun {
        self.results.extend(next.results);
        self.strobe.extend(next.strobe);
        self.r_series.extend(next.r_series);
        self.final_state.extend(next.final_state);
        self.timings.integrate_s += next.timings.integrate_s;
        self.timings.reduce_s += next.timings.reduce_s;
        self.timings.gpu = gpu::GpuTimings::join(self.timings.gpu, next.timings.gpu);
        self.dispatches += next.dispatches;
        self.stopped_early += next.stopped_early;
        self.sub_steps = add_counts(self.sub_steps, next.sub_steps);
        self
    }

    /// Instance-steps per second of the integration.
    pub fn instance_steps_per_s(&self) -> f64 {
        let steps: u64 = self.results.iter().map(|r| r.steps).sum();
        steps as f64 / self.integration_s().max(1e-12)
    }
}

/// The one interface of the engines: a plan in, per-instance results out.
pub(crate) trait EnsembleEngine {
    /// Integrate and reduce every instance of `plan`.
    fn run(
        &self,
        plan: &EnsemblePlan,
        reduce: &ReduceOptions,
        readback: Readback,
        progress: Progress,
    ) -> Result<EngineRun, EngineError>;
}

impl EnsembleEngine for CpuEngine {
    fn run(
        &self,
        plan: &EnsemblePlan,
        reduce: &ReduceOptions,
        readback: Readback,
        progress: Progress,
    ) -> Result<EngineRun, EngineError> {
        CpuEngine::run(self, plan, reduce, readback, progress)
    }
}

/// What [`Engine::mark_reused`] adds to an engine's reason.
const REUSED: &str = " (reused: opened by an earlier call of this process)";

/// An opened engine: what the caller creates once and hands to every batch.
pub struct Engine {
    info: EngineInfo,
    inner: EngineImpl,
}

enum EngineImpl {
    Cpu(CpuEngine),
    Gpu(Box<GpuEngine>),
}

impl Engine {
    /// The CPU engine in `precision` (SIMD lanes).
    pub fn cpu(precision: Precision) -> Engine {
        Engine::cpu_because(precision, "requested: the CPU engine".into())
    }

    /// The CPU engine in `precision` with the loop `simd`.
    pub fn cpu_with(precision: Precision, simd: CpuLoop) -> Engine {
        let mut e = Engine::cpu(precision);
        e.set_cpu_loop(simd);
        e
    }

    fn cpu_because(precision: Precision, reason: String) -> Engine {
        let mut e = Engine {
            info: EngineInfo {
                kind: EngineKind::Cpu,
                precision,
                device: String::new(),
                reason,
                open_s: 0.0,
                cpu_loop: None,
            },
            inner: EngineImpl::Cpu(CpuEngine {
                precision,
                simd: CpuLoop::Simd,
            }),
        };
        e.set_cpu_loop(CpuLoop::Simd);
        e
    }

    /// Use the loop `simd` if this is the CPU engine (the GPU engine has none).
    pub fn set_cpu_loop(&mut self, simd: CpuLoop) {
        if let EngineImpl::Cpu(c) = &mut self.inner {
            c.simd = simd;
            self.info.cpu_loop = Some(simd);
            self.info.device = format!(
                "CPU, {} rayon threads, {} loop ({} {} lane{})",
                rayon::current_num_threads(),
                simd.name(),
                simd.lanes(c.precision),
                c.precision.name(),
                if simd.lanes(c.precision) == 1 {
                    ""
                } else {
                    "s"
                },
            );
        }
    }

    /// On the GPU engine, run at most `max` instances at a time (`None`: as many as the
    /// adapter's buffer and dispatch limits allow; larger plans are always split to fit).
    pub fn set_gpu_max_batch(&mut self, max: Option<usize>) {
        if let EngineImpl::Gpu(g) = &mut self.inner {
            g.set_max_batch(max);
        }
    }

    /// On the GPU engine, slice each reduction pass as `slicing` says (`None`: above a size,
    /// by a timed probe to the dispatch target). For tests: results do not depend on it.
    pub fn set_gpu_reduce_slice(&mut self, slicing: Option<gpu::slices::Slicing>) {
        if let EngineImpl::Gpu(g) = &mut self.inner {
            g.set_reduce_slice(slicing);
        }
    }

    /// On the GPU engine, at most `steps` steps per integration dispatch (`None`: sized by
    /// wall time and the adapter's limits). For tests: results do not depend on it.
    pub fn set_gpu_dispatch_steps(&mut self, steps: Option<u64>) {
        if let EngineImpl::Gpu(g) = &mut self.inner {
            g.set_dispatch_steps(steps);
        }
    }

    /// On the GPU engine, build the kernels with wgpu's runtime checks (`on`) or without them
    /// (the default; `GpuContext::set_runtime_checks`). For tests and benches.
    pub fn set_gpu_runtime_checks(&mut self, on: bool) {
        if let EngineImpl::Gpu(g) = &mut self.inner {
            g.set_runtime_checks(on);
        }
    }

    /// The GPU engine on adapter `index` of [`gpu::list_adapters`].
    pub fn gpu_adapter(index: usize) -> Result<Engine, EngineError> {
        let t0 = Instant::now();
        let ctx = GpuContext::new(gpu::AdapterChoice::Index(index))?;
        let why = format!("requested: adapter {index} ({})", ctx.adapter_name);
        Ok(Engine::gpu(ctx, why, t0.elapsed().as_secs_f64()))
    }

    /// The GPU engine on an opened device.
    pub fn gpu(ctx: GpuContext, reason: String, open_s: f64) -> Engine {
        Engine {
            info: EngineInfo {
                kind: EngineKind::Gpu,
                precision: Precision::F32,
                device: ctx.adapter_name.clone(),
                reason,
                open_s,
                cpu_loop: None,
            },
            inner: EngineImpl::Gpu(Box::new(GpuEngine::new(ctx))),
        }
    }

    /// Open the engine a user asked for. `precision` defaults to `f64` on the CPU and `f32`
    /// on a GPU; `auto` on a software adapter measures which is faster (see `auto`).
    pub fn open(backend: Backend, precision: Option<Precision>) -> Result<Engine, EngineError> {
        let t0 = Instant::now();
        match (backend, precision) {
            (Backend::Cpu, p) => Ok(Engine::cpu(p.unwrap_or(Precision::F64))),
            (Backend::Gpu, Some(Precision::F64)) => Err(EngineError::GpuNeedsF32),
            (Backend::Gpu, _) => {
                let ctx = GpuContext::new(gpu::AdapterChoice::Any)?;
                let why = format!("requested: the GPU engine ({})", ctx.adapter_name);
                Ok(Engine::gpu(ctx, why, t0.elapsed().as_secs_f64()))
            }
            (Backend::Auto, Some(Precision::F64)) => Ok(Engine::cpu_because(
                Precision::F64,
                "auto: f64 runs on the CPU engine".into(),
            )),
            (Backend::Auto, p) => Ok(Engine::auto(t0, p)),
        }
    }

    /// [`Engine::open`] for runs whose steps are controlled by `control`: `auto` takes only an
    /// engine that allows it, the CPU engine in f64 where the tolerance is finer than f32
    /// resolves ([`adaptive::F32_FINEST_RTOL`]); an engine asked for by name is opened as asked
    /// (and its runs refused by [`Engine::run`]'s check).
    pub fn open_for(
        backend: Backend,
        precision: Option<Precision>,
        control: crate::config::StepControl,
    ) -> Result<Engine, EngineError> {
        if backend == Backend::Auto
            && precision.is_none()
            && adaptive::check_f32_tolerance(control, true).is_err()
        {
            let why = format!(
                "auto: integration.rtol below {:e} needs f64, so the CPU engine",
                adaptive::F32_FINEST_RTOL
            );
            return Ok(Engine::cpu_because(Precision::F64, why));
        }
        Engine::open(backend, precision)
    }

    /// [`Backend::Auto`] without a precision asked for f64: a hardware GPU, else the CPU
    /// engine (in `precision`, f64 by default).
    fn auto(t0: Instant, precision: Option<Precision>) -> Engine {
        let cpu = |why: String| Engine::cpu_because(precision.unwrap_or(Precision::F64), why);
        match GpuContext::new(gpu::AdapterChoice::HardwareOnly) {
            Ok(ctx) => {
                let why = format!("auto: hardware GPU `{}`", ctx.adapter_name);
                Engine::gpu(ctx, why, t0.elapsed().as_secs_f64())
            }
            Err(_) => cpu(
                "auto: no hardware GPU, so the CPU engine (a software adapter such as lavapipe runs only with --backend gpu)"
                    .into(),
            ),
        }
    }

    /// Mark this engine as reused by a later call of the same process (the Python package keeps
    /// its engines open): its opening cost no more (`open_s` 0) and its reason says so.
    pub fn mark_reused(&mut self) {
        self.info.open_s = 0.0;
        if !self.info.reason.ends_with(REUSED) {
            self.info.reason.push_str(REUSED);
        }
    }

    /// What this engine is.
    pub fn info(&self) -> &EngineInfo {
        &self.info
    }

    /// Whether this is the GPU engine on a hardware adapter (not a software one like lavapipe).
    pub fn is_hardware_gpu(&self) -> bool {
        self.gpu_context().is_some_and(|c| !c.is_software)
    }

    /// The GPU context, when this is the GPU engine.
    pub fn gpu_context(&self) -> Option<&GpuContext> {
        match &self.inner {
            EngineImpl::Gpu(g) => Some(g.context()),
            EngineImpl::Cpu(_) => None,
        }
    }

    /// The same engine's results in plan order (see `EnsembleEngine::run`).
    pub fn run(
        &self,
        plan: &EnsemblePlan,
        reduce: &ReduceOptions,
        readback: Readback,
        progress: Progress,
    ) -> Result<EngineRun, EngineError> {
        let f32 = self.info.precision == Precision::F32;
        for p in &plan.instances {
            adaptive::check_f32_tolerance(p.control, f32)?;
        }
        let mut run = match &self.inner {
            EngineImpl::Cpu(c) => EnsembleEngine::run(c, plan, reduce, readback, progress),
            EngineImpl::Gpu(g) => EnsembleEngine::run(g.as_ref(), plan, reduce, readback, progress),
        }?;
        if let Some(k) = readback.strobe_last {
            for s in &mut run.strobe {
                s.drain(..s.len().saturating_sub(k as usize));
            }
        }
        Ok(run)
    }
}
