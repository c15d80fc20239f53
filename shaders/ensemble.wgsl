// Ensemble engine of pendulum-atlas: thousands of independent instances of the model of
// shared/docs/MODEL.md, one invocation each, integrated in f32 with classical RK4, and the
// per-instance reductions (0–1 test K, phase synchronisation R, period) of ANALYSIS.md.
//
// The CPU twin of every function here is in src/integrate/ensemble.rs (integration and
// bookkeeping) and src/analysis (reductions); tests hold the two against each other.
//
// Specialised at pipeline creation with override constants: the segment count, whether the
// bumpers and the piezo exist, and which series the requested metrics need. Kernels whose
// metric is not requested are never created, and their buffers are not allocated.

// ---- specialisation --------------------------------------------------------------------
override N_SEG: u32 = 3u;           // rigid segments N (<= MAX_SEG)
override HAS_CONTACT: bool = true;  // limiter.enabled
override HAS_PIEZO: bool = false;   // piezo.enabled
override WANT_STROBE: bool = true;  // K, period or a bifurcation diagram asked for
override WANT_RSERIES: bool = true; // R asked for
override WANT_K: bool = true;      // K asked for (the period alone skips the 0–1 test)
override PAPER_CONVENTION: bool = false; // R with Δφ reduced modulo π (paper) or 2π (standard)
override WG: u32 = 64u;             // workgroup size of the integration and R kernels
override WG_K: u32 = 32u;           // workgroup size of the 0–1 test kernel
override N_C: u32 = 100u;           // number of c values of the 0–1 test

const MAX_SEG: u32 = 64u;
const CHECK_EVERY: u32 = 64u;
const TAU: f32 = 6.2831853071795864;
const PI: f32 = 3.1415926535897932;

const STATUS_OK: u32 = 0u;
const STATUS_DIVERGED: u32 = 1u;
const STATUS_NONFINITE: u32 = 2u;
const STATUS_ESCAPED: u32 = 3u;

// ---- data ------------------------------------------------------------------------------
// Mirrors `GpuInstanceParams` in src/integrate/gpu/layout.rs (a test compares the layouts).
struct InstanceParams {
    seg_len: f32,
    seg_mass: f32,
    seg_inertia: f32,
    tip_mass: f32,
    holder_inertia: f32,
    g: f32,
    k: f32,
    k0: f32,
    b: f32,
    b0: f32,
    gap: f32,
    kc: f32,
    cc: f32,
    piezo_inv_c: f32,
    piezo_inv_r: f32,
    piezo_theta: f32,
    pos_amp: f32,
    vel_amp: f32,
    acc_amp: f32,
    dt: f32,
    guard_energy: f32,
    guard_bend: f32,
    theta0: f32,
    omega0: f32,
    volt0: f32,
    half_clearance: f32,
    guard_holder: f32,
    pad1: f32,
    n_levers: u32,
    piezo_last: u32,
    spp: u32,
    transient_periods: u32,
    total_periods: u32,
    strobe_offset: u32,
    strobe_count: u32,
    r_every: u32,
    r_count: u32,
    r_start: u32,
    pad2: u32,
    pad3: u32,
    levers: array<f32, 64>,
}

// Mirrors `GpuAccum`: running accumulators while integrating, then the reductions.
struct Accum {
    step: u32,
    status: u32,
    touch: u32,
    well: i32,
    hops: u32,
    impacts: u32,
    period: u32,
    pad0: u32,
    alpha_min: f32,
    alpha_max: f32,
    power_sum: f32,
    power_comp: f32,
    k: f32,
    r: f32,
    pad1: f32,
    pad2: f32,
}

// Mirrors `GpuControl`.
struct Control {
    n_inst: u32,
    steps_per_dispatch: u32,
    strobe_stride: u32,
    rwork_stride: u32,
    period_max: u32,
    period_window: u32,
    period_tol: f32,
    c_index: u32,
}

