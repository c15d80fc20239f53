//! The structs the GPU kernels read and write, `#[repr(C)]` and [`bytemuck::Pod`], each
//! defined once here: their WGSL twins are generated from these definitions into the kernels'
//! header (`gpu_struct!`; a test compares both layouts with naga).
//!
//! [`GpuInstanceParams`] is filled from the one parameter struct, `ModelParams`, and the
//! instance's step plan: no physical coefficient is derived anywhere else.

use crate::config::StepControl;
use crate::engine::gpu::gpu_struct::{GpuStruct, gpu_struct};
use crate::engine::plan::{EnsemblePlan, InstancePlan};
use crate::model::Coefficient;
use crate::reduce::TwinPlan;
use crate::reduce::lyapunov::{LYAPUNOV_BLOCKS, TwinNorm};
use crate::schema::{GPU_SLOTS, WgslType, gpu_fields};
use bytemuck::Zeroable;

/// Largest segment count the GPU kernel's per-invocation arrays hold.
pub(crate) const GPU_MAX_SEGMENTS: usize = 64;

gpu_struct! {
    /// Per-instance coefficients and step plan (WGSL `InstanceParams`); the contact levers are
    /// in a buffer of their own (`levers_of`).
    pub struct GpuInstanceParams as "InstanceParams" {
        /// ℓ (m).
        pub seg_len: f32,
        /// m (kg).
        pub seg_mass: f32,
        /// J (kg m²).
        pub seg_inertia: f32,
        /// M (kg).
        pub tip_mass: f32,
        /// J_h (kg m²).
        pub holder_inertia: f32,
        /// g (m/s²).
        pub g: f32,
        /// k (N m/rad).
        pub k: f32,
        /// k0 (N m/rad).
        pub k0: f32,
        /// b (N m s/rad).
        pub b: f32,
        /// b0 (N m s/rad).
        pub b0: f32,
        /// g_c (m).
        pub gap: f32,
        /// k_c (N/m).
        pub kc: f32,
        /// c_c (N s/m).
        pub cc: f32,
        /// 1/C_p (1/F).
        pub piezo_inv_c: f32,
        /// 1/R_L (1/Ω).
        pub piezo_inv_r: f32,
        /// Θ (N m/V).
        pub piezo_theta: f32,
        /// A (m).
        pub pos_amp: f32,
        /// A ω (m/s).
        pub vel_amp: f32,
        /// A ω² (m/s²).
        pub acc_amp: f32,
        /// dt (s).
        pub dt: f32,
        /// Energy bound of the guard (J).
        pub guard_energy: f32,
        /// Joint bend bound of the guard (rad).
        pub guard_bend: f32,
        /// Initial angle (rad).
        pub theta0: f32,
        /// Initial rate (rad/s).
        pub omega0: f32,
        /// Initial voltage (V).
        pub volt0: f32,
        /// θc/2 (rad), the well threshold of hop counting.
        pub half_clearance: f32,
        /// |α| beyond which the holder has escaped over a bumper (rad; huge without bumpers).
        pub guard_holder: f32,
        /// Forcing phase at t = 0 (cycles, [`CartMotion::phase_cycles`](crate::model::CartMotion)).
        pub phase0: f32,
        /// Number of contact levers.
        pub n_levers: u32,
        /// Last segment of the piezo patch (0-based).
        pub piezo_last: u32,
        /// Steps per forcing period.
        pub spp: u32,
        /// Transient periods.
        pub transient_periods: u32,
        /// Total periods.
        pub total_periods: u32,
        /// Step within the period of the stroboscopic samples.
        pub strobe_offset: u32,
        /// Stroboscopic samples after the transient.
        pub strobe_count: u32,
        /// Steps between R samples.
        pub r_every: u32,
        /// R series length.
        pub r_count: u32,
        /// Step of the first R sample.
        pub r_start: u32,
        /// Index (in f32) of this instance's IMEX matrices in the matrix buffer (0 for RK4).
        pub imex_offset: u32,
        /// The contact damping law ([`crate::model::ContactDamping::gpu_code`]).
        pub contact_law: u32,
        /// λ1's twin: the stroboscopic sample it starts at ([`TwinPlan::start_sample`]).
        pub twin_start: u32,
        /// Renormalisations that align the twin.
        pub twin_align: u32,
        /// Renormalisations averaged into λ1 (0: no twin).
        pub twin_window: u32,
        /// The twin's separation d0.
        pub twin_d0: f32,
        /// The rigid rotation's weight in the twin's norm, [`TwinNorm::rigid_weight`].
        pub twin_rigid_w: f32,
        /// The scale of the twin's norm, [`TwinNorm::scale`] (the chain's inertias, springs and
        /// the patch's capacitance are the instance's own).
        pub twin_scale: f32,
        /// The voltage's weight in the twin's norm, [`TwinNorm::volt_weight`] (C_p of a coupled
        /// patch, else 0).
        pub twin_volt_w: f32,
        /// The twin's start offset `d0·u` of every angle ([`TwinNorm::start_offset`], the
        /// CPU's too).
        pub twin_start_th: f32,
        /// The twin's start offset of every rate.
        pub twin_start_om: f32,
        /// The twin's start offset of the voltage (0 without a coupled patch).
        pub twin_start_v: f32,
        /// The forcing period T = 1/f (s).
        pub period_s: f32,
        /// Adaptive steps: the relative tolerance (0 for fixed steps).
        pub rtol: f32,
        /// Adaptive steps: the absolute tolerance (0 for fixed steps).
        pub atol: f32,
    }
}

