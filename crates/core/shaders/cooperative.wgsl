
// ---- the cooperative kernel: one workgroup per instance ---------------------------------
//
// `integrate_wg` advances the instances `integrate` would, with the same arithmetic, but one
// workgroup per instance (GpuKernel::Workgroup of src/engine/gpu/kernels.rs), for ensembles
// too small to fill the device. Lane l owns the segments l, l + WGC, l + 2 WGC, …: their
// stage sums, compensated updates, sines and cosines, the IMEX method's joint couples and
// matrix rows run on the owners side by side, in workgroup memory. The chain's O(N) sweep
// (`chain_rates`, the thread kernel's own function) and the run's bookkeeping (accumulate,
// record_r, period_events, health) run on lane 0, on copies in its private arrays, so the
// physics and the rules are written once.
//
// Uniform control flow by construction: every branch around a barrier reads the control
// block, the read-only parameters, a loop counter, or a word lane 0 broadcast with
// workgroupUniformLoad. The host refuses adaptive steps, λ1's twin and the early stop on this
// kernel (GpuKernel::refusal); the thread kernel does them.

// Lanes per workgroup (the host's GpuKernel::lanes: N rounded up to a power of two, ≤ 64).
override WGC: u32 = 32u;

// The instance's state and its summation compensation (owners only).
var<workgroup> w_th: array<f32, MAX_SEG>;
var<workgroup> w_om: array<f32, MAX_SEG>;
var<workgroup> w_th_c: array<f32, MAX_SEG>;
var<workgroup> w_om_c: array<f32, MAX_SEG>;
// RK4's Σ w_s k_s (owners only).
var<workgroup> w_th_acc: array<f32, MAX_SEG>;
var<workgroup> w_om_acc: array<f32, MAX_SEG>;
// The stage state, its sines and cosines (owners write, lane 0's sweep reads), and θ̈ of the
// last derivative (lane 0 writes, owners read).
var<workgroup> w_sth: array<f32, MAX_SEG>;
var<workgroup> w_som: array<f32, MAX_SEG>;
var<workgroup> w_sn: array<f32, MAX_SEG>;
var<workgroup> w_cs: array<f32, MAX_SEG>;
var<workgroup> w_acc: array<f32, MAX_SEG>;
// The IMEX method's stage derivatives, L's ω-part, the couples and R_ω (imex.wgsl's f_th,
// f_om, l_om, qv, rv).
var<workgroup> w_fth: array<array<f32, MAX_SEG>, 4>;
var<workgroup> w_fom: array<array<f32, MAX_SEG>, 4>;
var<workgroup> w_lom: array<array<f32, MAX_SEG>, 4>;
var<workgroup> w_q: array<f32, MAX_SEG>;
var<workgroup> w_r: array<f32, MAX_SEG>;
// Words lane 0 broadcasts: the instance, whether it has finished, its first step, the
// health check's status.
var<workgroup> w_inst: u32;
var<workgroup> w_finished: u32;
var<workgroup> w_step: u32;
var<workgroup> w_status: u32;

// The stage state set to the step's state (th, om) and its sines and cosines, on segment i's
// owner: where every step begins.
fn wg_stage_at_state(i: u32) {
    let t = w_th[i];
    w_sth[i] = t;
    w_som[i] = w_om[i];
    w_sn[i] = sin(t);
    w_cs[i] = cos(t);
}

// The derivative at the stage state (`derivative`): lane 0 copies the stage into its private
// arrays, runs the sweep (the sines and cosines the owners took) and hands θ̈ back; v̇ stays
// in its dvolt_out.
fn wg_rates(lane: u32, cart_a: f32) {
    if lane == 0u {
        for (var i = 0u; i < N_SEG; i++) {
            sth[i] = w_sth[i];
            som[i] = w_som[i];
            sn[i] = w_sn[i];
            cs[i] = w_cs[i];
        }
        chain_rates(cart_a);
        for (var i = 0u; i < N_SEG; i++) {
            w_acc[i] = acc_out[i];
        }
    }
    workgroupBarrier();
}