@group(0) @binding(0) var<storage, read> params: array<InstanceParams>;
// State, structure of arrays: component j of instance i at [j * n_inst + i], j < 2N + 1.
@group(0) @binding(1) var<storage, read_write> state: array<f32>;
@group(0) @binding(2) var<storage, read_write> acc: array<Accum>;
// Stroboscopic samples of α, `strobe_stride` per instance.
@group(0) @binding(3) var<storage, read_write> strobe: array<f32>;
// Work space of the reductions: the uniform α series (then its analytic signal and the
// cart's), or the (p, q) sums of the 0–1 test; `rwork_stride` per instance.
@group(0) @binding(4) var<storage, read_write> rwork: array<vec2<f32>>;
// c / 2π of the 0–1 test as 32-bit fixed-point fractions of a turn (exact phase arithmetic).
@group(0) @binding(5) var<storage, read> cturns: array<u32>;
@group(0) @binding(6) var<uniform> ctl: Control;
// K_c of every instance and c value, N_C per instance.
@group(0) @binding(7) var<storage, read_write> kc: array<f32>;

// ---- per-invocation state of the integrator ---------------------------------------------
var<private> P: InstanceParams;
var<private> th: array<f32, MAX_SEG>;     // θ at the start of the step
var<private> om: array<f32, MAX_SEG>;     // θ̇ at the start of the step
var<private> th_acc: array<f32, MAX_SEG>; // Σ w_s k_s for θ
var<private> om_acc: array<f32, MAX_SEG>; // Σ w_s k_s for θ̇
var<private> sth: array<f32, MAX_SEG>;    // stage state θ
var<private> som: array<f32, MAX_SEG>;    // stage state θ̇
var<private> sn: array<f32, MAX_SEG>;
var<private> cs: array<f32, MAX_SEG>;
var<private> hx: array<f32, MAX_SEG>;
var<private> hy: array<f32, MAX_SEG>;
var<private> dinv: array<f32, MAX_SEG>;
var<private> beta: array<f32, MAX_SEG>;
var<private> volt: f32;
var<private> volt_acc: f32;
var<private> svolt: f32;

// Cart acceleration at phase (step mod spp + frac) / spp: exact phase, never t += dt.
fn cart_acc(phase_steps: u32, frac: f32) -> f32 {
    let ph = (f32(phase_steps) + frac) / f32(P.spp);
    return -P.acc_amp * sin(TAU * ph);
}

// Bumper forces at the stage state: the horizontal force fl − fr on the beam.
fn contact_force() -> f32 {
    if !HAS_CONTACT {
        return 0.0;
    }
    var x = 0.0;
    var xd = 0.0;
    for (var i = 0u; i < P.n_levers; i++) {
        let lam = P.levers[i];
        x += lam * sin(sth[i]);
        xd += lam * cos(sth[i]) * som[i];
    }
    let dr = x - P.gap;
    let dl = -x - P.gap;
    var fr = 0.0;
    var fl = 0.0;
    if dr > 0.0 {
        fr = max(P.kc * dr + P.cc * xd, 0.0);
    }
    if dl > 0.0 {
        fl = max(P.kc * dl - P.cc * xd, 0.0);
    }
    return fl - fr;
}

// Relative-joint torque on segment i from joint (i−1, i); the root spring for i = 0.
fn joint_torque(i: u32) -> f32 {
    if i == 0u {
        return -P.k0 * sth[0] - P.b0 * som[0];
    }
    return -P.k * (sth[i] - sth[i - 1u]) - P.b * (som[i] - som[i - 1u]);
}