/// The contact levers λ_i (m) of an instance, `segments` words (zero past the contact
/// segment): the `levers` buffer holds them sample-major, N words per instance, beside the
/// parameter block, so that the block has no array sized for the largest N.
pub(crate) fn levers_of(p: &InstancePlan, segments: usize) -> Vec<f32> {
    (0..segments)
        .map(|i| Coefficient::Lever(i).of(&p.params) as f32)
        .collect()
}

impl GpuInstanceParams {
    /// From an instance plan (its `ModelParams` and step plan), its IMEX matrices at
    /// `imex_offset` of the matrix buffer, λ1's twin (when the plan has one) at separation
    /// `twin_d0`.
    pub(crate) fn from_plan(p: &InstancePlan, imex_offset: u32, twin_d0: f64) -> GpuInstanceParams {
        let m = &p.params;
        // The chain's coefficients as the CPU engine's `Chain` takes them (one definition).
        let c = |k: Coefficient| k.of(m) as f32;
        let n_levers = m.contact.as_ref().map_or(0, |c| c.levers_m.len() as u32);
        let last = m.piezo.as_ref().map_or(0, |z| z.last_segment as u32);
        let n = m.segments;
        let w = std::f64::consts::TAU * p.frequency_hz;
        let (rtol, atol) = match p.control {
            StepControl::Adaptive { rtol, atol } => (rtol, atol),
            StepControl::Fixed => (0.0, 0.0),
        };
        let twin = p.twin.unwrap_or(TwinPlan {
            start_sample: 0,
            align: 0,
            window: 0,
            norm: TwinNorm::of(m, w),
            period_s: 1.0 / p.frequency_hz,
        });
        let offset = twin.norm.start_offset(n, 2 * n + 1, twin_d0);
        let start = |k: usize| offset[k] as f32;
        GpuInstanceParams {
            seg_len: c(Coefficient::SegLength),
            seg_mass: c(Coefficient::SegMass),
            seg_inertia: c(Coefficient::SegInertia),
            tip_mass: c(Coefficient::TipMass),
            holder_inertia: c(Coefficient::HolderInertia),
            g: c(Coefficient::Gravity),
            k: c(Coefficient::JointStiffness),
            k0: c(Coefficient::RootStiffness),
            b: c(Coefficient::JointDamping),
            b0: c(Coefficient::RootDamping),
            gap: c(Coefficient::BumperGap),
            kc: c(Coefficient::BumperStiffness),
            cc: c(Coefficient::BumperDamping),
            piezo_inv_c: c(Coefficient::PiezoInvCapacitance),
            piezo_inv_r: c(Coefficient::PiezoInvLoad),
            piezo_theta: c(Coefficient::PiezoCoupling),
            pos_amp: p.amplitude_m as f32,
            vel_amp: (p.amplitude_m * w) as f32,
            acc_amp: (p.amplitude_m * w * w) as f32,
            dt: p.dt_s as f32,
            guard_energy: p.guard.max_energy_j as f32,
            guard_bend: p.guard.max_joint_bend_rad as f32,
            theta0: p.y0[0] as f32,
            omega0: p.y0[n] as f32,
            volt0: p.y0[2 * n] as f32,
            half_clearance: p.half_clearance_rad as f32,
            guard_holder: p.guard.max_holder_angle_rad.min(f64::from(f32::MAX)) as f32,
            phase0: p.params.cart.phase_cycles as f32,
            n_levers,
            piezo_last: last,
            spp: p.spp,
            transient_periods: p.transient_periods,
            total_periods: p.total_periods,
            strobe_offset: p.strobe_offset,
            strobe_count: p.strobe_count,
            r_every: p.r_every,
            r_count: p.r_count,
            r_start: p.r_start,
            imex_offset,
            contact_law: m.contact.as_ref().map_or(0, |c| c.law.gpu_code()),
            twin_start: twin.start_sample,
            twin_align: twin.align,
            twin_window: twin.window,
            twin_d0: twin_d0 as f32,
            twin_rigid_w: twin.norm.rigid_weight as f32,
            twin_scale: twin.norm.scale as f32,
            twin_volt_w: twin.norm.volt_weight as f32,
            twin_start_th: start(0),
            twin_start_om: start(n),
            twin_start_v: start(2 * n),
            period_s: (1.0 / p.frequency_hz) as f32,
            rtol: rtol as f32,
            atol: atol as f32,
        }
    }
}