// One classical RK4 step (rk4_step): stage_add on the owners, the sweep on lane 0.
fn wg_rk4_step(lane: u32, ph: u32, dt: f32) {
    for (var i = lane; i < N_SEG; i += WGC) {
        w_th_acc[i] = 0.0;
        w_om_acc[i] = 0.0;
    }
    if lane == 0u {
        volt_acc = 0.0;
        svolt = volt;
    }
    let a0 = cart_acc(ph, 0.0);
    let am = cart_acc(ph, 0.5);
    let a1 = cart_acc(ph, 1.0);
    wg_rates(lane, a0);
    wg_stage_add(lane, 1.0 / 6.0, 0.5, dt);
    wg_rates(lane, am);
    wg_stage_add(lane, 1.0 / 3.0, 0.5, dt);
    wg_rates(lane, am);
    wg_stage_add(lane, 1.0 / 3.0, 1.0, dt);
    wg_rates(lane, a1);
    wg_rk4_last(lane, 1.0 / 6.0, dt);
}

// stage_add on the owners: the stage's rates into the sums, the next stage state and its
// sines and cosines; the voltage on lane 0.
fn wg_stage_add(lane: u32, w: f32, a_next: f32, dt: f32) {
    let wdt = w * dt;
    let adt = a_next * dt;
    for (var i = lane; i < N_SEG; i += WGC) {
        let rate = w_som[i];
        let accel = w_acc[i];
        w_th_acc[i] += wdt * rate;
        w_om_acc[i] += wdt * accel;
        let t = w_th[i] + adt * rate;
        w_sth[i] = t;
        w_som[i] = w_om[i] + adt * accel;
        w_sn[i] = sin(t);
        w_cs[i] = cos(t);
    }
    if lane == 0u && HAS_PIEZO {
        volt_acc += wdt * dvolt_out;
        svolt = volt + adt * dvolt_out;
    }
    workgroupBarrier();
}

// The last stage's rates into the sums and the state advanced (rk4_finish), compensated; the
// next step's stage state set.
fn wg_rk4_last(lane: u32, w: f32, dt: f32) {
    let wdt = w * dt;
    for (var i = lane; i < N_SEG; i += WGC) {
        let th_inc = w_th_acc[i] + wdt * w_som[i];
        let om_inc = w_om_acc[i] + wdt * w_acc[i];
        wg_advance(i, th_inc, om_inc);
    }
    if lane == 0u && HAS_PIEZO {
        volt_acc += wdt * dvolt_out;
        let v = comp_add(volt, volt_c, volt_acc);
        volt = v.x;
        volt_c = v.y;
    }
    workgroupBarrier();
}

// Segment i's state advanced by (th_inc, om_inc), compensated (comp_add), and the next step's
// stage state set.
fn wg_advance(i: u32, th_inc: f32, om_inc: f32) {
    let t = comp_add(w_th[i], w_th_c[i], th_inc);
    w_th[i] = t.x;
    w_th_c[i] = t.y;
    let o = comp_add(w_om[i], w_om_c[i], om_inc);
    w_om[i] = o.x;
    w_om_c[i] = o.y;
    wg_stage_at_state(i);
}

// imex_couples on the owner of segment s: −(K θ + C ω)_s at the stage angles, with the stage
// rates (`at_r` false) or R_ω (true), the dampers only when `damp` is 1: τ_s − τ_{s+1}.
fn wg_couple(s: u32, damp: f32, at_r: bool) -> f32 {
    var q = root_couple(w_sth[0], wg_rate(0u, at_r), damp);
    if s > 0u {
        q = 0.0 + wg_tau(s, damp, at_r);
    }
    if s + 1u < N_SEG {
        q -= wg_tau(s + 1u, damp, at_r);
    }
    return q;
}

// The torque of joint (i − 1, i), i ≥ 1, as imex_couples forms it.
fn wg_tau(i: u32, damp: f32, at_r: bool) -> f32 {
    let dom = wg_rate(i, at_r) - wg_rate(i - 1u, at_r);
    return joint_couple(w_sth[i] - w_sth[i - 1u], dom, damp);
}

// Segment i's stage rate, or R_ω where `at_r`.
fn wg_rate(i: u32, at_r: bool) -> f32 {
    if at_r {
        return w_r[i];
    }
    return w_som[i];
}