// One RK4 stage: evaluate the derivative at the stage state (sth, som, svolt), add
// `w · dt · k` to the accumulators, and form the next stage state y + a_next · dt · k.
// The O(N) articulated-body recursion of src/model/chain.rs, with Q_i formed on the fly.
fn stage(cart_a: f32, w: f32, a_next: f32, dt: f32) {
    let l = P.seg_len;
    let m = P.seg_mass;
    let hml = 0.5 * m * l;
    let base_d = P.seg_inertia + m * l * l * 0.25;
    let fx = contact_force();
    var dvolt = 0.0;
    var couple = 0.0;
    if HAS_PIEZO {
        dvolt = (P.piezo_theta * (som[P.piezo_last] - som[0]) - svolt * P.piezo_inv_r) * P.piezo_inv_c;
        couple = P.piezo_theta * svolt;
    }
    var kxx = P.tip_mass;
    var kxy = 0.0;
    var kyy = P.tip_mass;
    var px = 0.0;
    var py = P.tip_mass * P.g;
    for (var ii = 0u; ii < N_SEG; ii++) {
        let i = N_SEG - 1u - ii;
        let s = sin(sth[i]);
        let c = cos(sth[i]);
        sn[i] = s;
        cs[i] = c;
        var q = joint_torque(i);
        if i + 1u < N_SEG {
            q -= joint_torque(i + 1u);
        }
        if HAS_CONTACT && i < P.n_levers {
            q += fx * P.levers[i] * c;
        }
        if HAS_PIEZO {
            if i == 0u {
                q += couple;
            }
            if i == P.piezo_last {
                q -= couple;
            }
        }
        let nx = c;
        let ny = -s;
        let w2 = som[i] * som[i];
        let knx = kxx * nx + kxy * ny;
        let kny = kxy * nx + kyy * ny;
        let kux = kxx * s + kxy * c;
        let kuy = kxy * s + kyy * c;
        let h_x = hml * nx + l * knx;
        let h_y = hml * ny + l * kny;
        var d = base_d + l * l * (nx * knx + ny * kny);
        if i == 0u {
            d += P.holder_inertia;
        }
        let ex = -(hml * s + l * kux) * w2 + px;
        let ey = -(hml * c + l * kuy) * w2 + py + m * P.g;
        let b2x = -(hml * s + 2.0 * l * kux) * w2 + 2.0 * px;
        let b2y = -(hml * c + 2.0 * l * kuy) * w2 + 2.0 * py + m * P.g;
        let bt = -0.5 * l * (nx * b2x + ny * b2y) + q;
        let inv_d = 1.0 / d;
        kxx = m + kxx - h_x * h_x * inv_d;
        kxy -= h_x * h_y * inv_d;
        kyy = m + kyy - h_y * h_y * inv_d;
        px = ex + h_x * bt * inv_d;
        py = ey + h_y * bt * inv_d;
        hx[i] = h_x;
        hy[i] = h_y;
        dinv[i] = inv_d;
        beta[i] = bt;
    }
    var ax = cart_a;
    var ay = 0.0;
    let wdt = w * dt;
    let adt = a_next * dt;
    for (var i = 0u; i < N_SEG; i++) {
        let accel = (beta[i] - hx[i] * ax - hy[i] * ay) * dinv[i];
        let s = sn[i];
        let c = cs[i];
        let rate = som[i];
        let w2 = rate * rate;
        ax += l * (c * accel - s * w2);
        ay += l * (-s * accel - c * w2);
        th_acc[i] += wdt * rate;
        om_acc[i] += wdt * accel;
        sth[i] = th[i] + adt * rate;
        som[i] = om[i] + adt * accel;
    }
    if HAS_PIEZO {
        volt_acc += wdt * dvolt;
        svolt = volt + adt * dvolt;
    }
}

// One classical RK4 step from step count `s` (phase within the period `ph`).
fn rk4_step(ph: u32, dt: f32) {
    for (var i = 0u; i < N_SEG; i++) {
        th_acc[i] = 0.0;
        om_acc[i] = 0.0;
        sth[i] = th[i];
        som[i] = om[i];
    }
    volt_acc = 0.0;
    svolt = volt;
    let a0 = cart_acc(ph, 0.0);
    let am = cart_acc(ph, 0.5);
    let a1 = cart_acc(ph, 1.0);
    stage(a0, 1.0 / 6.0, 0.5, dt);
    stage(am, 1.0 / 3.0, 0.5, dt);
    stage(am, 1.0 / 3.0, 1.0, dt);
    stage(a1, 1.0 / 6.0, 0.0, dt);
    for (var i = 0u; i < N_SEG; i++) {
        th[i] += th_acc[i];
        om[i] += om_acc[i];
    }
    if HAS_PIEZO {
        volt += volt_acc;
    }
}