gpu_struct! {
    /// Running accumulators and reductions of one instance (WGSL `Accum`, generated from this
    /// definition: `accum_wgsl`). Its first words are the result schema's GPU slots
    /// ([`crate::schema::gpu_fields`], in the table's order), then the engine's own words
    /// (member for member).
    pub struct GpuAccum as "Accum" {
        /// The result schema's words (K, the period, the tallies, λ1, the regime, the status, the
        /// steps taken...), as bits; read with [`GpuAccum::read`].
        pub slots: [u32; GPU_SLOTS],
        /// Bumper penetration flags after the last step.
        pub touch: u32,
        /// Current well (+1, −1, 0 = none yet).
        pub well: i32,
        /// Adaptive steps: the position within the base step where the last dispatch stopped
        /// (in units of the finest step; 0 at a base step's start).
        pub sub_pos: u32,
        /// Kahan compensation of the power sum.
        pub power_comp: f32,
        /// Adaptive steps: the sub-steps tried, accepted and rejected.
        pub sub_steps: u32,
        /// λ1's twin: Σ ln(d/d0) per block of the window.
        pub lyap_sums: [f32; LYAPUNOV_BLOCKS],
        /// Growths summed so far.
        pub lyap_n: u32,
        /// The twin's state: [`TWIN_RUNNING`], [`TWIN_BROKEN`] bits.
        pub twin_flags: u32,
        /// λ1's twin: its first stroboscopic instant (absolute, the transient included).
        pub tw_start: u32,
        /// Its window (renormalisations averaged).
        pub tw_window: u32,
        /// The current period's hops.
        pub p_hops: u32,
        /// The current period's contact onsets.
        pub p_impacts: u32,
        /// The current period's Σ v²/R_L.
        pub p_power: f32,
        /// The current period's smallest α (rad).
        pub p_amin: f32,
        /// The current period's largest α (rad).
        pub p_amax: f32,
        /// The early stop's phase (watching, measuring, closing, off: `shaders/early.wgsl`).
        pub e_phase: u32,
        /// The confirmed orbit's period (forcing periods).
        pub e_p: u32,
        /// The instant λ1's measurement of the confirmed orbit ends.
        pub e_until: u32,
        /// Stroboscopic instants kept so far.
        pub e_seen: u32,
        /// The last one.
        pub e_last: u32,
        /// The period of the orbit the instance stopped on (0: it ran to its end).
        pub stopped: u32,
        /// Adaptive steps: the ladder level k of the next sub-step (h = dt / 2^k).
        pub level: u32,
        /// Adaptive steps: contact onsets within the base step so far.
        pub sub_onsets: u32,
    }
}

/// The WGSL `Accum` struct, generated from [`GpuAccum`]: its `slots` written out as the result
/// schema's words (one named member each, in the schema's order), then the engine's own.
pub(crate) fn accum_wgsl() -> String {
    let mut s = String::from(
        "// Generated from `GpuAccum` (src/engine/gpu/layout.rs): the result schema's words \
         (src/schema.rs), then the engine's own.\nstruct Accum {\n",
    );
    for m in GpuAccum::members() {
        if m.name == "slots" {
            for (f, g) in gpu_fields() {
                s += &format!("    {}: {}, // {}\n", g.member, g.ty.name(), f.name);
            }
        } else {
            s += &format!("    {}: {}, // {}\n", m.name, m.wgsl, m.doc.trim());
        }
    }
    s + "}\n"
}

/// `GpuAccum::twin_flags`: the twin runs (the kernel advances it).
pub const TWIN_RUNNING: u32 = 1;
/// `GpuAccum::twin_flags`: a separation was zero or not finite.
pub const TWIN_BROKEN: u32 = 2;

impl GpuAccum {
    /// The state before the first step, with bumper flags `touch`, of an instance whose twin
    /// (if any) starts at instant `tw_start` with a window of `tw_window`: each result word at
    /// its schema's initial value.
    pub fn initial(touch: u32, tw_start: u32, tw_window: u32) -> GpuAccum {
        let mut slots = [0u32; GPU_SLOTS];
        for (word, (_, g)) in slots.iter_mut().zip(gpu_fields()) {
            *word = match g.ty {
                WgslType::F32 => g.initial.to_bits(),
                WgslType::U32 => g.initial as u32,
                WgslType::I32 => (g.initial as i32) as u32,
            };
        }
        GpuAccum {
            slots,
            touch,
            tw_start,
            tw_window,
            p_amin: f32::MAX,
            p_amax: -f32::MAX,
            ..GpuAccum::zeroed()
        }
    }