// Row i of the matrix `which` (mat_row_base) times w_q or w_r.
fn wg_row_q(which: u32, i: u32) -> f32 {
    let base = mat_row_base(which, i);
    var s = 0.0;
    for (var j = 0u; j < N_SEG; j++) {
        s += imex_mats[base + j] * w_q[j];
    }
    return s;
}

fn wg_row_r(which: u32, i: u32) -> f32 {
    let base = mat_row_base(which, i);
    var s = 0.0;
    for (var j = 0u; j < N_SEG; j++) {
        s += imex_mats[base + j] * w_r[j];
    }
    return s;
}

// One IMEX step (imex_step), its stages written out as imex_stages does.
fn wg_imex_step(lane: u32, ph: u32, h: f32) {
    if lane == 0u {
        svolt = volt;
    }
    wg_imex_eval(lane, 0u, cart_acc(ph, IMEX_C[0]));
    wg_imex_implicit(lane, 1u, h);
    wg_imex_eval(lane, 1u, cart_acc(ph, IMEX_C[1]));
    wg_imex_implicit(lane, 2u, h);
    wg_imex_eval(lane, 2u, cart_acc(ph, IMEX_C[2]));
    wg_imex_implicit(lane, 3u, h);
    wg_imex_eval(lane, 3u, cart_acc(ph, IMEX_C[3]));
    wg_imex_finish(lane, h);
}

// imex_eval: the derivative of stage j kept; the couples at the stage state for L's ω-part,
// which the next implicit stage's owners multiply out.
fn wg_imex_eval(lane: u32, j: u32, cart_a: f32) {
    wg_rates(lane, cart_a);
    for (var s = lane; s < N_SEG; s += WGC) {
        w_fth[j][s] = w_som[s];
        w_fom[j][s] = w_acc[s];
        if j < 3u {
            w_q[s] = wg_couple(s, 1.0, false);
        }
    }
    if lane == 0u {
        f_v[j] = dvolt_out;
    }
    workgroupBarrier();
}

// imex_implicit_stage i on the owners: L's ω-part of stage i − 1, R, then S U_ω = M0 R_ω −
// hγ K R_θ and U_θ = R_θ + hγ U_ω, in three phases (each reads every segment of the last).
fn wg_imex_implicit(lane: u32, i: u32, h: f32) {
    for (var s = lane; s < N_SEG; s += WGC) {
        w_lom[i - 1u][s] = wg_row_q(0u, s);
        var rt = w_th[s];
        var ro = w_om[s];
        for (var j = 0u; j < i; j++) {
            let ae = IMEX_AE[i * 4u + j];
            let ai = IMEX_AI[i * 4u + j];
            rt += h * ai * w_fth[j][s];
            ro += h * (ae * w_fom[j][s] + (ai - ae) * w_lom[j][s]);
        }
        w_sth[s] = rt;
        w_r[s] = ro;
    }
    if lane == 0u {
        svolt = volt;
        for (var j = 0u; j < i; j++) {
            svolt += h * IMEX_AE[i * 4u + j] * f_v[j];
        }
    }
    workgroupBarrier();
    let hg = h * IMEX_GAMMA;
    for (var s = lane; s < N_SEG; s += WGC) {
        w_q[s] = wg_row_r(2u, s) + hg * wg_couple(s, 0.0, true);
    }
    workgroupBarrier();
    for (var s = lane; s < N_SEG; s += WGC) {
        let u_om = wg_row_q(1u, s);
        w_som[s] = u_om;
        let t = w_sth[s] + hg * u_om;
        w_sth[s] = t;
        w_sn[s] = sin(t);
        w_cs[s] = cos(t);
    }
    workgroupBarrier();
}

// imex_finish on the owners: y += h Σ b_j f_j, compensated; the voltage on lane 0.
fn wg_imex_finish(lane: u32, h: f32) {
    for (var s = lane; s < N_SEG; s += WGC) {
        var dth = 0.0;
        var dom = 0.0;
        for (var j = 0u; j < 4u; j++) {
            dth += IMEX_B[j] * w_fth[j][s];
            dom += IMEX_B[j] * w_fom[j][s];
        }
        wg_advance(s, h * dth, h * dom);
    }
    if lane == 0u && HAS_PIEZO {
        var dv = 0.0;
        for (var j = 0u; j < 4u; j++) {
            dv += IMEX_B[j] * f_v[j];
        }
        let v = comp_add(volt, volt_c, h * dv);
        volt = v.x;
        volt_c = v.y;
    }
    workgroupBarrier();
}