fn not_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}

// Stored energy (inertial frame) at the step's state, as Chain::energy computes it.
fn energy(cart_v: f32) -> f32 {
    let l = P.seg_len;
    let m = P.seg_mass;
    var vx = cart_v;
    var vy = 0.0;
    var height = 0.0;
    var e = 0.0;
    for (var i = 0u; i < N_SEG; i++) {
        let s = sin(th[i]);
        let c = cos(th[i]);
        let w = om[i];
        let gvx = vx + 0.5 * l * c * w;
        let gvy = vy - 0.5 * l * s * w;
        e += 0.5 * m * (gvx * gvx + gvy * gvy) + 0.5 * P.seg_inertia * w * w;
        e += m * P.g * (height + 0.5 * l * c);
        vx += l * c * w;
        vy -= l * s * w;
        height += l * c;
        if i > 0u {
            let rel = th[i] - th[i - 1u];
            e += 0.5 * P.k * rel * rel;
        }
    }
    e += 0.5 * P.tip_mass * (vx * vx + vy * vy) + 0.5 * P.holder_inertia * om[0] * om[0];
    e += P.tip_mass * P.g * height;
    e += 0.5 * P.k0 * th[0] * th[0];
    if HAS_CONTACT {
        var x = 0.0;
        for (var i = 0u; i < P.n_levers; i++) {
            x += P.levers[i] * sin(th[i]);
        }
        let delta = abs(x) - P.gap;
        if delta > 0.0 {
            e += 0.5 * P.kc * delta * delta;
        }
    }
    if HAS_PIEZO {
        e += 0.5 * volt * volt / P.piezo_inv_c;
    }
    return e;
}

// Health check of rk4::health: non-finite state, holder escaped over a bumper, folded
// chain, or runaway energy.
fn health(ph: u32) -> u32 {
    for (var i = 0u; i < N_SEG; i++) {
        if not_finite(th[i]) || not_finite(om[i]) {
            return STATUS_NONFINITE;
        }
    }
    if HAS_PIEZO && not_finite(volt) {
        return STATUS_NONFINITE;
    }
    if abs(th[0]) > P.guard_holder {
        return STATUS_ESCAPED;
    }
    for (var i = 1u; i < N_SEG; i++) {
        if abs(th[i] - th[i - 1u]) > P.guard_bend {
            return STATUS_DIVERGED;
        }
    }
    let cart_v = P.vel_amp * cos(TAU * f32(ph) / f32(P.spp));
    let e = energy(cart_v);
    if not_finite(e) || abs(e) > P.guard_energy {
        return STATUS_DIVERGED;
    }
    return STATUS_OK;
}

// Bumper penetration flags at the step's state: bit 0 the +x bumper, bit 1 the −x one.
fn touch_flags() -> u32 {
    if !HAS_CONTACT {
        return 0u;
    }
    var x = 0.0;
    for (var i = 0u; i < P.n_levers; i++) {
        x += P.levers[i] * sin(th[i]);
    }
    var f = 0u;
    if x - P.gap > 0.0 {
        f |= 1u;
    }
    if -x - P.gap > 0.0 {
        f |= 2u;
    }
    return f;
}