    /// The value of the result `name`'s word (a schema row with a GPU slot).
    pub fn read(&self, name: &str) -> f64 {
        let (i, (_, g)) = gpu_fields()
            .enumerate()
            .find(|(_, (f, _))| f.name == name)
            .unwrap_or_else(|| panic!("`{name}` has no GPU slot in the result schema"));
        g.ty.read(self.slots[i])
    }

    /// The raw word of the result `name` (a code or count, exactly).
    pub fn word(&self, name: &str) -> u32 {
        let i = gpu_fields()
            .position(|(f, _)| f.name == name)
            .unwrap_or_else(|| panic!("`{name}` has no GPU slot in the result schema"));
        self.slots[i]
    }
}

gpu_struct! {
    /// Settings shared by every instance of a dispatch (WGSL `Control`, a uniform).
    pub struct GpuControl as "Control" {
        /// Instances.
        pub n_inst: u32,
        /// Steps each instance advances per dispatch (fixed steps; `u32::MAX` with adaptive
        /// steps, whose dispatches are bounded by `pass_budget`).
        pub steps_per_dispatch: u32,
        /// Stroboscopic samples per instance in the strobe buffer (its capacity; the buffer is
        /// sample-major, `n_inst` words per sample).
        pub strobe_stride: u32,
        /// Work-space entries (vec2) per instance (sample-major like the strobe buffer).
        pub rwork_stride: u32,
        /// Longest period searched.
        pub period_max: u32,
        /// Trailing samples that must repeat.
        pub period_window: u32,
        /// Period tolerance (rad).
        pub period_tol: f32,
        /// The c value the `k_pass` kernel works on.
        pub c_index: u32,
        /// The first instance a reduction dispatch covers (its slice, `slices.rs`).
        pub slice_first: u32,
        /// One past the last instance a reduction dispatch covers (`n_inst` when unsliced).
        pub slice_end: u32,
        /// Instances in the `active` list (the integration kernel's range).
        pub n_active: u32,
        /// The early stop: longest period tried (0 without the early stop).
        pub e_p_max: u32,
        /// Trailing stroboscopic instants that must repeat.
        pub e_window: u32,
        /// Relative tolerance of the repetition.
        pub e_tol: f32,
        /// Offset (words) of the α ring in an instance's early-stop rings.
        pub e_alpha_off: u32,
        /// Offset of the period tallies.
        pub e_period_off: u32,
        /// Offset of the R instants' α.
        pub e_r_off: u32,
        /// Length of that ring (1 when unused).
        pub e_r_len: u32,
        /// Adaptive steps: sub-steps an invocation tries per dispatch, the dispatch's size (within
        /// a software adapter's loop budget). A dispatch may end within a base step.
        pub pass_budget: u32,
        /// The half of the `live` list the integration dispatch reads (0 or `n_inst`); the
        /// device's compaction writes the other (`shaders/schedule.wgsl`).
        pub live_from: u32,
        /// 1, read at run time: the kernels' compensated sums multiply by it so that their
        /// shader compiler cannot fold `(s − y) − c` to 0 ([`crate::model::Lane::opaque`]).
        pub one: f32,
    }
}

/// Word of the schedule buffer (`sched`) that counts the instances still integrating; words
/// 0–2 are the next integration dispatch's workgroup count (an indirect dispatch).
pub(crate) const SCHED_LIVE: u32 = 3;

/// Words of one tally in the early stop's period ring (hops, impacts, Σ v²/R_L, α min, max).
pub(crate) const EARLY_PERIOD_WORDS: u32 = 5;

impl GpuControl {
    /// The early stop's part of the control block for `plan` (zeros without the early stop),
    /// and the words of one instance's rings.
    pub(crate) fn with_early(mut self, plan: &EnsemblePlan) -> (GpuControl, u32) {
        let Some(e) = plan.early_stop else {
            self.e_r_len = 1;
            return (self, 0);
        };
        let dim = 2 * plan.segments as u32 + 1;
        let sp = plan.instances.first().map_or(1, |p| p.spp / p.r_every);
        self.e_p_max = e.p_max;
        self.e_window = e.window;
        self.e_tol = e.tol_in::<f32>() as f32;
        self.e_alpha_off = (e.p_max + 1) * dim;
        self.e_period_off = self.e_alpha_off + e.window + e.p_max;
        self.e_r_off = self.e_period_off + EARLY_PERIOD_WORDS * e.p_max;
        self.e_r_len = if plan.want_rseries { e.p_max * sp } else { 1 };
        let words = self.e_r_off + if plan.want_rseries { self.e_r_len } else { 0 };
        (self, words)
    }
}
