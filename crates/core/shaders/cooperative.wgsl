
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
// workgroupUniformLoad (`wg_share`). Adaptive steps, λ1's twin and the early stop run as in
// `integrate`: the ladder's position and level are the same on every lane (the error and the
// bumper flags broadcast), the twin lives in workgroup memory beside the state and is stepped
// by the same functions after a swap, and the events run on lane 0 on copies of the state.

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
// λ1's twin and its compensation (owners only; its voltage on lane 0, tw_volt).
var<workgroup> w_tw_th: array<f32, MAX_SEG>;
var<workgroup> w_tw_om: array<f32, MAX_SEG>;
var<workgroup> w_tw_th_c: array<f32, MAX_SEG>;
var<workgroup> w_tw_om_c: array<f32, MAX_SEG>;
// Adaptive steps: θ̈ of the next try's k₁, RK4's k₄ (k1_om, k4_th, k4_om), each segment's
// scaled error (the IMEX method's).
var<workgroup> w_k1_om: array<f32, MAX_SEG>;
var<workgroup> w_k4_th: array<f32, MAX_SEG>;
var<workgroup> w_k4_om: array<f32, MAX_SEG>;
var<workgroup> w_err: array<f32, MAX_SEG>;
// Words lane 0 broadcasts (`wg_share`, `wg_share_f32`).
var<workgroup> w_word: u32;
var<workgroup> w_real: f32;

// Lane 0's `v` on every lane, uniform.
fn wg_share(lane: u32, v: u32) -> u32 {
    if lane == 0u {
        w_word = v;
    }
    return workgroupUniformLoad(&w_word);
}

fn wg_share_f32(lane: u32, v: f32) -> f32 {
    if lane == 0u {
        w_real = v;
    }
    return workgroupUniformLoad(&w_real);
}

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

// The stage state set to the step's state on every owner, the voltage's on lane 0: a try's
// start where the last one left its stages behind.
fn wg_stage_reset(lane: u32) {
    for (var i = lane; i < N_SEG; i += WGC) {
        wg_stage_at_state(i);
    }
    if lane == 0u {
        svolt = volt;
    }
    workgroupBarrier();
}

