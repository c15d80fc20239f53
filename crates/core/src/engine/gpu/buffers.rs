//! The buffers of one GPU run: sized and checked against the adapter before anything is
//! allocated, filled from the plan, bound once.

use crate::engine::error::{EngineError, GpuFaultKind};
use crate::engine::gpu::ReduceSettings;
use crate::engine::gpu::codegen::RK4_UNROLLED_UP_TO;
use crate::engine::gpu::context::GpuContext;
use crate::engine::gpu::kernels::{KernelKey, WG};
use crate::engine::gpu::layout::{GpuAccum, GpuControl, GpuInstanceParams, levers_of};
use crate::engine::imex::ImexMatrices;
use crate::engine::ladder::MAX_LEVEL;
use crate::engine::method::Method;
use crate::engine::plan::{EnsemblePlan, InstancePlan};
use crate::model::{CHECK_EVERY, Chain};
use bytemuck::Zeroable;

/// Loop iterations one invocation may run on a software adapter (lavapipe stops at 65535).
const SOFTWARE_LOOP_BUDGET: usize = 60_000;

/// Per-instance strides and buffer sizes of a run (bytes; at least 16, a placeholder for a
/// series no metric needs).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sizes {
    pub n_inst: usize,
    /// Instances per workgroup of the integration kernel.
    pub per_group: u32,
    pub state_len: usize,
    pub strobe_stride: u32,
    pub rwork_stride: u32,
    pub accum_bytes: u64,
    pub strobe_bytes: u64,
    pub rwork_bytes: u64,
    pub kc_bytes: u64,
    pub early_bytes: u64,
    pub levers_bytes: u64,
}

impl Sizes {
    /// Bytes of the per-instance buffers: parameters, state, accumulators, the series, the
    /// early-stop rings, the contact levers and the K_c values (the rest is a few kilobytes).
    pub fn device_bytes(&self) -> u64 {
        let n = self.n_inst as u64;
        n * (size_of::<GpuInstanceParams>() as u64 + 4 * self.state_len as u64)
            + self.accum_bytes
            + self.strobe_bytes
            + self.rwork_bytes
            + self.kc_bytes
            + self.early_bytes
            + self.levers_bytes
            + 12 * n
            + 32
    }
}

impl Sizes {
    /// The sizes of `plan`, each checked against the adapter's buffer limits.
    pub fn new(
        ctx: &GpuContext,
        plan: &EnsemblePlan,
        key: &KernelKey,
    ) -> Result<Sizes, EngineError> {
        let n_inst = plan.instances.len();
        let limit = buffer_limit(ctx);
        let f = Footprint::of(plan, key);
        let bytes = |(what, per): (&'static str, u64)| -> Result<u64, EngineError> {
            let b = (n_inst as u64).saturating_mul(per);
            if b > limit {
                return Err(EngineError::BufferTooLarge {
                    what,
                    bytes: b,
                    limit,
                });
            }
            Ok(b.max(16))
        };
        bytes(f.params)?;
        bytes(f.state)?;
        bytes(f.live)?;
        Ok(Sizes {
            n_inst,
            per_group: WG,
            state_len: f.state_len,
            strobe_stride: f.strobe_stride,
            rwork_stride: f.rwork_stride,
            accum_bytes: bytes(f.accum)?,
            strobe_bytes: bytes(f.strobe)?,
            rwork_bytes: bytes(f.rwork)?,
            kc_bytes: bytes(f.kc)?,
            early_bytes: bytes(f.early)?,
            levers_bytes: bytes(f.levers)?,
        })
    }
}

