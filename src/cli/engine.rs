//! The engine flags shared by `map`, `search`, `bench`: the CLI's spelling of
//! [`Backend`] and [`Precision`], and opening the engine once per command.

use pendulum_atlas_core::config::Scene;
use pendulum_atlas_core::engine::{Backend, CpuLoop, Engine, EngineError, Precision, StepPlan};

/// CLI spelling of [`Backend`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendArg {
    /// A hardware GPU if present, else the software adapter lavapipe, else the CPU engine.
    Auto,
    /// The GPU engine (any wgpu adapter, lavapipe included).
    Gpu,
    /// The CPU engine (rayon).
    Cpu,
}

impl From<BackendArg> for Backend {
    fn from(b: BackendArg) -> Backend {
        match b {
            BackendArg::Auto => Backend::Auto,
            BackendArg::Gpu => Backend::Gpu,
            BackendArg::Cpu => Backend::Cpu,
        }
    }
}

/// CLI spelling of [`Precision`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PrecisionArg {
    /// Single precision, as the GPU integrates.
    F32,
    /// Double precision.
    F64,
}

impl From<PrecisionArg> for Precision {
    fn from(p: PrecisionArg) -> Precision {
        match p {
            PrecisionArg::F32 => Precision::F32,
            PrecisionArg::F64 => Precision::F64,
        }
    }
}

/// CLI spelling of [`CpuLoop`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CpuLoopArg {
    /// One instance per thread task, scalar arithmetic (the SIMD loop's reference).
    Scalar,
    /// Instances side by side in vector lanes (4 in f64, 8 in f32).
    Simd,
}

impl From<CpuLoopArg> for CpuLoop {
    fn from(l: CpuLoopArg) -> CpuLoop {
        match l {
            CpuLoopArg::Scalar => CpuLoop::Scalar,
            CpuLoopArg::Simd => CpuLoop::Simd,
        }
    }
}

/// `--backend`, `--precision`, `--adapter` and `--cpu-loop`.
#[derive(Debug, clap::Args)]
pub struct EngineArgs {
    /// Engine: `auto` (a hardware GPU, else the software adapter lavapipe, else the CPU),
    /// `gpu` (any wgpu adapter, lavapipe included) or `cpu`.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// Float type (default: f64 on the CPU engine, f32 otherwise; the GPU integrates in f32).
    #[arg(long, value_enum)]
    pub precision: Option<PrecisionArg>,
    /// Run on this GPU adapter (its index in `pendulum-atlas adapters`); implies the GPU engine.
    #[arg(long, value_name = "INDEX")]
    pub adapter: Option<usize>,
    /// The CPU engine's loop: `simd` (default: instances in vector lanes) or `scalar` (one
    /// instance at a time, the reference of the SIMD loop). Only for the CPU engine.
    #[arg(long, value_enum)]
    pub cpu_loop: Option<CpuLoopArg>,
}

impl EngineArgs {
    /// Open the engine once for the whole command, whose runs step as `scene` says (`auto`
    /// takes only an engine that allows its tolerance: `Engine::open_for`).
    pub fn open(&self, scene: &Scene) -> anyhow::Result<Engine> {
        let control = StepPlan::for_scene(scene)?.control;
        let mut engine = match self.adapter {
            Some(i) => Self::on_adapter(i, self)?,
            None => Engine::open_for(self.backend.into(), self.precision.map(Into::into), control)
                .map_err(hint)?,
        };
        if let Some(l) = self.cpu_loop {
            if engine.info().cpu_loop.is_none() {
                anyhow::bail!(
                    "--cpu-loop applies to the CPU engine, but this command runs on the GPU ({}) [add --backend cpu]",
                    engine.info().device
                );
            }
            engine.set_cpu_loop(l.into());
        }
        Ok(engine)
    }

    /// The GPU engine on adapter `index`, refusing flags that contradict it.
    fn on_adapter(index: usize, a: &EngineArgs) -> anyhow::Result<Engine> {
        if a.backend == BackendArg::Cpu {
            anyhow::bail!("--adapter picks a GPU adapter; drop --backend cpu or --adapter");
        }
        if a.precision == Some(PrecisionArg::F64) {
            return Err(hint(EngineError::GpuNeedsF32));
        }
        Engine::gpu_adapter(index).map_err(hint)
    }

    /// The GPU engine (any adapter, lavapipe included).
    pub fn gpu_engine() -> anyhow::Result<Engine> {
        Engine::open(Backend::Gpu, None).map_err(hint)
    }
}

/// An engine error with the command-line flag that mends it, where one does.
pub fn hint(e: EngineError) -> anyhow::Error {
    let flag = match &e {
        EngineError::GpuNeedsF32 => Some("drop --precision f64, or use --backend cpu"),
        EngineError::NoAdapter { .. }
        | EngineError::TooManySegments { .. }
        | EngineError::SoftwareLoopBudget { .. } => Some("--backend cpu"),
        _ => None,
    };
    match flag {
        Some(f) => anyhow::anyhow!("{e} [{f}]"),
        None => anyhow::Error::new(e),
    }
}
