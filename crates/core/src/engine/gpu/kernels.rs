//! The WGSL kernels: their source, assembled at build time from the stage files in `shaders/`
//! behind a header generated from the Rust definitions, and their specialisation.
//!
//! The header holds the status codes ([`Status::code`]), the health-check interval
//! ([`CHECK_EVERY`]), the IMEX method's tableaux ([`crate::engine::imex`]) and the adaptive
//! ladder's depth and growth bound ([`crate::engine::adaptive`]), the structs shared with Rust
//! (`InstanceParams`, `Control`, `Accum`, from [`crate::engine::gpu::layout`]), the regime codes and
//! thresholds ([`crate::reduce::regime`]), λ1's block count and twin flags, and the bound of the
//! per-invocation arrays, the scene's N (so no private array is larger than the scene needs):
//! the shader never carries its own copy of a rule or coefficient defined in Rust.

use crate::config::GpuKernelChoice;
use crate::engine::gpu::codegen;
use crate::engine::gpu::gpu_struct::GpuStruct;
use crate::engine::gpu::layout::{
    GpuControl, GpuInstanceParams, SCHED_LIVE, TWIN_BROKEN, TWIN_RUNNING,
};
use crate::engine::imex::{AE, AI, B, B_HAT, C, GAMMA};
use crate::engine::ladder::{LADDER_GROW, LADDER_UNIT, MAX_LEVEL};
use crate::engine::method::Method;
use crate::model::{CHECK_EVERY, ChainShape, ContactDamping, Status};
use crate::reduce::Regime;
use crate::reduce::lyapunov::LYAPUNOV_BLOCK_COUNT;
use crate::reduce::regime::{
    CLASS_FLAT, CLASS_GROWING, CLASS_SHRINKING, CLASS_UNRESOLVED, K_FIRM_SAMPLES,
    REGIME_FLAT_PER_PERIOD, REGIME_K_CHAOS, REGIME_Z,
};
use std::fmt::Write;

/// The stage files of the ensemble kernels, in assembly order: common definitions,
/// integration (RK4, λ1's twin), its schedule on the device, the early stop, the IMEX method, the R reduction, the 0–1 test and
/// period, λ1 and the regime.
pub const SHADER_STAGES: [(&str, &str); 8] = [
    ("common.wgsl", include_str!("../../../shaders/common.wgsl")),
    (
        "integrate.wgsl",
        include_str!("../../../shaders/integrate.wgsl"),
    ),
    (
        "schedule.wgsl",
        include_str!("../../../shaders/schedule.wgsl"),
    ),
    ("early.wgsl", include_str!("../../../shaders/early.wgsl")),
    ("imex.wgsl", include_str!("../../../shaders/imex.wgsl")),
    (
        "reduce_r.wgsl",
        include_str!("../../../shaders/reduce_r.wgsl"),
    ),
    (
        "reduce_k.wgsl",
        include_str!("../../../shaders/reduce_k.wgsl"),
    ),
    (
        "verdict.wgsl",
        include_str!("../../../shaders/verdict.wgsl"),
    ),
];

/// The stage files concatenated (assembled at build time).
pub(crate) const SHADER_BODY: &str = concat!(
    include_str!("../../../shaders/common.wgsl"),
    include_str!("../../../shaders/integrate.wgsl"),
    include_str!("../../../shaders/schedule.wgsl"),
    include_str!("../../../shaders/early.wgsl"),
    include_str!("../../../shaders/imex.wgsl"),
    include_str!("../../../shaders/reduce_r.wgsl"),
    include_str!("../../../shaders/reduce_k.wgsl"),
    include_str!("../../../shaders/verdict.wgsl"),
);

/// A WGSL array constant of f32 values.
fn wgsl_array(name: &str, values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|v| format!("{v:e}")).collect();
    format!(
        "const {name}: array<f32, {n}> = array<f32, {n}>({});\n",
        items.join(", "),
        n = values.len()
    )
}