/// What one instance of a plan takes in each per-instance buffer: (buffer, bytes); 0 for a
/// series no metric needs (bound as a 16-byte placeholder).
struct Footprint {
    state_len: usize,
    strobe_stride: u32,
    rwork_stride: u32,
    params: (&'static str, u64),
    state: (&'static str, u64),
    accum: (&'static str, u64),
    strobe: (&'static str, u64),
    rwork: (&'static str, u64),
    kc: (&'static str, u64),
    early: (&'static str, u64),
    levers: (&'static str, u64),
    live: (&'static str, u64),
}

impl Footprint {
    fn of(plan: &EnsemblePlan, key: &KernelKey) -> Footprint {
        // λ1's twin keeps a second state beside the main one.
        let state_len = (2 * plan.segments + 1) * if key.want_twin { 2 } else { 1 };
        let strobe_stride = plan.strobe_stride.max(1);
        let n_cut_max = (plan.strobe_stride + 5) / 10;
        let rwork_stride = (if key.want_rseries {
            2 * plan.r_stride
        } else {
            0
        })
        .max(if key.want_k {
            plan.strobe_stride + n_cut_max
        } else {
            0
        });
        let on = |wanted: bool, bytes: u64| if wanted { bytes } else { 0 };
        Footprint {
            state_len,
            strobe_stride,
            rwork_stride,
            params: ("parameters", size_of::<GpuInstanceParams>() as u64),
            state: ("state", 4 * state_len as u64),
            accum: ("accumulators", size_of::<GpuAccum>() as u64),
            strobe: (
                "stroboscopic samples",
                on(key.want_strobe, 4 * u64::from(strobe_stride)),
            ),
            rwork: (
                "reduction work space",
                on(key.want_rseries || key.want_k, 8 * u64::from(rwork_stride)),
            ),
            kc: ("K_c values", on(key.want_k, 4 * key.n_c as u64)),
            early: (
                "early-stop rings",
                on(
                    key.want_early,
                    4 * u64::from(GpuControl::zeroed().with_early(plan).1),
                ),
            ),
            levers: ("contact levers", 4 * plan.segments.max(1) as u64),
            // Two halves of one word each (`shaders/schedule.wgsl`).
            live: ("live list", 8),
        }
    }

    fn buffers(&self) -> [(&'static str, u64); 9] {
        [
            self.live,
            self.levers,
            self.params,
            self.state,
            self.accum,
            self.strobe,
            self.rwork,
            self.kc,
            self.early,
        ]
    }
}

/// The largest buffer the adapter binds (bytes).
fn buffer_limit(ctx: &GpuContext) -> u64 {
    ctx.limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size)
}

/// The most instances of `plan` one run on the adapter can hold: every per-instance buffer
/// within the binding limit, and every dispatch within the workgroup-count limit. A larger
/// plan is run in batches of at most this many; an error names the buffer when a single
/// instance is already too large.
pub(crate) fn batch_capacity(
    ctx: &GpuContext,
    plan: &EnsemblePlan,
    key: &KernelKey,
) -> Result<usize, EngineError> {
    let limit = buffer_limit(ctx);
    let groups = ctx.limits.max_compute_workgroups_per_dimension as usize;
    let per_group = WG.min(key.wg_k());
    let mut cap = groups.saturating_mul(per_group as usize);
    for (what, per) in Footprint::of(plan, key).buffers() {
        if per > limit {
            return Err(EngineError::InstanceTooLarge {
                what,
                bytes: per,
                limit,
            });
        }
        if let Some(fits) = limit.checked_div(per) {
            cap = cap.min(fits as usize);
        }
    }
    Ok(cap.max(1))
}

/// Integration steps one invocation may take per dispatch on a software adapter (`None` on
/// hardware), after checking that every reduction kernel fits lavapipe's loop limit.
pub(crate) fn software_step_budget(
    ctx: &GpuContext,
    plan: &EnsemblePlan,
    key: &KernelKey,
    reduce: &ReduceSettings,
) -> Result<Option<u64>, EngineError> {
    if !ctx.is_software {
        return Ok(None);
    }
    let refuse = |what: String, loops: usize, remedy: &str| EngineError::SoftwareLoopBudget {
        adapter: ctx.adapter_name.clone(),
        what,
        loops,
        remedy: remedy.into(),
    };
    let n_seg = plan.segments;
    let n_cut_max = (plan.strobe_stride as usize + 5) / 10;
    let r_n = plan.r_stride as usize;
    let r_loops = 11 * r_n + r_n * (r_n.max(2).ilog2() as usize);
    if key.want_rseries && r_loops > SOFTWARE_LOOP_BUDGET {
        return Err(refuse(
            format!("R and the dominant line on {r_n} samples"),
            r_loops,
            "set map.r_max_samples <= 1024, or use the CPU engine",
        ));
    }
    let s_n = plan.strobe_stride as usize;
    let k_loops = s_n + s_n * n_cut_max + 2 * n_cut_max;
    if key.want_k && k_loops > SOFTWARE_LOOP_BUDGET {
        return Err(refuse(
            format!("the 0-1 test on {s_n} stroboscopic samples"),
            k_loops,
            "shorten the run (fewer forcing periods after the transient) or use the CPU engine",
        ));
    }
    let n_c = key.n_c;
    let f_loops =
        n_c * n_c / 2 + n_c + (reduce.period_max as usize + 1) * reduce.period_window as usize;
    if key.run_k_final && f_loops > SOFTWARE_LOOP_BUDGET {
        return Err(refuse(
            format!("the median over map.k_n_c = {n_c} c values"),
            f_loops,
            "use fewer c values, or the CPU engine",
        ));
    }
    Ok(Some(steps_within_loop_budget(
        (key.method, key.adaptive),
        n_seg,
        key.want_twin,
        early_loops(plan, key),
    )))
}

/// Loop iterations the early stop adds (`shaders/early.wgsl`): per step, its watch at each
/// stroboscopic instant spread over the shortest period (`early_keep`: `N` stores, then per
/// period tried the window and the state; `lyap_estimate`, `twin_restart` and `twin_extend`:
/// 32); per
/// dispatch, the continuation at most once (every later period, stroboscopic and R sample).
fn early_loops(plan: &EnsemblePlan, key: &KernelKey) -> (f64, f64) {
    let Some(e) = plan.early_stop.filter(|_| key.want_early) else {
        return (0.0, 0.0);
    };
    let dim = 2 * plan.segments + 1;
    let watch = (e.p_max as usize * (e.window as usize + dim + 1) + plan.segments + 32) as f64;
    let spp_min = plan
        .instances
        .iter()
        .map(|p| p.spp)
        .min()
        .unwrap_or(1)
        .max(1);
    let periods = plan
        .instances
        .iter()
        .map(|p| p.total_periods)
        .max()
        .unwrap_or(0);
    let fixed = f64::from(periods) + f64::from(plan.strobe_stride) + f64::from(plan.r_stride);
    (watch / f64::from(spp_min), fixed)
}

/// Steps per dispatch whose loop iterations, health checks included (one every
/// [`CHECK_EVERY`] steps, one at the end and one at a dispatch's start at most; `2 N`: the
/// state's finiteness and the bends, the energy being generated without a loop), stay within
/// [`SOFTWARE_LOOP_BUDGET`]. lavapipe counts every loop iteration of an invocation against
/// one limit, and silently ends the loop when it is reached: an undercount here left
/// instances short of their last step (caught by the GPU results' check). λ1's twin takes
/// every step again with a swap in and out (`twin_step`: one step and `2 N`), and at most once
/// per step a sample (`twin_sample`: `2 N`; its saltation is generated without a loop, and the
/// `6 N` it once took is still counted, an upper bound);
/// per dispatch it is loaded and stored (`2 N`). The early stop adds `early` (per step,
/// per dispatch: [`early_loops`]).
fn steps_within_loop_budget(
    (method, adaptive): (Method, bool),
    n: usize,
    twin: bool,
    early: (f64, f64),
) -> u64 {
    let one = (loops_per_step(method, n) + adaptive_loops(n, adaptive)) as f64;
    let n = n as f64;
    let (per_step, fixed) = if twin {
        (2.0 * one + 10.0 * n + early.0, 2.0 * n + early.1)
    } else {
        (one + early.0, early.1)
    };
    let health = 2.0 * n;
    let spare = SOFTWARE_LOOP_BUDGET as f64 - 2.0 * health - fixed;
    ((spare / (per_step + health / CHECK_EVERY as f64)) as u64).max(1)
}

/// Loop iterations of one integration step in the kernel, counted from the WGSL (an upper
/// bound: loops the compiler unrolls cost nothing), without the health check. The derivative
/// and the bumper flags are generated unrolled (`super::codegen`) and have no loop:
/// - RK4: the step loop (1), the first stage's state (N), four `keep_stage` (N each):
///   `5 N + 1`; above [`RK4_UNROLLED_UP_TO`] segments the generated stage states and finish
///   are loops too (4N more);
/// - IMEX: the step loop (1), `imex_step`'s copy (N), stage loop (3) and weighted sums
///   (5N + 4), four `imex_eval` (N each: the copy out) of which three add the joint couples
///   and an N × N product (N² + 3N), three `imex_implicit_stage` (2N² + (6 + i) N + i for
///   i = 1, 2, 3): `9 N² + 43 N + 14`.
fn loops_per_step(method: Method, n: usize) -> usize {
    match method {
        Method::Rk4 if n > RK4_UNROLLED_UP_TO => 9 * n + 1,
        Method::Rk4 => 5 * n + 1,
        Method::Imex => 9 * n * n + 43 * n + 14,
    }
}

/// Loop iterations a sub-step of adaptive steps adds to an IMEX step (with adaptive steps the
/// budget counts sub-steps tried, each a pass of the kernel's loop): `imex_error` (its sums
/// 5N, the couples N, two N × N products N² + N each, the piezo's 4): `2 N² + 8 N + 4`. The
/// same count bounds RK4(3)'s additions: `rk4_error`'s max (N), k₁ handed on (N) and kept
/// (N), the generated candidate and estimate above [`RK4_UNROLLED_UP_TO`] segments (2N), and
/// once a dispatch `prime_k1` (2N).
fn adaptive_loops(n: usize, adaptive: bool) -> usize {
    if adaptive { 2 * n * n + 8 * n + 4 } else { 0 }
}

/// The buffers of a run and their bind group (which keeps the others alive).
pub(crate) struct Buffers {
    /// The integration's schedule (`shaders/schedule.wgsl`): the next dispatch's workgroup
    /// count, then the instances still integrating (word [`super::layout::SCHED_LIVE`]).
    pub sched: wgpu::Buffer,
    /// The integration dispatch's indirect arguments, copied from `sched`'s first words (a
    /// buffer bound as storage cannot also be a dispatch's indirect arguments).
    pub args: wgpu::Buffer,
    pub state: wgpu::Buffer,
    pub accum: wgpu::Buffer,
    pub strobe: wgpu::Buffer,
    pub rwork: wgpu::Buffer,
    pub control: wgpu::Buffer,
    pub bind: wgpu::BindGroup,
}

impl Buffers {
    /// Create and fill every buffer of `plan` (λ1's twins at separation `twin_d0`). The
    /// buffers are created empty inside out-of-memory and validation error scopes, checked,
    /// and only then filled through the queue: a failed allocation is an error, not a panic.
    pub(crate) fn upload(
        ctx: &GpuContext,
        plan: &EnsemblePlan,
        reduce: &ReduceSettings,
        sizes: &Sizes,
        control: &GpuControl,
        twin_d0: f64,
    ) -> Result<Buffers, EngineError> {
        let (mats, offsets) = imex_matrices(plan);
        let limit = buffer_limit(ctx);
        let mats_bytes = 4 * mats.len() as u64;
        if mats_bytes > limit {
            return Err(EngineError::BufferTooLarge {
                what: "imex_mats",
                bytes: mats_bytes,
                limit,
            });
        }
        let params: Vec<GpuInstanceParams> = plan
            .instances
            .iter()
            .zip(&offsets)
            .map(|(p, &off)| GpuInstanceParams::from_plan(p, off, twin_d0))
            .collect();
        let (state, accum) = initial_state(plan, sizes);
        let levers = levers_sample_major(plan, sizes.n_inst);
        // The live list's two halves: every instance in the first, the second written by the
        // device's first compaction.
        let all: Vec<u32> = (0..sizes.n_inst as u32)
            .chain(std::iter::repeat_n(0, sizes.n_inst))
            .collect();
        let sched = [
            (sizes.n_inst as u32).div_ceil(sizes.per_group),
            1,
            1,
            sizes.n_inst as u32,
        ];
        let turns = c_turns(reduce);
        let zeros = vec![0u32; sizes.n_inst];
        let filled: [(&str, &[u8]); 9] = [
            ("params", bytemuck::cast_slice(&params)),
            ("state", bytemuck::cast_slice(&state)),
            ("accum", bytemuck::cast_slice(&accum)),
            ("c_turns", bytemuck::cast_slice(&turns)),
            ("imex_mats", bytemuck::cast_slice(&mats)),
            ("active", bytemuck::cast_slice(&all)),
            ("done", bytemuck::cast_slice(&zeros)),
            ("levers", bytemuck::cast_slice(&levers)),
            ("sched", bytemuck::cast_slice(&sched)),
        ];
        let dev = &ctx.device;
        let oom = dev.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let invalid = dev.push_error_scope(wgpu::ErrorFilter::Validation);
        let sto = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let create = |label: &str, size: u64, usage| {
            dev.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16).next_multiple_of(4),
                usage,
                mapped_at_creation: false,
            })
        };
        let [
            params,
            state,
            accum,
            turns,
            imex,
            active,
            done,
            levers,
            sched,
        ] = filled.map(|(label, bytes)| create(label, bytes.len() as u64, sto));
        let strobe = create("strobe", sizes.strobe_bytes, sto);
        let rwork = create("rwork", sizes.rwork_bytes, sto);
        let kc = create("kc", sizes.kc_bytes, sto);
        let early = create("early", sizes.early_bytes, sto);
        let args = create(
            "args",
            16,
            wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
        );
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let control_buf = create("control", size_of::<GpuControl>() as u64, uniform);
        let invalid = pollster::block_on(invalid.pop());
        let oom = pollster::block_on(oom.pop());
        allocation_checked(ctx, oom, invalid)?;
        let targets = [
            &params, &state, &accum, &turns, &imex, &active, &done, &levers, &sched,
        ];
        for (buffer, (_, bytes)) in targets.iter().zip(&filled) {
            write_padded(ctx, buffer, bytes);
        }
        ctx.queue
            .write_buffer(&control_buf, 0, bytemuck::bytes_of(control));
        let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ensemble"),
            layout: &ctx.bind_layout,
            entries: &[
                entry(0, &params),
                entry(1, &state),
                entry(2, &accum),
                entry(3, &strobe),
                entry(4, &rwork),
                entry(5, &turns),
                entry(6, &control_buf),
                entry(7, &kc),
                entry(8, &imex),
                entry(9, &early),
                entry(10, &active),
                entry(11, &done),
                entry(12, &levers),
                entry(13, &sched),
            ],
        });
        Ok(Buffers {
            sched,
            args,
            state,
            accum,
            strobe,
            rwork,
            control: control_buf,
            bind,
        })
    }
}

/// The allocation's outcome: an out-of-memory or validation error its scopes caught, or the
/// `oom` failpoint ([`super::fault`]), as a fault.
fn allocation_checked(
    ctx: &GpuContext,
    oom: Option<wgpu::Error>,
    invalid: Option<wgpu::Error>,
) -> Result<(), EngineError> {
    if let Some(e) = oom {
        return Err(ctx.fault(GpuFaultKind::OutOfMemory, e.to_string()));
    }
    if super::fault::failpoint()? == Some(super::fault::Failpoint::Oom) {
        return Err(ctx.fault(
            GpuFaultKind::OutOfMemory,
            format!("injected by {}=oom", super::fault::GPU_FAULT_ENV),
        ));
    }
    if let Some(e) = invalid {
        return Err(ctx.fault(GpuFaultKind::Validation, e.to_string()));
    }
    ctx.health()
}

/// Fill `buffer` with `bytes` (the queue writes whole 4-byte words).
fn write_padded(ctx: &GpuContext, buffer: &wgpu::Buffer, bytes: &[u8]) {
    if bytes.len().is_multiple_of(4) {
        ctx.queue.write_buffer(buffer, 0, bytes);
    } else {
        let mut padded = bytes.to_vec();
        padded.resize(bytes.len().next_multiple_of(4), 0);
        ctx.queue.write_buffer(buffer, 0, &padded);
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// The initial states (structure of arrays: component j of instance i at `j·n_inst + i`) and
/// accumulators, with the bumper contacts of the initial state.
/// Every instance's contact levers ([`levers_of`]), sample-major: lever i of instance k at
/// `i · n_inst + k`.
fn levers_sample_major(plan: &EnsemblePlan, n_inst: usize) -> Vec<f32> {
    let n = plan.segments.max(1);
    let mut out = vec![0f32; n * n_inst];
    for (k, p) in plan.instances.iter().enumerate() {
        for (i, v) in levers_of(p, n).into_iter().enumerate() {
            out[i * n_inst + k] = v;
        }
    }
    out
}

fn initial_state(plan: &EnsemblePlan, sizes: &Sizes) -> (Vec<f32>, Vec<GpuAccum>) {
    let n_inst = sizes.n_inst;
    let mut state = vec![0f32; n_inst * sizes.state_len];
    let mut accum = Vec::with_capacity(n_inst);
    for (i, p) in plan.instances.iter().enumerate() {
        for (j, &v) in p.y0.iter().enumerate() {
            state[j * n_inst + i] = v as f32;
        }
        let chain: Chain<f32> = Chain::new(&p.params);
        let y: Vec<f32> = p.y0.iter().map(|&v| v as f32).collect();
        let (r, l) = chain.touching(&y);
        let (tw_start, tw_window) = p
            .twin
            .map_or((0, 0), |t| (t.start_sample + p.transient_periods, t.window));
        accum.push(GpuAccum::initial(
            u32::from(r) | (u32::from(l) << 1),
            tw_start,
            tw_window,
        ));
    }
    (state, accum)
}

/// The IMEX matrices of every distinct (structure, step) set the instances share, as f32
/// (M0⁻¹, S⁻¹, M0 per set), and each instance's offset into them; a 16-byte placeholder and
/// zero offsets for RK4 (fixed or adaptive). Adaptive IMEX instances share a ladder per
/// (structure, base step): S⁻¹ of levels 1 … [`MAX_LEVEL`] follow their set
/// ([`ladder_matrices`]).
pub(crate) fn imex_matrices(plan: &EnsemblePlan) -> (Vec<f32>, Vec<u32>) {
    if plan.is_adaptive() && plan.method == Method::Imex {
        return ladder_matrices(plan);
    }
    let mut data: Vec<f32> = Vec::new();
    let mut seen: std::collections::HashMap<*const ImexMatrices, u32> = Default::default();
    let mut offsets = Vec::with_capacity(plan.instances.len());
    for p in &plan.instances {
        let Some(m) = &p.imex else {
            offsets.push(0);
            continue;
        };
        let key = std::sync::Arc::as_ptr(m);
        let off = *seen.entry(key).or_insert_with(|| {
            let off = data.len() as u32;
            push_f32(&mut data, [&m.m0_inv, &m.s_inv, &m.m0]);
            off
        });
        offsets.push(off);
    }
    data.resize(data.len().max(4), 0.0);
    (data, offsets)
}

/// The ladders of adaptive steps ([`crate::engine::adaptive`]): per distinct structure and
/// base step H, M0⁻¹, S⁻¹(H), M0, then S⁻¹(H / 2^k) for k = 1 … [`MAX_LEVEL`]
/// (`imex.wgsl`'s `mat_row_base`), built once per ladder, in parallel.
fn ladder_matrices(plan: &EnsemblePlan) -> (Vec<f32>, Vec<u32>) {
    use rayon::prelude::*;
    use std::collections::HashMap;
    let key = InstancePlan::imex_key;
    let mut first_of: HashMap<Vec<u64>, usize> = HashMap::new();
    let mut order: Vec<Vec<u64>> = Vec::new();
    for (i, p) in plan.instances.iter().enumerate() {
        let k = key(p);
        if !first_of.contains_key(&k) {
            first_of.insert(k.clone(), i);
            order.push(k);
        }
    }
    let ladders: Vec<Vec<f32>> = order
        .par_iter()
        .map(|k| {
            let p = &plan.instances[first_of[k]];
            let base = ImexMatrices::new(&p.params, p.dt_s);
            let mut data = Vec::new();
            push_f32(&mut data, [&base.m0_inv, &base.s_inv, &base.m0]);
            for level in 1..=MAX_LEVEL {
                let h = p.dt_s / f64::from(1u32 << level);
                push_f32(&mut data, [&ImexMatrices::new(&p.params, h).s_inv]);
            }
            data
        })
        .collect();
    let mut data = Vec::new();
    let mut offset_of: HashMap<&Vec<u64>, u32> = HashMap::new();
    for (k, ladder) in order.iter().zip(&ladders) {
        offset_of.insert(k, data.len() as u32);
        data.extend_from_slice(ladder);
    }
    let offsets = plan.instances.iter().map(|p| offset_of[&key(p)]).collect();
    data.resize(data.len().max(4), 0.0);
    (data, offsets)
}

/// The blocks, in order, as f32.
fn push_f32<const B: usize>(data: &mut Vec<f32>, blocks: [&Vec<f64>; B]) {
    for block in blocks {
        data.extend(block.iter().map(|&v| v as f32));
    }
}

/// c / 2π of the 0–1 test as 32-bit fixed-point fractions of a turn (exact phase arithmetic).
/// Padded to at least 4 entries (a buffer holds at least 16 bytes).
fn c_turns(reduce: &ReduceSettings) -> Vec<u32> {
    let mut turns: Vec<u32> = reduce
        .c_values
        .iter()
        .map(|c| (c / std::f64::consts::TAU * 4294967296.0).round() as u64 as u32)
        .collect();
    turns.resize(turns.len().max(4), 0);
    turns
}
