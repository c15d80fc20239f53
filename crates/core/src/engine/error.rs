//! What can stop an engine: a plan that cannot be integrated as asked, or a GPU that refuses.
//! Each variant says what to change.

use thiserror::Error;

/// Errors of planning and running an ensemble.
#[derive(Debug, Error)]
pub enum EngineError {
    /// A scene of the ensemble is invalid.
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    /// A scene's linearisation (its automatic step, its damping ratio) cannot be computed.
    #[error(transparent)]
    Linear(#[from] crate::model::linear::LinearError),
    /// `--adapter` or `--devices` beyond the adapters of this machine.
    #[error(
        "there is no adapter {index}: this machine has {count} (`pendulum-atlas adapters` lists them)"
    )]
    NoSuchAdapter {
        /// The index asked for.
        index: usize,
        /// Adapters present.
        count: usize,
    },
    /// λ1's twin separation is too small for the engine's float type.
    #[error(
        "map.lyapunov_perturbation = {given:e} is below what {precision} resolves for lambda1's twin (at least {min:e}: smaller separations drown in the rounding of the state); set map.lyapunov_perturbation to {min:e} or more, \"auto\" ({auto:e} in {precision}), or use f64"
    )]
    TwinSeparation {
        /// The d0 asked for.
        given: f64,
        /// The engine's float type.
        precision: &'static str,
        /// The smallest d0 accepted in it.
        min: f64,
        /// The default in it.
        auto: f64,
    },
    /// The progress callback cancelled the run (Ctrl-C in the Python package).
    #[error("the run was cancelled before it finished")]
    Cancelled,
    /// A map too large for the host's memory.
    #[error(
        "a map of {instances} instances at N = {segments} needs about {need} of memory to plan and hold its results, and {available} is available: use a coarser grid or fewer axis values"
    )]
    HostMemory {
        /// Instances of the map.
        instances: usize,
        /// Segments N.
        segments: usize,
        /// Memory it needs, readable.
        need: String,
        /// Memory available, readable.
        available: String,
    },
    /// A map (or each shard of it) above the size at which `map` asks first, not accepted;
    /// or, accepted, the figures said to the user.
    #[error("{figures}; {advice}")]
    HugeMap {
        /// Its runs, steps, memory and, where probed, time.
        figures: String,
        /// What to do: accept it, or that it was accepted.
        advice: String,
    },
    /// An ensemble needs at least one instance.
    #[error("an ensemble needs at least one instance")]
    Empty,
    /// Ensembles are integrated on a stroboscopic step grid, which needs one forcing period.
    #[error("ensembles need harmonic excitation, found a {0}")]
    NotHarmonic(&'static str),
    /// Every instance of an ensemble shares the kernel's structure.
    #[error(
        "every instance of an ensemble must share beam.segments, limiter.enabled and piezo.enabled (instance {index} differs from the first)"
    )]
    MixedStructure {
        /// The first instance that differs.
        index: usize,
    },
    /// The GPU's kernels are generated for one chain shape, and an instance has another.
    #[error(
        "the GPU kernels are generated for one chain shape: every instance of a GPU ensemble must share limiter.damping_law and piezo.segments (instance {index} differs from the first); run it with --backend cpu, or as separate maps"
    )]
    MixedKernelShape {
        /// The first instance that differs.
        index: usize,
    },
    /// The run is too short for what it must measure.
    #[error("{at}: {reason}")]
    TooShort {
        /// The instance's frequency, duration and transient.
        at: String,
        /// What is missing, and how to get it.
        reason: String,
    },
    /// An instance needs more steps than the engines' 32-bit step counter holds.
    #[error(
        "{at}: {} steps per instance exceed the engines' 32-bit step counter; shorten integration.duration_s or lengthen the step", crate::text::num(*steps as f64)
    )]
    TooManySteps {
        /// The instance's frequency, duration and transient.
        at: String,
        /// Steps it would need.
        steps: u64,
    },
    /// No wgpu adapter could be found.
    #[error(
        "no GPU adapter found (no Vulkan, Metal or DX12 driver){}",
        if *hardware_only { ": a hardware GPU was required" } else { ". On Debian/Ubuntu `apt-get install mesa-vulkan-drivers` provides the software adapter lavapipe; or use the CPU engine" }
    )]
    NoAdapter {
        /// Only hardware adapters were acceptable.
        hardware_only: bool,
    },
    /// The adapter was found but its device could not be opened.
    #[error("cannot open GPU device `{adapter}`: {message}")]
    DeviceOpen {
        /// Adapter name.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
    /// The DOP853 reference integrates in double precision only.
    #[error(
        "the reference integrator runs in f64 only: ask for f64, or use the fixed-step engine for an f32 run"
    )]
    ReferenceNeedsF64,
    /// The GPU engine integrates in single precision only.
    #[error("the GPU engine integrates in f32: ask for f32, or use the CPU engine for f64")]
    GpuNeedsF32,
    /// The GPU kernel's per-invocation arrays hold a bounded number of segments.
    #[error(
        "the GPU kernel holds at most {max} segments, the scene has {segments}: use the CPU engine"
    )]
    TooManySegments {
        /// The scene's N.
        segments: usize,
        /// The kernel's limit.
        max: usize,
    },
    /// Adaptive steps to a tolerance below what f32 resolves.
    #[error(
        "integration.rtol = {rtol:e} is finer than f32 resolves (at least {floor:e}): every sub-step would be forced to the finest level, hundreds of times slower; run in f64 (--precision f64, the CPU engine) or set integration.rtol >= {floor:e}"
    )]
    ToleranceBelowF32 {
        /// The tolerance asked for.
        rtol: f64,
        /// The finest an f32 engine meets.
        floor: f64,
    },
    /// lavapipe ends any shader invocation after 65535 loop iterations.
    #[error(
        "the software GPU adapter ({adapter}) stops a shader after 65535 loop iterations; {what} needs about {loops}: {remedy}"
    )]
    SoftwareLoopBudget {
        /// Adapter name.
        adapter: String,
        /// The kernel's work.
        what: String,
        /// Loop iterations it would need.
        loops: usize,
        /// What to change.
        remedy: String,
    },
    /// The integration kernel's loops could not be counted for the software adapter's loop
    /// limit (a defect of the kernels, never of the input).
    #[error("the integration kernel's loops could not be counted for lavapipe's loop limit: {0}")]
    KernelLoops(String),
    /// A buffer larger than the adapter allows.
    #[error(
        "the ensemble needs a {bytes}-byte GPU buffer ({what}), more than the adapter allows ({limit} bytes): use fewer instances, a shorter run or fewer R samples"
    )]
    BufferTooLarge {
        /// Which buffer.
        what: &'static str,
        /// Bytes needed.
        bytes: u64,
        /// The adapter's limit.
        limit: u64,
    },
    /// A single instance needs more of a buffer than the adapter allows (larger plans are
    /// split into batches, which cannot help here).
    #[error(
        "one instance needs a {bytes}-byte GPU buffer ({what}), more than the adapter allows ({limit} bytes): use a shorter run, fewer c values or fewer R samples"
    )]
    InstanceTooLarge {
        /// Which buffer.
        what: &'static str,
        /// Bytes one instance needs.
        bytes: u64,
        /// The adapter's limit.
        limit: u64,
    },
    /// The DOP853 reference integrator failed.
    #[error("the reference integration (DOP853) failed: {0}")]
    Reference(String),
    /// The GPU failed while waiting for work or reading results back.
    #[error("GPU {stage} failed: {message}")]
    Gpu {
        /// `wait` or `readback`.
        stage: &'static str,
        /// wgpu's message.
        message: String,
    },
    /// The GPU device failed during a run: lost, out of memory, rejected the work or stopped
    /// answering. Raised within seconds, never as a panic or a hang.
    #[error(
        "the GPU ({adapter}) {kind} during a run of {instances} instances at N = {segments} ({mib:.1} MiB of buffers): {message}; {}", kind.hint()
    )]
    GpuFault {
        /// Adapter name.
        adapter: String,
        /// What happened.
        kind: GpuFaultKind,
        /// wgpu's (or the failpoint's) message.
        message: String,
        /// Instances of the batch that was running.
        instances: usize,
        /// Segments N.
        segments: usize,
        /// Device memory of the batch's buffers (MiB).
        mib: f64,
    },
    /// The GPU handed back an instance that is not what the dispatches should have left:
    /// a status code the engines do not define, or an `ok` instance short of its last step.
    #[error(
        "GPU result of instance {index} is inconsistent: {what}; the GPU's work was lost or cut short (try again, or use --backend cpu)"
    )]
    GpuInconsistent {
        /// The instance.
        index: usize,
        /// What is wrong with it.
        what: String,
    },
}

/// What a GPU device did to end a run ([`EngineError::GpuFault`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GpuFaultKind {
    /// The device was lost (driver reset, a kernel stopped by a watchdog, the device removed).
    Lost,
    /// An allocation failed.
    OutOfMemory,
    /// The device refused the work as invalid.
    Validation,
    /// The device did not finish a submission within the engine's bound.
    Timeout,
}

impl GpuFaultKind {
    /// What the user can do about it.
    pub fn hint(self) -> &'static str {
        match self {
            GpuFaultKind::OutOfMemory => {
                "use a smaller map (fewer cells, a shorter run, fewer R samples), or --backend cpu"
            }
            GpuFaultKind::Lost | GpuFaultKind::Timeout => {
                "try again (the device may need a moment to recover), or use --backend cpu"
            }
            GpuFaultKind::Validation => "please report this, and use --backend cpu meanwhile",
        }
    }
}

impl std::fmt::Display for GpuFaultKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            GpuFaultKind::Lost => "was lost",
            GpuFaultKind::OutOfMemory => "ran out of memory",
            GpuFaultKind::Validation => "refused the work",
            GpuFaultKind::Timeout => "stopped answering",
        })
    }
}
