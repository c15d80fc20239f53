//! The buffers of one GPU run: sized and checked against the adapter before anything is
//! allocated, filled from the plan, bound once.

use crate::engine::error::{EngineError, GpuFaultKind};
use crate::engine::gpu::ReduceSettings;
use crate::engine::gpu::context::GpuContext;
use crate::engine::gpu::kernels::{KernelKey, WG, shader_source};
use crate::engine::gpu::layout::{GpuAccum, GpuControl, GpuInstanceParams, levers_of};
use crate::engine::gpu::loop_count::{LoopCountError, LoopCounter};
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
        // λ1's twin keeps a second state beside the main one, and each word its compensation
        // (`shaders/integrate.wgsl`, carried from one dispatch to the next).
        let state_len = 2 * (2 * plan.segments + 1) * if key.want_twin { 2 } else { 1 };
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
    if let Some(e) = plan.early_stop.filter(|_| key.want_early) {
        let e_loops = early_finish_loops(plan);
        if e_loops > SOFTWARE_LOOP_BUDGET {
            return Err(refuse(
                format!(
                    "the early stop's continuation (period max {}) of {} forcing periods",
                    e.p_max,
                    e_loops - s_n - r_n
                ),
                e_loops,
                "shorten the run, set map.early_stop = false, or use the CPU engine",
            ));
        }
    }
    let loops = StepLoops::count(plan, key).map_err(|e| EngineError::KernelLoops(e.to_string()))?;
    let one_step = loops.dispatch_of(1);
    if one_step > SOFTWARE_LOOP_BUDGET as u64 {
        let twin = if key.want_twin {
            " with λ1's twin"
        } else {
            ""
        };
        return Err(refuse(
            format!("one {} step at N = {n_seg}{twin}", key.method.name()),
            one_step as usize,
            "use the CPU engine, fewer segments, or RK4",
        ));
    }
    Ok(Some(loops.steps_within(SOFTWARE_LOOP_BUDGET as u64)))
}

/// Loop iterations of the early stop's own pass (`early_finish` of `shaders/early.wgsl`): its
/// continuation loops over every later forcing period, stroboscopic sample and R sample, run-time
/// trip counts bounded by the plan.
fn early_finish_loops(plan: &EnsemblePlan) -> usize {
    let periods = plan
        .instances
        .iter()
        .map(|p| p.total_periods)
        .max()
        .unwrap_or(0);
    periods as usize + plan.strobe_stride as usize + plan.r_stride as usize
}

/// The integration kernel's loop iterations, counted from its code ([`LoopCounter`]), in the
/// parts the step loop of `integrate` (`shaders/integrate.wgsl`) runs at different rates.
#[derive(Debug, Clone, Copy, PartialEq)]
struct StepLoops {
    /// One pass of the step loop: the pass itself (1), a step (`step_state`, and the twin's
    /// `twin_step` with λ1) or with adaptive steps a sub-step tried (`adaptive_substep`).
    pass: u64,
    /// One health check (`health`): every [`CHECK_EVERY`] steps, at a dispatch's start and end.
    health: u64,
    /// The events of one forcing period (`strobe_instant`, `period_end`): once per period.
    period: u64,
    /// A dispatch outside its step loop (`integrate`'s loads, stores and set-up).
    dispatch: u64,
    /// The fewest steps of a forcing period in the plan.
    spp_min: u64,
}

impl StepLoops {
    fn count(plan: &EnsemblePlan, key: &KernelKey) -> Result<StepLoops, LoopCountError> {
        let early = plan.early_stop.filter(|_| key.want_early);
        let spp_min = plan.instances.iter().map(|p| p.spp).min().unwrap_or(1);
        Self::count_for(key, early.map(|e| (e.p_max, e.window)), spp_min)
    }

    /// The counts of the kernels of `key`, with the early stop's longest period and window,
    /// and the fewest steps of a forcing period.
    fn count_for(
        key: &KernelKey,
        early: Option<(u32, u32)>,
        spp_min: u32,
    ) -> Result<StepLoops, LoopCountError> {
        let (p_max, window) = early.map_or((0, 0), |(p, w)| (i64::from(p), i64::from(w)));
        let uniforms = [("ctl.e_p_max", p_max), ("ctl.e_window", window)];
        let c = LoopCounter::new(&shader_source(key.chain), &key.constants(), &uniforms)?;
        let step = if key.adaptive {
            c.of("adaptive_substep", &[("twin_on", key.want_twin)])?
        } else {
            let twin = if key.want_twin {
                c.of("twin_step", &[])?
            } else {
                0
            };
            c.of("step_state", &[])? + twin
        };
        Ok(StepLoops {
            pass: 1 + step,
            health: c.of("health", &[])?,
            period: c.of("strobe_instant", &[])? + c.of("period_end", &[])?,
            dispatch: c.outside_loops("integrate")?,
            spp_min: u64::from(spp_min.max(1)),
        })
    }