/// The constants the kernels take from the Rust side, for chains of `segments` segments.
pub fn shader_header(segments: usize) -> String {
    let mut h =
        String::from("// Generated from the Rust definitions (src/engine/gpu/kernels.rs).\n");
    for s in Status::ALL {
        let _ = writeln!(h, "const {}: u32 = {}u;", s.wgsl_name(), s.code());
    }
    for law in ContactDamping::ALL {
        let _ = writeln!(h, "const {}: u32 = {}u;", law.wgsl_name(), law.gpu_code());
    }
    let _ = writeln!(h, "const CHECK_EVERY: u32 = {CHECK_EVERY}u;");
    for r in Regime::ALL {
        let _ = writeln!(h, "const {}: i32 = {}i;", r.wgsl_name(), r.code());
    }
    let _ = writeln!(h, "const REGIME_Z: f32 = {REGIME_Z:e};");
    let _ = writeln!(
        h,
        "const REGIME_FLAT_PER_PERIOD: f32 = {REGIME_FLAT_PER_PERIOD:e};"
    );
    let _ = writeln!(h, "const REGIME_K_CHAOS: f32 = {REGIME_K_CHAOS:e};");
    let _ = writeln!(h, "const K_FIRM_SAMPLES: u32 = {K_FIRM_SAMPLES}u;");
    for (name, code) in [
        ("CLASS_UNRESOLVED", CLASS_UNRESOLVED),
        ("CLASS_GROWING", CLASS_GROWING),
        ("CLASS_FLAT", CLASS_FLAT),
        ("CLASS_SHRINKING", CLASS_SHRINKING),
    ] {
        let _ = writeln!(h, "const {name}: u32 = {code}u;");
    }
    let _ = writeln!(
        h,
        "const LYAPUNOV_BLOCK_COUNT: u32 = {LYAPUNOV_BLOCK_COUNT}u;"
    );
    let _ = writeln!(
        h,
        "const EARLY_LYAPUNOV_REL_SE: f32 = {:e};",
        crate::engine::early::EARLY_LYAPUNOV_REL_SE
    );
    let _ = writeln!(h, "const TWIN_RUNNING: u32 = {TWIN_RUNNING}u;");
    let _ = writeln!(h, "const TWIN_BROKEN: u32 = {TWIN_BROKEN}u;");
    let _ = writeln!(h, "const SCHED_LIVE: u32 = {SCHED_LIVE}u;");
    let _ = writeln!(h, "const MAX_SEG: u32 = {}u;", segments.max(1));
    let _ = writeln!(h, "const IMEX_GAMMA: f32 = {GAMMA:e};");
    h.push_str(&wgsl_array("IMEX_C", &C));
    h.push_str(&wgsl_array("IMEX_B", &B));
    h.push_str(&wgsl_array("IMEX_B_HAT", &B_HAT));
    let _ = writeln!(h, "const MAX_LEVEL: u32 = {MAX_LEVEL}u;");
    let _ = writeln!(h, "const LADDER_UNIT: u32 = {LADDER_UNIT}u;");
    let _ = writeln!(h, "const LADDER_GROW: f32 = {LADDER_GROW:e};");
    h.push_str(&wgsl_array("IMEX_AE", AE.as_flattened()));
    h.push_str(&wgsl_array("IMEX_AI", AI.as_flattened()));
    h.push_str(&GpuInstanceParams::wgsl());
    h.push_str(&GpuControl::wgsl());
    h.push_str(&crate::engine::gpu::layout::accum_wgsl());
    h.push_str(&codegen::shared_rules_wgsl());
    h.push('\n');
    h
}

/// The complete WGSL source of the ensemble kernels for chains of `shape`: the header, the
/// chain's functions generated from the Rust model ([`codegen`]), the stage files.
pub fn shader_source(shape: ChainShape) -> String {
    shader_header(shape.segments) + &codegen::generated_wgsl(shape) + SHADER_BODY
}

/// The kernels written out under the top-level `shaders/` for reading, as (file name, text):
/// the default scene's shape (its bumpers' levers and law, no piezo) at N = 3 and 17.
/// One module serves RK4 and IMEX alike (the method is an override constant); each file is
/// exactly what [`crate::engine::GpuContext`] compiles for its shape, behind two comment lines.
/// A test fails when a file differs from this.
pub fn written_kernels() -> Vec<(String, String)> {
    [3, 17]
        .map(|n| {
            let scene = crate::config::load_scene(None, &[format!("beam.segments={n}")])
                .expect("the embedded default scene loads");
            let params = scene
                .model_params()
                .expect("the embedded default scene builds");
            let shape = ChainShape::of(&params);
            let text = format!(
                "{}\n// The ensemble kernels of the default scene at N = {n} (RK4 and IMEX: the \
                 method is an override constant).\n{}",
                codegen::GENERATED_LINE,
                shader_source(shape)
            );
            (format!("ensemble_n{n}.wgsl"), text)
        })
        .into()
}

/// Everything the kernels are specialised on (their override constants): one compiled set of
/// pipelines per distinct key, cached by [`crate::engine::GpuContext`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct KernelKey {
    /// The chain's shape (N, the bumpers' law, the piezo's span): one module per shape.
    pub chain: ChainShape,
    /// Stroboscopic samples recorded.
    pub want_strobe: bool,
    /// R series recorded (for R or the dominant line).
    pub want_rseries: bool,
    /// R reduced.
    pub want_r: bool,
    /// The dominant line reduced.
    pub want_line: bool,
    /// The 0–1 test wanted.
    pub want_k: bool,
    /// The K/period kernel is needed (K or the period).
    pub run_k_final: bool,
    /// R in the paper's convention.
    pub paper_convention: bool,
    /// c values of the 0–1 test.
    pub n_c: usize,
    /// Integration method.
    pub method: Method,
    /// λ1's twin rides along (and the λ1 and regime kernel runs).
    pub want_twin: bool,
    /// The early stop of confirmed orbits.
    pub want_early: bool,
    /// Adaptive steps on the ladder ([`crate::engine::adaptive`]), IMEX or RK4 by `method`.
    pub adaptive: bool,
    /// How the integration spreads over the device: an invocation or a workgroup per instance.
    pub kernel: GpuKernel,
    /// Built with wgpu's runtime checks (`crate::engine::GpuContext::set_runtime_checks`).
    pub runtime_checks: bool,
}