// Advance every unfinished instance by up to `ctl.steps_per_dispatch` steps.
@compute @workgroup_size(WG)
fn integrate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = gid.x;
    let n_inst = ctl.n_inst;
    if inst >= n_inst {
        return;
    }
    var a = acc[inst];
    P = params[inst];
    let total = P.total_periods * P.spp;
    if a.status != STATUS_OK || a.step >= total {
        return;
    }
    for (var i = 0u; i < N_SEG; i++) {
        th[i] = state[i * n_inst + inst];
        om[i] = state[(N_SEG + i) * n_inst + inst];
    }
    volt = state[2u * N_SEG * n_inst + inst];
    let transient = P.transient_periods * P.spp;
    let end = min(total, a.step + min(ctl.steps_per_dispatch, total - a.step));
    let dt = P.dt;
    var s = a.step;
    loop {
        if s >= end {
            break;
        }
        let ph = s % P.spp;
        rk4_step(ph, dt);
        s += 1u;
        let alpha = th[0];
        let now = touch_flags();
        if s > transient {
            a.impacts += countOneBits(now & ~a.touch);
            a.alpha_min = min(a.alpha_min, alpha);
            a.alpha_max = max(a.alpha_max, alpha);
            var well = 0i;
            if alpha > P.half_clearance {
                well = 1i;
            } else if alpha < -P.half_clearance {
                well = -1i;
            }
            if well != 0i {
                if a.well != 0i && a.well != well {
                    a.hops += 1u;
                }
                a.well = well;
            }
            if HAS_PIEZO {
                // Kahan-compensated Σ v²/R_L.
                let y = volt * volt * P.piezo_inv_r - a.power_comp;
                let t = a.power_sum + y;
                a.power_comp = (t - a.power_sum) - y;
                a.power_sum = t;
            }
        }
        a.touch = now;
        if WANT_STROBE && s >= transient && s % P.spp == P.strobe_offset {
            let k = (s - P.strobe_offset) / P.spp - P.transient_periods;
            if k < P.strobe_count {
                strobe[inst * ctl.strobe_stride + k] = alpha;
            }
        }
        if WANT_RSERIES && s >= P.r_start && (s - P.r_start) % P.r_every == 0u {
            let j = (s - P.r_start) / P.r_every;
            if j < P.r_count {
                rwork[inst * ctl.rwork_stride + j] = vec2<f32>(alpha, 0.0);
            }
        }
        if s % CHECK_EVERY == 0u || s == total {
            let h = health(s % P.spp);
            if h != STATUS_OK {
                a.status = h;
                break;
            }
        }
    }
    a.step = s;
    for (var i = 0u; i < N_SEG; i++) {
        state[i * n_inst + inst] = th[i];
        state[(N_SEG + i) * n_inst + inst] = om[i];
    }
    state[2u * N_SEG * n_inst + inst] = volt;
    acc[inst] = a;
}

// ---- reductions -------------------------------------------------------------------------

fn cmul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

// In-place iterative radix-2 FFT of rwork[base .. base + n] (n a power of two); `sign` is
// −1 for the forward transform and +1 for the (unscaled) inverse.
fn fft(base: u32, n: u32, sign: f32) {
    var j = 0u;
    for (var i = 1u; i < n; i++) {
        var bit = n >> 1u;
        loop {
            if (j & bit) == 0u {
                break;
            }
            j ^= bit;
            bit >>= 1u;
        }
        j ^= bit;
        if i < j {
            let t = rwork[base + i];
            rwork[base + i] = rwork[base + j];
            rwork[base + j] = t;
        }
    }
    var len = 2u;
    loop {
        if len > n {
            break;
        }
        let half = len >> 1u;
        for (var start = 0u; start < n; start += len) {
            for (var k = 0u; k < half; k++) {
                let ang = sign * TAU * f32(k) / f32(len);
                let w = vec2<f32>(cos(ang), sin(ang));
                let u = rwork[base + start + k];
                let v = cmul(rwork[base + start + k + half], w);
                rwork[base + start + k] = u + v;
                rwork[base + start + k + half] = u - v;
            }
        }
        len <<= 1u;
    }
}

// Analytic signal of the real parts of rwork[base .. base + n] (mean removed), in place:
// FFT, weights h (1 at DC and Nyquist, 2 for positive, 0 for negative frequencies), inverse.
fn analytic(base: u32, n: u32) {
    var mean = 0.0;
    for (var j = 0u; j < n; j++) {
        mean += rwork[base + j].x;
    }
    mean /= f32(n);
    for (var j = 0u; j < n; j++) {
        rwork[base + j] = vec2<f32>(rwork[base + j].x - mean, 0.0);
    }
    fft(base, n, -1.0);
    let half = n / 2u;
    for (var k = 1u; k < n; k++) {
        if k < half {
            rwork[base + k] *= 2.0;
        } else if k > half {
            rwork[base + k] = vec2<f32>(0.0, 0.0);
        }
    }
    fft(base, n, 1.0);
}