    /// Loop iterations of a dispatch of `steps` steps (an upper bound, as below).
    fn dispatch_of(&self, steps: u64) -> u64 {
        let events = (steps / self.spp_min + 1) * self.period;
        let checks = (steps / CHECK_EVERY + 2) * self.health;
        steps * self.pass + events + checks + self.dispatch
    }

    /// The steps per dispatch whose loop iterations stay within `budget`: a pass per step
    /// (with adaptive steps a step takes one pass or more, and a dispatch counts passes); a
    /// forcing period's events every `spp_min` steps and once more (S steps meet each event at
    /// most S / spp_min + 1 times); a health check every [`CHECK_EVERY`] steps and two more;
    /// and the dispatch's own.
    fn steps_within(&self, budget: u64) -> u64 {
        let per_step = self.pass as f64
            + self.period as f64 / self.spp_min as f64
            + self.health as f64 / CHECK_EVERY as f64;
        let spare = budget.saturating_sub(2 * self.health + self.period + self.dispatch);
        ((spare as f64 / per_step) as u64).max(1)
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::gpu::kernels::GpuKernel;
    use crate::model::ChainShape;

    pub(super) fn key(
        n: usize,
        method: Method,
        adaptive: bool,
        twin: bool,
        early: bool,
    ) -> KernelKey {
        let scene = crate::config::load_scene(None, &[format!("beam.segments={n}")]).unwrap();
        KernelKey {
            chain: ChainShape::of(&scene.model_params().unwrap()),
            want_strobe: true,
            want_rseries: true,
            want_r: true,
            want_line: false,
            want_k: true,
            run_k_final: true,
            paper_convention: false,
            n_c: 100,
            method,
            want_twin: twin,
            want_early: early,
            adaptive,
            kernel: GpuKernel::Thread,
            runtime_checks: false,
        }
    }

    /// Every specialisation's step functions have loops of known trip counts, so a change
    /// that adds a loop bounded at run time to them fails here, not on lavapipe; and the steps
    /// per dispatch keep a dispatch within the budget. With `--nocapture` it prints the counts
    /// (`docs/model.md` §14).
    #[test]
    fn every_specialisation_counts_its_loops_from_the_kernel() {
        for n in [1, 3, 9, 17, 64] {
            for method in [Method::Rk4, Method::Imex] {
                for flags in 0..8 {
                    let (adaptive, twin, early) = (flags & 1 != 0, flags & 2 != 0, flags & 4 != 0);
                    let k = key(n, method, adaptive, twin, early);
                    let l = StepLoops::count_for(&k, early.then_some((8, 16)), 50).unwrap();
                    assert!(
                        l.pass > n as u64 && l.health >= n as u64,
                        "{n} {method:?} {l:?}"
                    );
                    let budget = SOFTWARE_LOOP_BUDGET as u64;
                    let steps = l.steps_within(budget);
                    let fits = l.dispatch_of(steps) <= budget;
                    assert!(fits || l.dispatch_of(1) > budget, "{n} {method:?} {l:?}");
                    println!(
                        "N = {n} {method:?} adaptive {adaptive} twin {twin} early {early}: \
                         {l:?}, {steps} steps a dispatch, {} loops for one",
                        l.dispatch_of(1)
                    );
                }
            }
        }
    }

    /// The counts the kernel's loops give at N = 3, fixed steps, no twin or early stop: a step
    /// copies the state and keeps four stages (5 N, with the pass 5 N + 1); a health check
    /// tests the state and the bends in one loop (N).
    #[test]
    fn an_rk4_step_counts_the_loops_its_wgsl_has() {
        let l = StepLoops::count_for(&key(3, Method::Rk4, false, false, false), None, 50).unwrap();
        assert_eq!((l.pass, l.health), (16, 3));
        let twin = StepLoops::count_for(&key(3, Method::Rk4, false, true, false), None, 50);
        // The twin's step adds its swaps in and out (2 N) to a second step.
        assert_eq!(twin.unwrap().pass, 1 + 2 * 15 + 6);
    }
}