/// Workgroup size of the integration and R kernels.
pub(crate) const WG: u32 = 64;

/// How the integration kernel spreads an ensemble over the device (the map's `gpu.kernel`,
/// resolved by [`GpuKernel::resolve`]).
///
/// One invocation per instance is the only kernel since issue 73: the cooperative kernel (a
/// workgroup per instance) was a hand-written copy of the physics that `auto` never picked and
/// that ran 17–49× slower on lavapipe; it returns once it is generated from the Rust model and
/// hardware has measured it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GpuKernel {
    /// One invocation per instance (`integrate`, `shaders/integrate.wgsl`).
    Thread,
}

impl From<GpuKernel> for GpuKernelChoice {
    fn from(k: GpuKernel) -> GpuKernelChoice {
        match k {
            GpuKernel::Thread => GpuKernelChoice::Thread,
        }
    }
}

impl GpuKernel {
    /// Every kernel.
    pub const ALL: [GpuKernel; 1] = [GpuKernel::Thread];

    /// The kernel's name, as `gpu.kernel` spells it.
    pub fn name(self) -> &'static str {
        match self {
            GpuKernel::Thread => "thread",
        }
    }

    /// The kernel `choice` names.
    pub fn resolve(choice: GpuKernelChoice) -> GpuKernel {
        match choice {
            GpuKernelChoice::Auto | GpuKernelChoice::Thread => GpuKernel::Thread,
        }
    }
}

impl KernelKey {
    /// Workgroup size of the K kernel: its sorting rows live in 16 KiB of workgroup memory.
    pub(crate) fn wg_k(&self) -> u32 {
        ((16384 / (4 * self.n_c)) as u32).clamp(1, 64)
    }

    /// The override constants of this specialisation.
    pub fn constants(&self) -> Vec<(&'static str, f64)> {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        vec![
            ("N_SEG", self.chain.segments as f64),
            ("HAS_CONTACT", flag(self.chain.contact.is_some())),
            ("HAS_PIEZO", flag(self.chain.piezo_last.is_some())),
            ("WANT_STROBE", flag(self.want_strobe)),
            ("WANT_RSERIES", flag(self.want_rseries)),
            ("WANT_K", flag(self.want_k)),
            ("PAPER_CONVENTION", flag(self.paper_convention)),
            ("WG", f64::from(WG)),
            ("WG_K", f64::from(self.wg_k())),
            ("N_C", self.n_c as f64),
            ("METHOD_IMEX", flag(self.method == Method::Imex)),
            ("WANT_TWIN", flag(self.want_twin)),
            ("WANT_EARLY", flag(self.want_early)),
            ("ADAPTIVE", flag(self.adaptive)),
        ]
    }
}

/// The compiled pipelines of one [`KernelKey`]; kernels of metrics not asked for are absent.
#[derive(Debug)]
pub struct Kernels {
    /// Which integration kernel `integrate` is.
    pub kernel: GpuKernel,
    /// The integration kernel.
    pub integrate: wgpu::ComputePipeline,
    /// The device's compaction of the live list after each integration dispatch.
    pub compact: wgpu::ComputePipeline,
    /// The next integration dispatch's workgroup count, from the compaction's count.
    pub schedule: wgpu::ComputePipeline,
    /// The dominant line of the R series (before the R kernels overwrite it).
    pub line: Option<wgpu::ComputePipeline>,
    /// The three R kernels (α's analytic signal, the cart's, then R).
    pub r: Option<[wgpu::ComputePipeline; 3]>,
    /// One pass of the 0–1 test per c value.
    pub k_pass: Option<wgpu::ComputePipeline>,
    /// The median over c and the period.
    pub k_final: Option<wgpu::ComputePipeline>,
    /// λ1 from the twin's growths, and the regime.
    pub verdict: Option<wgpu::ComputePipeline>,
    /// The continuation of the instances stopped early, after the integration.
    pub early_finish: Option<wgpu::ComputePipeline>,
}

impl Kernels {
    /// Compile the pipelines of `key` from `module`.
    pub(crate) fn compile(
        device: &wgpu::Device,
        layout: &wgpu::PipelineLayout,
        module: &wgpu::ShaderModule,
        key: &KernelKey,
    ) -> Kernels {
        let constants = key.constants();
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            })
        };
        Kernels {
            kernel: key.kernel,
            integrate: pipeline("integrate"),
            compact: pipeline("compact"),
            schedule: pipeline("schedule"),
            line: key.want_line.then(|| pipeline("line")),
            r: key
                .want_r
                .then(|| [pipeline("r_alpha"), pipeline("r_cart"), pipeline("r_phase")]),
            k_pass: key.want_k.then(|| pipeline("k_pass")),
            k_final: key.run_k_final.then(|| pipeline("k_final")),
            verdict: key.want_twin.then(|| pipeline("verdict")),
            early_finish: key.want_early.then(|| pipeline("early_finish")),
        }
    }
}
