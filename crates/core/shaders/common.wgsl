// Common definitions of the ensemble kernels of pendulum-atlas: specialisation constants, the
// data structures shared with Rust, the bindings and the integrator's per-invocation state.
//
// The kernels are assembled from eight files (common, integrate, schedule, early, imex,
// reduce_r, reduce_k, verdict; see src/engine/gpu/kernels.rs) behind the chain's functions and
// RK4's arithmetic, generated from src/model/chain.rs and src/engine/rk4.rs, and a header from the
// Rust definitions: the status and regime codes, the health-check interval CHECK_EVERY, the array
// bound MAX_SEG (the scene's N), the IMEX method's tableaux, the adaptive ladder's rules
// (src/engine/ladder.rs) and the structs shared with Rust (`InstanceParams`, `Control`, and
// `Accum`, whose first words are the result schema's, src/schema.rs). The physics is
// docs/model.md, the reductions docs/analysis.md; the CPU twin of every function is named where
// it is defined, and the engine test suite holds the two against each other.

// ---- specialisation --------------------------------------------------------------------
override N_SEG: u32 = 3u;           // rigid segments N (<= MAX_SEG)
override HAS_CONTACT: bool = true;  // limiter.enabled
override HAS_PIEZO: bool = false;   // piezo.enabled
override WANT_STROBE: bool = true;  // K, period or a bifurcation diagram asked for
override WANT_RSERIES: bool = true; // R or the dominant line asked for
override WANT_K: bool = true;      // K asked for (the period alone skips the 0–1 test)
override PAPER_CONVENTION: bool = false; // R with Δφ reduced modulo π (paper) or 2π (standard)
override WG: u32 = 64u;             // workgroup size of the integration and R kernels
override WG_K: u32 = 32u;           // workgroup size of the 0–1 test kernel
override N_C: u32 = 100u;           // number of c values of the 0–1 test
override METHOD_IMEX: bool = false; // integrate with the IMEX method (else classical RK4)
override WANT_TWIN: bool = false;   // λ1 asked for: a twin trajectory rides along
override WANT_EARLY: bool = false;  // the early stop of confirmed orbits (shaders/early.wgsl)
override ADAPTIVE: bool = false;    // adaptive IMEX steps on the ladder (integrate.wgsl's adaptive_step)

const TAU: f32 = 6.2831853071795864;
const PI: f32 = 3.1415926535897932;

// sin and cos of 2π·x for any x: the turn is reduced to [-1/2, 1/2] first, so the argument
// stays within [-π, π], where WGSL bounds the error of sin and cos.
fn sin_turn(x: f32) -> f32 {
    return sin(TAU * (x - round(x)));
}

fn cos_turn(x: f32) -> f32 {
    return cos(TAU * (x - round(x)));
}

// ---- data ------------------------------------------------------------------------------
// `InstanceParams`, `Control` and `Accum` are generated into the header from their Rust
// definitions (`GpuInstanceParams`, `GpuControl`, `GpuAccum` in src/engine/gpu/layout.rs).