// rk4_stages: the four stages of a step of length h from fraction `start` of the base step,
// spanning `width` of it; stage_add on the owners, the sweep on lane 0; the increment in
// (w_th_acc, w_om_acc, volt_acc), the state not advanced. The stage state is the step's
// state (wg_advance, wg_swap_twin leave it so), or, `handed`, k₁ is the last try's k₅
// (keep_k1), so only the rates are set.
fn wg_rk4_stages(lane: u32, ph: u32, start: f32, width: f32, h: f32, handed: bool) {
    for (var i = lane; i < N_SEG; i += WGC) {
        w_th_acc[i] = 0.0;
        w_om_acc[i] = 0.0;
        if handed {
            w_som[i] = w_om[i];
            w_acc[i] = w_k1_om[i];
        }
    }
    if lane == 0u {
        volt_acc = 0.0;
        svolt = volt;
        if handed {
            dvolt_out = k1_v;
            branch_bits = k1_branch;
            stage_n = 1u;
        }
    }
    let a0 = cart_acc(ph, start);
    let am = cart_acc(ph, start + 0.5 * width);
    let a1 = cart_acc(ph, start + width);
    if !handed {
        wg_rates(lane, a0);
    }
    wg_stage_add(lane, 1.0 / 6.0, 0.5, h);
    wg_rates(lane, am);
    wg_stage_add(lane, 1.0 / 3.0, 0.5, h);
    wg_rates(lane, am);
    wg_stage_add(lane, 1.0 / 3.0, 1.0, h);
    wg_rates(lane, a1);
    wg_rk4_last(lane, 1.0 / 6.0, h);
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

// The last stage's rates into the sums, k₄ kept for the error with adaptive steps. Its owner
// reads each sum next, and lane 0 reads k₄ after a barrier: none here.
fn wg_rk4_last(lane: u32, w: f32, h: f32) {
    let wdt = w * h;
    for (var i = lane; i < N_SEG; i += WGC) {
        if ADAPTIVE {
            w_k4_th[i] = w_som[i];
            w_k4_om[i] = w_acc[i];
        }
        w_th_acc[i] += wdt * w_som[i];
        w_om_acc[i] += wdt * w_acc[i];
    }
    if lane == 0u && HAS_PIEZO {
        k4_v = dvolt_out;
        volt_acc += wdt * dvolt_out;
    }
}

// rk4_finish: the state advanced by the sums, compensated; the next step's stage state set.
fn wg_rk4_finish(lane: u32) {
    for (var i = lane; i < N_SEG; i += WGC) {
        wg_advance(i, w_th_acc[i], w_om_acc[i]);
    }
    if lane == 0u && HAS_PIEZO {
        let v = comp_add(volt, volt_c, volt_acc);
        volt = v.x;
        volt_c = v.y;
    }
    workgroupBarrier();
}

// rk4_error: k₅ at y₄ (the compensated sum wg_rk4_finish would leave) with the cart at the
// step's end `a_end`, then max over the state of |h (k₄ − k₅) / 6| / (atol + rtol |y|) on
// lane 0, broadcast.
fn wg_rk4_error(lane: u32, a_end: f32, h: f32) -> f32 {
    for (var i = lane; i < N_SEG; i += WGC) {
        let t = comp_add(w_th[i], w_th_c[i], w_th_acc[i]).x;
        w_sth[i] = t;
        w_som[i] = comp_add(w_om[i], w_om_c[i], w_om_acc[i]).x;
        w_sn[i] = sin(t);
        w_cs[i] = cos(t);
    }
    if lane == 0u {
        svolt = comp_add(volt, volt_c, volt_acc).x;
    }
    workgroupBarrier();
    wg_rates(lane, a_end);
    var e = 0.0;
    if lane == 0u {
        let w = h / 6.0;
        for (var i = 0u; i < N_SEG; i++) {
            e = scaled_max(e, w * (w_k4_th[i] - w_som[i]), w_th[i]);
            e = scaled_max(e, w * (w_k4_om[i] - w_acc[i]), w_om[i]);
        }
        if HAS_PIEZO {
            e = scaled_max(e, w * (k4_v - dvolt_out), volt);
        }
    }
    return wg_share_f32(lane, e);
}

// keep_k1: the last derivative (at the main state's stage `j`) kept as the next try's k₁.
fn wg_keep_k1(lane: u32, j: u32) {
    for (var i = lane; i < N_SEG; i += WGC) {
        w_k1_om[i] = w_acc[i];
    }
    if lane == 0u {
        k1_v = dvolt_out;
        k1_branch = (branch_bits >> (4u * j)) & 15u;
    }
}

// prime_k1: k₁ at the step's state, at fraction `start` of the base step from phase `ph`.
fn wg_prime_k1(lane: u32, ph: u32, start: f32) {
    if lane == 0u {
        svolt = volt;
        stage_n = 0u;
        branch_bits = 0u;
    }
    wg_rates(lane, cart_acc(ph, start));
    wg_keep_k1(lane, 0u);
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

// imex_stages: the four stages of a step of length h from fraction `start` of the base step,
// spanning `width` of it, written out; the stage state is the step's state.
fn wg_imex_stages(lane: u32, ph: u32, start: f32, width: f32, h: f32) {
    if lane == 0u {
        svolt = volt;
    }
    wg_imex_eval(lane, 0u, cart_acc(ph, start + IMEX_C[0] * width));
    wg_imex_implicit(lane, 1u, h);
    wg_imex_eval(lane, 1u, cart_acc(ph, start + IMEX_C[1] * width));
    wg_imex_implicit(lane, 2u, h);
    wg_imex_eval(lane, 2u, cart_acc(ph, start + IMEX_C[2] * width));
    wg_imex_implicit(lane, 3u, h);
    wg_imex_eval(lane, 3u, cart_acc(ph, start + IMEX_C[3] * width));
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

// imex_error: the embedded error h Σ (b_j − b̂_j) f_j filtered through the implicit solve
// (S x_ω = M0 e_ω − hγ K e_θ, x_θ = e_θ + hγ x_ω) on the owners, each segment's scaled error
// in w_err; their max and the voltage's on lane 0, broadcast.
fn wg_imex_error(lane: u32, h: f32) -> f32 {
    for (var s = lane; s < N_SEG; s += WGC) {
        var dth = 0.0;
        var dom = 0.0;
        for (var j = 0u; j < 4u; j++) {
            let w = IMEX_B[j] - IMEX_B_HAT[j];
            dth += w * w_fth[j][s];
            dom += w * w_fom[j][s];
        }
        w_sth[s] = h * dth;
        w_r[s] = h * dom;
    }
    workgroupBarrier();
    let hg = h * IMEX_GAMMA;
    for (var s = lane; s < N_SEG; s += WGC) {
        w_q[s] = wg_row_r(2u, s) + hg * wg_couple(s, 0.0, true);
    }
    workgroupBarrier();
    for (var s = lane; s < N_SEG; s += WGC) {
        let x_om = wg_row_q(1u, s);
        w_err[s] = scaled_max(scaled_max(0.0, w_sth[s] + hg * x_om, w_th[s]), x_om, w_om[s]);
    }
    workgroupBarrier();
    var e = 0.0;
    if lane == 0u {
        for (var s = 0u; s < N_SEG; s++) {
            e = max(e, w_err[s]);
        }
        if HAS_PIEZO {
            var dv = 0.0;
            for (var j = 0u; j < 4u; j++) {
                dv += (IMEX_B[j] - IMEX_B_HAT[j]) * f_v[j];
            }
            e = scaled_max(e, h * dv, volt);
        }
    }
    return wg_share_f32(lane, e);
}

// The stages of either method for a step of length h from fraction `start` of the base step,
// spanning `width` of it (0 and 1 for a whole step), not handed k₁.
fn wg_stages(lane: u32, ph: u32, start: f32, width: f32, h: f32) {
    if METHOD_IMEX {
        wg_imex_stages(lane, ph, start, width, h);
    } else {
        wg_rk4_stages(lane, ph, start, width, h, false);
    }
}

// method_finish: the state advanced by the stages just computed.
fn wg_finish(lane: u32, h: f32) {
    if METHOD_IMEX {
        wg_imex_finish(lane, h);
    } else {
        wg_rk4_finish(lane);
    }
}

// One step of whichever state is in (w_th, w_om, volt) from phase `ph` (step_state): the main
// one, recording its stages' bumper branches, or the twin's, on them.
fn wg_step(lane: u32, ph: u32, dt: f32) {
    if lane == 0u {
        stage_n = 0u;
        if !twin_mode {
            branch_bits = 0u;
        }
    }
    wg_stages(lane, ph, 0.0, 1.0, dt);
    wg_finish(lane, dt);
}

// swap_twin on the owners (the voltage on lane 0), and the stage state set to the state now
// in place.
fn wg_swap_twin(lane: u32) {
    for (var i = lane; i < N_SEG; i += WGC) {
        let t = w_th[i];
        w_th[i] = w_tw_th[i];
        w_tw_th[i] = t;
        let o = w_om[i];
        w_om[i] = w_tw_om[i];
        w_tw_om[i] = o;
        let tc = w_th_c[i];
        w_th_c[i] = w_tw_th_c[i];
        w_tw_th_c[i] = tc;
        let oc = w_om_c[i];
        w_om_c[i] = w_tw_om_c[i];
        w_tw_om_c[i] = oc;
        wg_stage_at_state(i);
    }
    if lane == 0u {
        let v = volt;
        volt = tw_volt;
        tw_volt = v;
        let vc = volt_c;
        volt_c = tw_volt_c;
        tw_volt_c = vc;
    }
    workgroupBarrier();
}

// The twin's step (or sub-step: `start`, `width`, h) beside the main one just taken, on the
// main stages' branches (twin_step, and adaptive_substep's twin).
fn wg_twin_step(lane: u32, ph: u32, start: f32, width: f32, h: f32) {
    wg_swap_twin(lane);
    if lane == 0u {
        twin_mode = true;
        stage_n = 0u;
    }
    wg_stages(lane, ph, start, width, h);
    wg_finish(lane, h);
    if lane == 0u {
        twin_mode = false;
    }
    wg_swap_twin(lane);
}

// twin_saltation on lane 0, on copies of the main angles and the twin, where the main state
// began touching a bumper (`onsets`).
fn wg_saltation(lane: u32, onsets: u32) {
    if lane == 0u && onsets != 0u {
        for (var i = 0u; i < N_SEG; i++) {
            th[i] = w_th[i];
            tw_th[i] = w_tw_th[i];
            tw_om[i] = w_tw_om[i];
        }
        twin_saltation(onsets);
        for (var i = 0u; i < N_SEG; i++) {
            w_tw_om[i] = tw_om[i];
        }
    }
    workgroupBarrier();
}

// adaptive_substep: one sub-step tried within the base step from phase `ph`, on every lane
// with the same ladder (the error and the bumper flags broadcast). True once the base step is
// complete.
fn wg_substep(lane: u32, ph: u32, twin_on: bool, l: ptr<function, Ladder>) -> bool {
    let unit = 1u << MAX_LEVEL;
    let k = (*l).level;
    let span = unit >> k;
    let start = f32((*l).pos) / f32(unit);
    let width = f32(span) / f32(unit);
    let h = P.dt / f32(1u << k);
    imex_level = k;
    if lane == 0u {
        stage_n = 0u;
        branch_bits = 0u;
    }
    var e = 0.0;
    if METHOD_IMEX {
        wg_stage_reset(lane);
        wg_imex_stages(lane, ph, start, width, h);
        e = wg_imex_error(lane, h);
    } else {
        wg_rk4_stages(lane, ph, start, width, h, true);
        e = wg_rk4_error(lane, cart_acc(ph, start + width), h);
    }
    if ladder_rejects(e, k) {
        (*l).level = k + 1u;
        return false;
    }
    wg_finish(lane, h);
    if !METHOD_IMEX {
        wg_keep_k1(lane, 4u);
    }
    let now = wg_share(lane, wg_touch_flags());
    let new_on = now & ~(*l).touching;
    (*l).onsets += countOneBits(new_on);
    (*l).touching = now;
    if twin_on {
        wg_twin_step(lane, ph, start, width, h);
        if HAS_CONTACT {
            wg_saltation(lane, new_on);
        }
    }
    let pos = (*l).pos + span;
    (*l).level = ladder_next_level(k, pos, e);
    if pos < unit {
        (*l).pos = pos;
        return false;
    }
    (*l).pos = 0u;
    return true;
}

// touch_flags at the step's state, from the sines its owners took, on every lane (after a
// barrier; adaptive steps broadcast it, since the ladder every lane keeps holds it).
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

// period_events on lane 0, on copies of the state and the twin (which its sample may start
// or pull back): bit 0 of the word broadcast, a closing orbit stops the run here; bit 1, the
// twin runs.
fn wg_events(lane: u32, inst: u32, s: u32, ph: u32, a: ptr<function, Accum>) -> u32 {
    var word = 0u;
    if lane == 0u {
        for (var i = 0u; i < N_SEG; i++) {
            th[i] = w_th[i];
            om[i] = w_om[i];
            if WANT_TWIN {
                tw_th[i] = w_tw_th[i];
                tw_om[i] = w_tw_om[i];
            }
        }
        let stop = period_events(inst, s, ph, th[0], a);
        if WANT_TWIN {
            for (var i = 0u; i < N_SEG; i++) {
                w_tw_th[i] = tw_th[i];
                w_tw_om[i] = tw_om[i];
            }
        }
        word = select(0u, 1u, stop) | select(0u, 2u, ((*a).twin_flags & TWIN_RUNNING) != 0u);
    }
    return wg_share(lane, word);
}

// The instance's state (and the twin's) from the state buffer, on the owners and lane 0.
fn wg_load(lane: u32, inst: u32) {
    let n_inst = ctl.n_inst;
    let tw = 2u * N_SEG + 1u;
    for (var i = lane; i < N_SEG; i += WGC) {
        w_th[i] = state[i * n_inst + inst];
        w_om[i] = state[(N_SEG + i) * n_inst + inst];
        w_th_c[i] = 0.0;
        w_om_c[i] = 0.0;
        if WANT_TWIN {
            w_tw_th[i] = state[(tw + i) * n_inst + inst];
            w_tw_om[i] = state[(tw + N_SEG + i) * n_inst + inst];
            w_tw_th_c[i] = 0.0;
            w_tw_om_c[i] = 0.0;
        }
        wg_stage_at_state(i);
    }
    if lane == 0u {
        volt = state[2u * N_SEG * n_inst + inst];
        volt_c = 0.0;
        if WANT_TWIN {
            tw_volt = state[(tw + 2u * N_SEG) * n_inst + inst];
            tw_volt_c = 0.0;
        }
        twin_mode = false;
        branch_bits = 0u;
    }
    workgroupBarrier();
}

// The state back into the state buffer, and the twin's while it runs (`twin`).
fn wg_store(lane: u32, inst: u32, twin: bool) {
    let n_inst = ctl.n_inst;
    let tw = 2u * N_SEG + 1u;
    for (var i = lane; i < N_SEG; i += WGC) {
        state[i * n_inst + inst] = w_th[i];
        state[(N_SEG + i) * n_inst + inst] = w_om[i];
        if twin {
            state[(tw + i) * n_inst + inst] = w_tw_th[i];
            state[(tw + N_SEG + i) * n_inst + inst] = w_tw_om[i];
        }
    }
    if lane == 0u {
        state[2u * N_SEG * n_inst + inst] = volt;
        if twin {
            state[(tw + 2u * N_SEG) * n_inst + inst] = tw_volt;
        }
    }
}

// Advance every instance still integrating (those `live` lists), one workgroup each, by up to
// `ctl.steps_per_dispatch` steps (adaptive: `ctl.pass_budget` sub-steps tried): `integrate`'s
// loop, its bookkeeping and events on lane 0.
@compute @workgroup_size(WGC)
fn integrate_wg(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    if wid.x >= ctl.n_active {
        return;
    }
    let inst = wg_share(lane, live[ctl.live_from + wid.x]);
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
    if wg_share(lane, select(0u, 1u, finished(a, total))) == 1u {
        if lane == 0u {
            done[inst] = 1u;
        }
        return;
    }
    var s = wg_share(lane, a.step);
    wg_load(lane, inst);
    let end = min(total, s + min(ctl.steps_per_dispatch, total - s));
    let dt = P.dt;
    var ph = s % spp;
    var rph = s % r_every;
    let r_phase = params[inst].r_start % r_every;
    var twin_on = WANT_TWIN && wg_share(lane, a.twin_flags & TWIN_RUNNING) != 0u;
    // Adaptive steps: the ladder goes on where the last dispatch left it, the same on every
    // lane; a dispatch tries at most ctl.pass_budget sub-steps.
    var lad = Ladder(0u, 0u, 0u, a.sub_onsets);
    if ADAPTIVE {
        lad.pos = wg_share(lane, a.sub_pos);
        lad.level = wg_share(lane, a.level);
        lad.touching = wg_share(lane, wg_touch_flags());
        if !METHOD_IMEX {
            wg_prime_k1(lane, ph, f32(lad.pos) / f32(1u << MAX_LEVEL));
        }
    }
    var passes = 0u;
    loop {
        if s >= end {
            break;
        }
        var now = 0u;
        var onsets = 0u;
        if ADAPTIVE {
            if passes == ctl.pass_budget {
                break;
            }
            passes += 1u;
            a.sub_steps += 1u;
            if !wg_substep(lane, ph, twin_on, &lad) {
                continue;
            }
            now = lad.touching;
            onsets = lad.onsets;
            lad.onsets = 0u;
        } else {
            wg_step(lane, ph, dt);
            // (Lane 0's alone counts: accumulate and the saltation's check run there.)
            now = wg_touch_flags();
            onsets = countOneBits(now & ~a.touch);
            if twin_on {
                wg_twin_step(lane, ph, 0.0, 1.0, dt);
                if HAS_CONTACT {
                    wg_saltation(lane, now & ~a.touch);
                }
            }
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
            accumulate(alpha, now, onsets, &a);
            record_r(inst, s, rph == r_phase, alpha);
            if WANT_EARLY && WANT_RSERIES && rph == 0u {
                early[at(inst, ctl.e_r_off + (s / r_every) % ctl.e_r_len)] = alpha;
            }
        }
        if s % CHECK_EVERY == 0u || s == total {
            var status = STATUS_OK;
            if lane == 0u {
                status = wg_health(ph);
            }
            let h = wg_share(lane, status);
            if h != STATUS_OK {
                a.status = h;
                break;
            }
        }
        if ph == strobe_offset || ph == 0u {
            let word = wg_events(lane, inst, s, ph, &a);
            if (word & 1u) != 0u {
                break;
            }
            twin_on = WANT_TWIN && (word & 2u) != 0u;
        }
    }
    let twin_runs = WANT_TWIN && (a.twin_flags & TWIN_RUNNING) != 0u && a.status == STATUS_OK;
    wg_store(lane, inst, wg_share(lane, select(0u, 1u, twin_runs)) == 1u);
    if lane == 0u {
        a.step = s;
        a.level = lad.level;
        a.sub_pos = lad.pos;
        a.sub_onsets = lad.onsets;
        if finished(a, total) {
            done[inst] = 1u;
        }
        acc[inst] = a;
    }
}