// touch_flags at the step's state, from the sines its owners took (lane 0).
fn wg_touch_flags() -> u32 {
    if !HAS_CONTACT {
        return 0u;
    }
    var x = 0.0;
    for (var i = 0u; i < P.n_levers; i++) {
        x += lev[i] * w_sn[i];
    }
    return touch_of(x);
}

// `health` on lane 0, on a copy of the state.
fn wg_health(ph: u32) -> u32 {
    for (var i = 0u; i < N_SEG; i++) {
        th[i] = w_th[i];
        om[i] = w_om[i];
    }
    return health(ph);
}

// Advance every instance still integrating (those `live` lists), one workgroup each, by up
// to `ctl.steps_per_dispatch` steps at fixed steps: `integrate`'s loop, its events on lane 0.
@compute @workgroup_size(WGC)
fn integrate_wg(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    if wid.x >= ctl.n_active {
        return;
    }
    if lane == 0u {
        w_inst = live[ctl.live_from + wid.x];
    }
    let inst = workgroupUniformLoad(&w_inst);
    let n_inst = ctl.n_inst;
    P = params[inst];
    for (var i = 0u; i < N_SEG; i++) {
        lev[i] = levers[at(inst, i)];
    }
    // The run's length and phases, read from the read-only parameters (uniform).
    let spp = params[inst].spp;
    let strobe_offset = params[inst].strobe_offset;
    let r_every = params[inst].r_every;
    let total = params[inst].total_periods * spp;
    var a = acc[inst];
    if lane == 0u {
        w_finished = select(0u, 1u, finished(a, total));
        w_step = a.step;
    }
    if workgroupUniformLoad(&w_finished) == 1u {
        if lane == 0u {
            done[inst] = 1u;
        }
        return;
    }
    var s = workgroupUniformLoad(&w_step);
    for (var i = lane; i < N_SEG; i += WGC) {
        w_th[i] = state[i * n_inst + inst];
        w_om[i] = state[(N_SEG + i) * n_inst + inst];
        w_th_c[i] = 0.0;
        w_om_c[i] = 0.0;
        wg_stage_at_state(i);
    }
    if lane == 0u {
        volt = state[2u * N_SEG * n_inst + inst];
        volt_c = 0.0;
        twin_mode = false;
        branch_bits = 0u;
    }
    workgroupBarrier();
    let end = min(total, s + min(ctl.steps_per_dispatch, total - s));
    let dt = P.dt;
    var ph = s % spp;
    var rph = s % r_every;
    let r_phase = params[inst].r_start % r_every;
    loop {
        if s >= end {
            break;
        }
        if lane == 0u {
            stage_n = 0u;
        }
        if METHOD_IMEX {
            wg_imex_step(lane, ph, dt);
        } else {
            wg_rk4_step(lane, ph, dt);
        }
        s += 1u;
        ph += 1u;
        if ph == spp {
            ph = 0u;
        }
        rph += 1u;
        if rph == r_every {
            rph = 0u;
        }
        if lane == 0u {
            let alpha = w_th[0];
            let now = wg_touch_flags();
            accumulate(alpha, now, countOneBits(now & ~a.touch), &a);
            record_r(inst, s, rph == r_phase, alpha);
        }
        if s % CHECK_EVERY == 0u || s == total {
            if lane == 0u {
                w_status = wg_health(ph);
            }
            let h = workgroupUniformLoad(&w_status);
            if h != STATUS_OK {
                a.status = h;
                break;
            }
        }
        if ph == strobe_offset || ph == 0u {
            if lane == 0u {
                // (Never a stop: the early stop is refused on this kernel.)
                _ = period_events(inst, s, ph, w_th[0], &a);
            }
        }
    }
    for (var i = lane; i < N_SEG; i += WGC) {
        state[i * n_inst + inst] = w_th[i];
        state[(N_SEG + i) * n_inst + inst] = w_om[i];
    }
    if lane == 0u {
        a.step = s;
        state[2u * N_SEG * n_inst + inst] = volt;
        if finished(a, total) {
            done[inst] = 1u;
        }
        acc[inst] = a;
    }
}