@group(0) @binding(0) var<storage, read> params: array<InstanceParams>;
// State, structure of arrays: component j of instance i at [j * n_inst + i], j < 2N + 1.
// With λ1, the twin's state follows: its component j at [(2N + 1 + j) * n_inst + i]. Then the
// summation compensation of each of those words w, at [(W + w) * n_inst + i], W the words
// before it (2N + 1, or 2(2N + 1) with the twin).
@group(0) @binding(1) var<storage, read_write> state: array<f32>;
@group(0) @binding(2) var<storage, read_write> acc: array<Accum>;
// The IMEX method's matrices (M0⁻¹, S⁻¹, M0; N × N each, row-major) per structure and step.
@group(0) @binding(8) var<storage, read> imex_mats: array<f32>;
// Stroboscopic samples of α, sample-major: sample j of instance i at [at(i, j)].
@group(0) @binding(3) var<storage, read_write> strobe: array<f32>;
// Work space of the reductions: the uniform α series (then its analytic signal and the
// cart's), or the (p, q) sums of the 0–1 test; sample-major like `strobe`.
@group(0) @binding(4) var<storage, read_write> rwork: array<vec2<f32>>;
// c / 2π of the 0–1 test as 32-bit fixed-point fractions of a turn (exact phase arithmetic).
@group(0) @binding(5) var<storage, read> cturns: array<u32>;
@group(0) @binding(6) var<uniform> ctl: Control;
// K_c of every instance and c value: value c of instance i at [at(i, c)].
@group(0) @binding(7) var<storage, read_write> kc: array<f32>;
// The early stop's rings (shaders/early.wgsl), word w of instance i at [at(i, w)]: the states
// at the last p_max + 1 stroboscopic instants, then α at the last window + p_max
// (ctl.e_alpha_off), the tallies of the last p_max periods (ctl.e_period_off, 5 words each),
// α at the R instants of the last p_max periods (ctl.e_r_off, ctl.e_r_len words).
@group(0) @binding(9) var<storage, read_write> early: array<f32>;
// The instances still integrating, ctl.n_active of them from ctl.live_from, in two halves of
// n_inst words: each dispatch reads one, and `compact` (shaders/schedule.wgsl) keeps the
// unfinished ones in the other.
@group(0) @binding(10) var<storage, read_write> live: array<u32>;
// 1 once an instance has finished (failed, stopped early, or run all its steps).
@group(0) @binding(11) var<storage, read_write> done: array<u32>;
// The contact levers λ_i, N words per instance, sample-major: lever i of instance `inst` at
// [at(inst, i)] (zero past the contact segment).
@group(0) @binding(12) var<storage, read> levers: array<f32>;
// The integration's schedule, written on the device (shaders/schedule.wgsl): the next
// dispatch's workgroup count (words 0–2, an indirect dispatch's arguments), then the
// instances still integrating (word SCHED_LIVE).
@group(0) @binding(13) var<storage, read_write> sched: array<atomic<u32>>;

// Word j of instance `inst` in the per-instance series (strobe, rwork, kc): sample-major, as
// the state is, so that neighbouring invocations read and write neighbouring words (coalesced
// on a GPU, one cache line per vector of invocations on lavapipe).
fn at(inst: u32, j: u32) -> u32 {
    return j * ctl.n_inst + inst;
}

// ---- per-invocation state of the integrator ---------------------------------------------
var<private> P: InstanceParams;
// Contact levers λ_i (n_levers ≤ N), copied from the `levers` buffer at a dispatch's start.
var<private> lev: array<f32, MAX_SEG>;
var<private> th: array<f32, MAX_SEG>;     // θ at the start of the step
var<private> om: array<f32, MAX_SEG>;     // θ̇ at the start of the step
// The stage derivatives of either method (`keep_stage`): θ̇, θ̈ and v̇ of stage j.
var<private> f_th: array<array<f32, MAX_SEG>, 4>;
var<private> f_om: array<array<f32, MAX_SEG>, 4>;
var<private> f_v: array<f32, 4>;
var<private> k1_om: array<f32, MAX_SEG>;  // adaptive RK4: θ̈ of the next try's k₁
var<private> k1_v: f32;                   // adaptive RK4: v̇ of the next try's k₁
var<private> k1_branch: u32;              // adaptive RK4: k₁'s bumper branches
var<private> sth: array<f32, MAX_SEG>;    // stage state θ
var<private> som: array<f32, MAX_SEG>;    // stage state θ̇
var<private> acc_out: array<f32, MAX_SEG>; // θ̈ of the last derivative
var<private> dvolt_out: f32;              // v̇ of the last derivative
var<private> volt: f32;
var<private> svolt: f32;
// Summation compensation of the state (compensated_add of src/engine/stepper.rs), zero at the
// start of each dispatch: at most one rounding per dispatch is not carried over.
var<private> th_c: array<f32, MAX_SEG>;
var<private> om_c: array<f32, MAX_SEG>;
var<private> volt_c: f32;
// λ1's twin (src/engine/twin.rs): its state and compensation, swapped with the main ones
// while it is stepped (`swap_twin`); while `twin_mode` is set, each stage's bumpers take the
// branches the main step recorded in `branch_bits` (4 bits per stage: +x on, +x damped,
// −x on, −x damped; `stage_n` counts the stages of a step).
var<private> tw_th: array<f32, MAX_SEG>;
var<private> tw_om: array<f32, MAX_SEG>;
var<private> tw_volt: f32;
var<private> tw_th_c: array<f32, MAX_SEG>;
var<private> tw_om_c: array<f32, MAX_SEG>;
var<private> tw_volt_c: f32;
var<private> twin_mode: bool;
var<private> stage_n: u32;
var<private> branch_bits: u32;