// Phase synchronisation R of α against the cart position x0 over the R series, in three
// kernels so that no invocation runs long loops (lavapipe stops any invocation after 65535
// loop iterations): the analytic signal of α, that of the cart, then R.
@compute @workgroup_size(WG)
fn r_alpha(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = gid.x;
    if inst >= ctl.n_inst || acc[inst].status != STATUS_OK {
        return;
    }
    analytic(inst * ctl.rwork_stride, params[inst].r_count);
}

@compute @workgroup_size(WG)
fn r_cart(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = gid.x;
    if inst >= ctl.n_inst || acc[inst].status != STATUS_OK {
        return;
    }
    let p = params[inst];
    let n = p.r_count;
    let base_c = inst * ctl.rwork_stride + n;
    for (var j = 0u; j < n; j++) {
        let s = p.r_start + j * p.r_every;
        let ph = f32(s % p.spp) / f32(p.spp);
        rwork[base_c + j] = vec2<f32>(p.pos_amp * sin(TAU * ph), 0.0);
    }
    analytic(base_c, n);
}

@compute @workgroup_size(WG)
fn r_phase(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = gid.x;
    if inst >= ctl.n_inst {
        return;
    }
    if acc[inst].status != STATUS_OK {
        acc[inst].r = bitcast<f32>(0x7fc00000u);
        return;
    }
    let n = params[inst].r_count;
    let base_a = inst * ctl.rwork_stride;
    let base_c = base_a + n;
    var sum_c = 0.0;
    var sum_s = 0.0;
    for (var j = 0u; j < n; j++) {
        let za = rwork[base_a + j];
        let zc = rwork[base_c + j];
        var d = atan2(za.y, za.x) - atan2(zc.y, zc.x);
        if PAPER_CONVENTION {
            d = d - PI * floor((d + 0.5 * PI) / PI);
        }
        sum_c += cos(d);
        sum_s += sin(d);
    }
    acc[inst].r = sqrt(sum_c * sum_c + sum_s * sum_s) / f32(n);
}

// cos and sin of (j · c) from the fixed-point turn fraction: exact modular phase.
fn turn_cos_sin(j: u32, turns: u32) -> vec2<f32> {
    let frac = f32(j * turns) * 2.3283064365386963e-10; // 2^-32
    let ang = TAU * frac;
    return vec2<f32>(cos(ang), sin(ang));
}

// The 0–1 test for chaos, correlation method, as analysis::zero_one_test computes it:
// K_c for the c value `ctl.c_index` (one dispatch per c), into kc[inst * N_C + c_index].
@compute @workgroup_size(WG)
fn k_pass(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = gid.x;
    if inst >= ctl.n_inst || acc[inst].status != STATUS_OK {
        return;
    }
    let n = params[inst].strobe_count;
    let sb = inst * ctl.strobe_stride;
    let wb = inst * ctl.rwork_stride;
    let n_cut = (n + 5u) / 10u;
    var lo = strobe[sb];
    var hi = strobe[sb];
    var mean = 0.0;
    for (var j = 0u; j < n; j++) {
        let v = strobe[sb + j];
        lo = min(lo, v);
        hi = max(hi, v);
        mean += v;
    }
    mean /= f32(n);
    var k_c = 0.0;
    // A constant series is the most regular motion there is: K_c = 0.
    if !(hi - lo <= 1e-12 * max(abs(lo), abs(hi))) {
        let turns = cturns[ctl.c_index];
        var sp = 0.0;
        var sq = 0.0;
        for (var j = 0u; j < n; j++) {
            let v = strobe[sb + j];
            let e = turn_cos_sin(j + 1u, turns);
            sp += v * e.x;
            sq += v * e.y;
            rwork[wb + j] = vec2<f32>(sp, sq);
        }
        let mean_sq = mean * mean;
        let one_minus_cos_c = 1.0 - turn_cos_sin(1u, turns).x;
        // D_c(lag) = M_c(lag) − (Eφ)² (1 − cos(lag c))/(1 − cos c), kept after the (p, q) sums.
        var d_sum = 0.0;
        for (var lag = 1u; lag <= n_cut; lag++) {
            var sum = 0.0;
            for (var j = 0u; j + lag < n; j++) {
                let d = rwork[wb + j + lag] - rwork[wb + j];
                sum += dot(d, d);
            }
            let m = sum / f32(n - lag);
            let dv = m - mean_sq * (1.0 - turn_cos_sin(lag, turns).x) / one_minus_cos_c;
            rwork[wb + n + lag - 1u] = vec2<f32>(dv, 0.0);
            d_sum += dv;
        }
        let d_mean = d_sum / f32(n_cut);
        let xi_mean = (f32(n_cut) + 1.0) * 0.5;
        var sxy = 0.0;
        var sxx = 0.0;
        var syy = 0.0;
        for (var lag = 1u; lag <= n_cut; lag++) {
            let dy = rwork[wb + n + lag - 1u].x - d_mean;
            let dx = f32(lag) - xi_mean;
            sxy += dx * dy;
            sxx += dx * dx;
            syy += dy * dy;
        }
        if syy > 0.0 && sxx > 0.0 {
            k_c = sxy / sqrt(sxx * syy);
        }
    }
    kc[inst * N_C + ctl.c_index] = k_c;
}

// Sorting space of k_final: one row of N_C values per invocation, sized by overrides.
var<workgroup> kc_rows: array<f32, WG_K * N_C>;

// K = median of K_c, and the period of the stroboscopic section.
@compute @workgroup_size(WG_K)
fn k_final(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let inst = gid.x;
    if inst >= ctl.n_inst {
        return;
    }
    if acc[inst].status != STATUS_OK {
        acc[inst].k = bitcast<f32>(0x7fc00000u);
        acc[inst].period = 0u;
        return;
    }
    var kval = bitcast<f32>(0x7fc00000u);
    if WANT_K {
        let row = lid * N_C;
        for (var i = 0u; i < N_C; i++) {
            let v = kc[inst * N_C + i];
            var j = i;
            loop {
                if j == 0u || kc_rows[row + j - 1u] <= v {
                    break;
                }
                kc_rows[row + j] = kc_rows[row + j - 1u];
                j -= 1u;
            }
            kc_rows[row + j] = v;
        }
        if (N_C & 1u) == 1u {
            kval = kc_rows[row + N_C / 2u];
        } else {
            kval = 0.5 * (kc_rows[row + N_C / 2u - 1u] + kc_rows[row + N_C / 2u]);
        }
    }
    acc[inst].k = kval;
    acc[inst].period = detect_period(inst * ctl.strobe_stride, params[inst].strobe_count);
}
// analysis::detect_period on the stroboscopic samples: the smallest p ≤ period_max with the
// last `period_window` samples repeating within tol · max(1, max|x|); 0 when none.
fn detect_period(sb: u32, n: u32) -> u32 {
    let m = ctl.period_window;
    if m == 0u || m > n {
        return 0u;
    }
    var scale = 0.0;
    for (var k = n - m; k < n; k++) {
        scale = max(scale, abs(strobe[sb + k]));
    }
    let bound = ctl.period_tol * max(scale, 1.0);
    for (var p = 1u; p <= ctl.period_max; p++) {
        if m + p > n {
            break;
        }
        var fits = true;
        for (var k = n - m; k < n; k++) {
            if !(abs(strobe[sb + k] - strobe[sb + k - p]) <= bound) {
                fits = false;
                break;
            }
        }
        if fits {
            return p;
        }
    }
    return 0u;
}
