// Integration kernel: one invocation advances one instance in f32 by classical RK4 or by the
// IMEX method (shaders/imex.wgsl), with the O(N) articulated-body solve of src/model/chain.rs,
// the step loop of src/engine/stepper.rs and the bookkeeping of src/engine/cpu.rs
// (accumulators, stroboscopic and R samples).

// Cart acceleration at phase (step mod spp + frac) / spp + φ0: CartMotion::at_phase of
// src/model/excitation.rs (exact phase, never t += dt).
fn cart_acc(phase_steps: u32, frac: f32) -> f32 {
    let ph = (f32(phase_steps) + frac) / f32(P.spp) + P.phase0;
    return -P.acc_amp * sin_turn(ph);
}

// The torque of a joint bent by dth at the rate dom: −k Δθ − damp · b Δω, the damper weighted
// by `damp` (1; 0 for the IMEX method's spring part alone).
fn joint_couple(dth: f32, dom: f32, damp: f32) -> f32 {
    return -P.k * dth - damp * P.b * dom;
}

// The root spring's torque at θ0, θ̇0: −k0 θ0 − damp · b0 θ̇0.
fn root_couple(th0: f32, om0: f32, damp: f32) -> f32 {
    return -P.k0 * th0 - damp * P.b0 * om0;
}

// The derivative at the stage state (sth, som, svolt): θ̈ into acc_out, v̇ into dvolt_out, by
// the generated chain_rates (Chain::rates of src/model/chain.rs). On the main state each
// stage's bumper branches are recorded in branch_bits for λ1's twin; on the twin
// (`twin_mode`) the stage takes the branches its main stage recorded (chain_rates_on).
fn derivative(cart_a: f32) {
    if !HAS_CONTACT {
        chain_rates(cart_a);
        return;
    }
    let shift = 4u * stage_n;
    stage_n += 1u;
    if twin_mode {
        chain_rates_on(cart_a, (branch_bits >> shift) & 15u);
        return;
    }
    let b = chain_rates(cart_a);
    if WANT_TWIN {
        branch_bits |= b << shift;
    }
}

// The derivative just taken (θ̇ = som, θ̈ = acc_out, v̇ = dvolt_out) kept as stage j's.
fn keep_stage(j: u32) {
    for (var i = 0u; i < N_SEG; i++) {
        f_th[j][i] = som[i];
        f_om[j][i] = acc_out[i];
    }
    f_v[j] = dvolt_out;
}

// One classical RK4 step from phase `ph` within the forcing period.
fn rk4_step(ph: u32, dt: f32) {
    rk4_stages(ph, 0.0, 1.0, dt, false);
    rk4_finish(dt);
}

// The four RK4 stages of a step of length h that starts at fraction `start` of the base step
// from phase `ph` and spans `width` of it (0 and 1 for a whole step), kept in (f_th, f_om,
// f_v); the state not advanced. The stage states and the finish are generated from
// src/engine/rk4.rs (rk4_stage_state_j, rk4_finish). With `handed` (the main state's adaptive
// sub-steps) k₁ is not evaluated but taken from (k1_om, k1_v, k1_branch): first same as last
// (Rk4Pair of src/engine/rk4.rs), four evaluations a try. `handed` is a constant at every
// call, so no branch is left for a SIMD adapter to take both sides of (lavapipe, with a flag
// per invocation here, took as long as with five evaluations).
fn rk4_stages(ph: u32, start: f32, width: f32, h: f32, handed: bool) {
    let a0 = cart_acc(ph, start);
    let am = cart_acc(ph, start + 0.5 * width);
    let a1 = cart_acc(ph, start + width);
    if handed {
        for (var i = 0u; i < N_SEG; i++) {
            f_th[0][i] = om[i];
            f_om[0][i] = k1_om[i];
        }
        f_v[0] = k1_v;
        branch_bits = k1_branch;
        stage_n = 1u;
    } else {
        for (var i = 0u; i < N_SEG; i++) {
            sth[i] = th[i];
            som[i] = om[i];
        }
        svolt = volt;
        derivative(a0);
        keep_stage(0u);
    }
    rk4_stage_state_1(h);
    derivative(am);
    keep_stage(1u);
    rk4_stage_state_2(h);
    derivative(am);
    keep_stage(2u);
    rk4_stage_state_3(h);
    derivative(a1);
    keep_stage(3u);
}

// k₁ of the main state at fraction `start` of the base step from phase `ph`, kept for its
// first sub-step (a dispatch's start; afterwards each accepted sub-step hands on its k₅).
fn prime_k1(ph: u32, start: f32) {
    for (var i = 0u; i < N_SEG; i++) {
        sth[i] = th[i];
        som[i] = om[i];
    }
    svolt = volt;
    stage_n = 0u;
    branch_bits = 0u;
    derivative(cart_acc(ph, start));
    keep_k1(0u);
}

// The last derivative (at the main state's stage `j`) kept as the next tries' k₁.
fn keep_k1(j: u32) {
    for (var i = 0u; i < N_SEG; i++) {
        k1_om[i] = acc_out[i];
    }
    k1_v = dvolt_out;
    k1_branch = (branch_bits >> (4u * j)) & 15u;
}

// The scaled error of the RK4 stages just computed (Rk4Rungs::error of src/engine/rk4.rs):
// k₅ at the candidate y₄ (rk4_candidate: the compensated sum rk4_finish leaves, so an
// accepted sub-step hands k₅ on as the next k₁) with the cart at the step's end `a_end`, the
// estimate h (k₄ − k₅)/6 (rk4_estimate), then its max over the state of
// |e| / (atol + rtol |y|), y the state before the step.
fn rk4_error(a_end: f32, h: f32) -> f32 {
    rk4_candidate(h);
    derivative(a_end);
    rk4_estimate(h);
    var e = 0.0;
    for (var i = 0u; i < N_SEG; i++) {
        e = scaled_max(e, sth[i], th[i], P.rtol, P.atol);
        e = scaled_max(e, som[i], om[i], P.rtol, P.atol);
    }
    if HAS_PIEZO {
        e = scaled_max(e, svolt, volt, P.rtol, P.atol);
    }
    return e;
}


// Guard::check of src/model/health.rs: what it measures (every value finite, |θ0|, the
// largest bend, the stored energy) judged by the shared guard_status. The chain's angles reach
// sin and cos unreduced: a healthy state keeps |θ_0| ≤ π/2 and every bend within the guard,
// so they stay near [-π, π]; a state that leaves it is stopped here.
fn health(ph: u32) -> u32 {
    var finite = !HAS_PIEZO || is_finite(volt);
    var bend = 0.0;
    for (var i = 0u; i < N_SEG; i++) {
        finite = finite && is_finite(th[i]) && is_finite(om[i]);
        if i > 0u {
            bend = max(bend, abs(th[i] - th[i - 1u]));
        }
    }
    let e = energy(P.vel_amp * cos_turn(f32(ph) / f32(P.spp) + P.phase0));
    return guard_status(finite, abs(th[0]), bend, e, P.guard_holder, P.guard_bend, P.guard_energy);
}

// One step of whichever state is in (th, om, volt): the main one (recording its stages'
// bumper branches), or the twin's when swapped in (on those branches).
fn step_state(ph: u32, dt: f32) {
    stage_n = 0u;
    if !twin_mode {
        branch_bits = k1_branch;
    }
    if METHOD_IMEX {
        imex_step(ph, dt);
    } else {
        rk4_step(ph, dt);
    }
}

// The state advanced by the stages of either method just computed.
fn method_finish(h: f32) {
    if METHOD_IMEX {
        imex_finish(h);
    } else {
        rk4_finish(h);
    }
}

// Where an invocation is within its base step of adaptive steps: the position in units of
// the finest step, the ladder level k of the next sub-step (h = P.dt / 2^k), the bumper flags
// after the last sub-step, and the contact onsets within the base step so far.
struct Ladder {
    pos: u32,
    level: u32,
    touching: u32,
    onsets: u32,
}

// One sub-step tried within the base step from phase `ph` (Adaptive::base_step of
// src/engine/adaptive.rs, one pass of its loop; IMEX or RK4 by METHOD_IMEX): a step whose scaled error exceeds 1 is taken
// again at the next level; an accepted one advances the state, and the twin beside it on the
// main stages' branches with its onset saltation; the level falls by one where the position
// is aligned to the coarser step and the error is at most LADDER_GROW. True once the base
// step is complete (its onsets in `l.onsets`, the position back at 0).
//
// One sub-step per call, not one base step, so that the invocations of a warp stay busy: an
// invocation in free flight completes its base step in one pass while one in contact takes
// many, and the base step's bookkeeping is the only work they do apart.
fn adaptive_substep(ph: u32, twin_on: bool, l: ptr<function, Ladder>) -> bool {
    let unit = 1u << MAX_LEVEL;
    let k = (*l).level;
    let span = unit >> k;
    let start = f32((*l).pos) / f32(unit);
    let width = f32(span) / f32(unit);
    let h = P.dt / f32(1u << k);
    imex_level = k;
    stage_n = 0u;
    branch_bits = 0u;
    var e = 0.0;
    if METHOD_IMEX {
        imex_stages(ph, start, width, h);
        e = imex_error(h);
    } else {
        rk4_stages(ph, start, width, h, true);
        e = rk4_error(cart_acc(ph, start + width), h);
    }
    if ladder_rejects(e, k) {
        (*l).level = k + 1u;
        return false;
    }
    method_finish(h);
    if !METHOD_IMEX {
        keep_k1(4u);
    }
    let now = touch_flags();
    let new_on = now & ~(*l).touching;
    (*l).onsets += countOneBits(new_on);
    (*l).touching = now;
    if twin_on {
        swap_twin();
        twin_mode = true;
        stage_n = 0u;
        if METHOD_IMEX {
            imex_stages(ph, start, width, h);
        } else {
            rk4_stages(ph, start, width, h, false);
        }
        method_finish(h);
        twin_mode = false;
        swap_twin();
        if HAS_CONTACT && new_on != 0u {
            twin_saltation(new_on);
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

// Exchange the main state (and its compensation) with the twin's.
fn swap_twin() {
    for (var i = 0u; i < N_SEG; i++) {
        let t = th[i];
        th[i] = tw_th[i];
        tw_th[i] = t;
        let o = om[i];
        om[i] = tw_om[i];
        tw_om[i] = o;
        let tc = th_c[i];
        th_c[i] = tw_th_c[i];
        tw_th_c[i] = tc;
        let oc = om_c[i];
        om_c[i] = tw_om_c[i];
        tw_om_c[i] = oc;
    }
    let v = volt;
    volt = tw_volt;
    tw_volt = v;
    let vc = volt_c;
    volt_c = tw_volt_c;
    tw_volt_c = vc;
}

// The twin's step beside the main one just taken from phase `ph` (step_twin of
// src/engine/stepper.rs).
fn twin_step(ph: u32, dt: f32) {
    swap_twin();
    twin_mode = true;
    step_state(ph, dt);
    twin_mode = false;
    swap_twin();
}

// TwinTracker::at_sample of src/engine/twin.rs at stroboscopic instant `j` (absolute, the
// transient included): start the twin at y + d0·u (d0·u of TwinNorm::direction, formed on the
// host as the CPU forms it: P.twin_start_*), or add g = ln(d/d0) to its block and pull it back
// to distance d0. Its first instant and window are the accumulators' (the early stop
// may restart it on a confirmed orbit).
fn twin_sample(j: u32, a: ptr<function, Accum>) {
    let start = (*a).tw_start;
    let window = (*a).tw_window;
    if j == start {
        for (var i = 0u; i < N_SEG; i++) {
            tw_th[i] = th[i] + P.twin_start_th;
            tw_om[i] = om[i] + P.twin_start_om;
            tw_th_c[i] = 0.0;
            tw_om_c[i] = 0.0;
        }
        tw_volt = volt + P.twin_start_v;
        tw_volt_c = 0.0;
        (*a).twin_flags = TWIN_RUNNING;
        return;
    }
    if ((*a).twin_flags & TWIN_RUNNING) == 0u || j <= start {
        return;
    }
    let d = sqrt(twin_norm2());
    if !is_finite(d) || d <= 0.0 {
        (*a).twin_flags = TWIN_BROKEN;
        return;
    }
    let r = j - start;
    if r > P.twin_align {
        (*a).lyap_sums[lyapunov_block(r - P.twin_align - 1u, window)] += log(d / P.twin_d0);
        (*a).lyap_n += 1u;
    }
    let scale = P.twin_d0 / d;
    for (var i = 0u; i < N_SEG; i++) {
        tw_th[i] = th[i] + scale * (tw_th[i] - th[i]);
        tw_om[i] = om[i] + scale * (tw_om[i] - om[i]);
    }
    tw_volt = volt + scale * (tw_volt - volt);
    if j >= start + P.twin_align + window {
        (*a).twin_flags = 0u;
    }
}

// The accumulators of the current period after a step to angle `alpha` with bumper flags
// `now` and `onsets` contacts begun within it: onsets, α range, hops (the shared rules of
// src/analysis/periodicity.rs, the wells as +1/−1 and 0 for none yet; the well last visited
// is kept through the transient), power.
fn accumulate(alpha: f32, now: u32, onsets: u32, a: ptr<function, Accum>) {
    (*a).p_impacts += onsets;
    (*a).p_amin = min((*a).p_amin, alpha);
    (*a).p_amax = max((*a).p_amax, alpha);
    let side = well_side(alpha, P.half_clearance);
    if is_hop((*a).well, side) {
        (*a).p_hops += 1u;
    }
    (*a).well = next_well((*a).well, side);
    if HAS_PIEZO {
        (*a).p_power += volt * volt * P.piezo_inv_r;
    }
    (*a).touch = now;
}

// The end of forcing period `q`: its tally into the run's after the transient, into the early
// stop's ring; true when a closing orbit stops here (its rest continued by early_finish).
fn period_end(inst: u32, q: u32, a: ptr<function, Accum>) -> bool {
    if q >= P.transient_periods {
        add_period(a, (*a).p_hops, (*a).p_impacts, (*a).p_power, (*a).p_amin, (*a).p_amax);
    }
    var stop = false;
    if WANT_EARLY {
        early_keep_period(inst, q, a);
        if (*a).e_phase == EARLY_CLOSING {
            // The rest of the run is continued by the early_finish pass.
            (*a).stopped = (*a).e_p;
            stop = true;
        }
    }
    (*a).p_hops = 0u;
    (*a).p_impacts = 0u;
    (*a).p_power = 0.0;
    (*a).p_amin = 3.4028235e38;
    (*a).p_amax = -3.4028235e38;
    return stop;
}

// A stroboscopic instant after step `s`: the recorded α after the transient, the early stop's
// watch, λ1's twin.
fn strobe_instant(inst: u32, s: u32, alpha: f32, a: ptr<function, Accum>) {
    let abs = (s - P.strobe_offset) / P.spp;
    if WANT_STROBE && abs >= P.transient_periods {
        let k = abs - P.transient_periods;
        if k < P.strobe_count {
            strobe[at(inst, k)] = alpha;
        }
    }
    if WANT_EARLY {
        early_watch(inst, abs, a);
    }
    if WANT_TWIN {
        twin_sample(abs, a);
    }
    if WANT_EARLY {
        early_measured(abs, a);
    }
}

// α after step `s` into the R series, where the step is on the series' phase (`on_phase`: s
// ≡ r_start mod r_every) and within it.
fn record_r(inst: u32, s: u32, on_phase: bool, alpha: f32) {
    if WANT_RSERIES && on_phase && s >= P.r_start {
        let j = (s - P.r_start) / P.r_every;
        if j < P.r_count {
            rwork[at(inst, j)] = vec2<f32>(alpha, 0.0);
        }
    }
}

// Whether an instance has nothing left to integrate.
fn finished(a: Accum, total: u32) -> bool {
    return a.status != STATUS_OK || a.step >= total || a.stopped != 0u;
}

// The events after step `s` at phase `ph` of its period, α now `alpha`: the stroboscopic
// instant, and the period's end; true when a closing orbit stops the run there (`period_end`).
fn period_events(inst: u32, s: u32, ph: u32, alpha: f32, a: ptr<function, Accum>) -> bool {
    if (WANT_EARLY || s >= P.transient_periods * P.spp) && ph == P.strobe_offset {
        strobe_instant(inst, s, alpha, a);
    }
    return ph == 0u && period_end(inst, s / P.spp - 1u, a);
}

// Advance every instance still integrating (those `live` lists) by up to
// `ctl.steps_per_dispatch` steps.
@compute @workgroup_size(WG)
fn integrate(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= ctl.n_active {
        return;
    }
    let inst = live[ctl.live_from + gid.x];
    let n_inst = ctl.n_inst;
    var a = acc[inst];
    P = params[inst];
    for (var i = 0u; i < N_SEG; i++) {
        lev[i] = levers[at(inst, i)];
    }
    let total = P.total_periods * P.spp;
    if finished(a, total) {
        done[inst] = 1u;
        return;
    }
    // The state, then the twin's, then the compensation of each word at word `cw` on: the
    // compensated sums go on across dispatches as within one, so a dispatch's size never
    // changes a result.
    let tw = 2u * N_SEG + 1u;
    let cw = select(1u, 2u, WANT_TWIN) * tw;
    for (var i = 0u; i < N_SEG; i++) {
        th[i] = state[i * n_inst + inst];
        om[i] = state[(N_SEG + i) * n_inst + inst];
        th_c[i] = state[(cw + i) * n_inst + inst];
        om_c[i] = state[(cw + N_SEG + i) * n_inst + inst];
    }
    volt = state[2u * N_SEG * n_inst + inst];
    volt_c = state[(cw + 2u * N_SEG) * n_inst + inst];
    if WANT_TWIN {
        for (var i = 0u; i < N_SEG; i++) {
            tw_th[i] = state[(tw + i) * n_inst + inst];
            tw_om[i] = state[(tw + N_SEG + i) * n_inst + inst];
            tw_th_c[i] = state[(cw + tw + i) * n_inst + inst];
            tw_om_c[i] = state[(cw + tw + N_SEG + i) * n_inst + inst];
        }
        tw_volt = state[(tw + 2u * N_SEG) * n_inst + inst];
        tw_volt_c = state[(cw + tw + 2u * N_SEG) * n_inst + inst];
    }
    let end = min(total, a.step + min(ctl.steps_per_dispatch, total - a.step));
    let dt = P.dt;
    var s = a.step;
    // s mod spp and s mod r_every, counted instead of divided at every step (an integer
    // division costs more than a step's arithmetic on lavapipe).
    var ph = s % P.spp;
    var rph = s % P.r_every;
    let r_phase = P.r_start % P.r_every;
    twin_mode = false;
    // Adaptive steps: the ladder goes on where the last dispatch left it (within a base step
    // when it ran out of passes), and a dispatch tries at most ctl.pass_budget sub-steps.
    var lad = Ladder(a.sub_pos, a.level, 0u, a.sub_onsets);
    if ADAPTIVE {
        lad.touching = touch_flags();
        if !METHOD_IMEX {
            prime_k1(ph, f32(lad.pos) / f32(1u << MAX_LEVEL));
        }
    }
    var passes = 0u;
    var out_of_passes = false;
    // Steps without an event run in the inner loop (with adaptive steps, one sub-step per
    // pass); the events of a forcing period (its stroboscopic instant and its end: the early
    // stop's watch, λ1's twin, the period's tally) are taken between its runs, out of the hot
    // loop, at fixed steps. With adaptive steps they are taken in it: the invocations of a
    // warp reach their events at different passes, and an invocation that left the inner loop
    // for its event would wait there until every other had reached one too.
    var failed = false;
    var halted = false;
    loop {
        if s >= end {
            break;
        }
        loop {
            let twin_on = WANT_TWIN && (a.twin_flags & TWIN_RUNNING) != 0u;
            var onsets = 0u;
            if ADAPTIVE {
                if passes == ctl.pass_budget {
                    out_of_passes = true;
                    break;
                }
                passes += 1u;
                a.sub_steps += 1u;
                if !adaptive_substep(ph, twin_on, &lad) {
                    continue;
                }
                onsets = lad.onsets;
                lad.onsets = 0u;
            } else {
                step_state(ph, dt);
                if twin_on {
                    twin_step(ph, dt);
                }
            }
            s += 1u;
            ph += 1u;
            if ph == P.spp {
                ph = 0u;
            }
            rph += 1u;
            if rph == P.r_every {
                rph = 0u;
            }
            let alpha = th[0];
            // (Adaptive: the ladder has the flags of the state its last sub-step left.)
            var now = lad.touching;
            if !ADAPTIVE {
                now = touch_flags();
            }
            if !ADAPTIVE {
                onsets = countOneBits(now & ~a.touch);
                if twin_on && HAS_CONTACT && (now & ~a.touch) != 0u {
                    twin_saltation(now & ~a.touch);
                }
            }
            accumulate(alpha, now, onsets, &a);
            record_r(inst, s, rph == r_phase, alpha);
            if WANT_EARLY && WANT_RSERIES && rph == 0u {
                early[at(inst, ctl.e_r_off + (s / P.r_every) % ctl.e_r_len)] = alpha;
            }
            if s % CHECK_EVERY == 0u || s == total {
                let h = health(ph);
                if h != STATUS_OK {
                    a.status = h;
                    failed = true;
                    break;
                }
            }
            let event = ph == P.strobe_offset || ph == 0u;
            if ADAPTIVE && event && period_events(inst, s, ph, th[0], &a) {
                halted = true;
                break;
            }
            if s >= end || (!ADAPTIVE && event) {
                break;
            }
        }
        if failed || out_of_passes || halted {
            break;
        }
        if !ADAPTIVE && period_events(inst, s, ph, th[0], &a) {
            break;
        }
    }
    a.step = s;
    a.level = lad.level;
    a.sub_pos = lad.pos;
    a.sub_onsets = lad.onsets;
    for (var i = 0u; i < N_SEG; i++) {
        state[i * n_inst + inst] = th[i];
        state[(N_SEG + i) * n_inst + inst] = om[i];
        state[(cw + i) * n_inst + inst] = th_c[i];
        state[(cw + N_SEG + i) * n_inst + inst] = om_c[i];
    }
    state[2u * N_SEG * n_inst + inst] = volt;
    state[(cw + 2u * N_SEG) * n_inst + inst] = volt_c;
    if WANT_TWIN && (a.twin_flags & TWIN_RUNNING) != 0u && a.status == STATUS_OK {
        for (var i = 0u; i < N_SEG; i++) {
            state[(tw + i) * n_inst + inst] = tw_th[i];
            state[(tw + N_SEG + i) * n_inst + inst] = tw_om[i];
            state[(cw + tw + i) * n_inst + inst] = tw_th_c[i];
            state[(cw + tw + N_SEG + i) * n_inst + inst] = tw_om_c[i];
        }
        state[(tw + 2u * N_SEG) * n_inst + inst] = tw_volt;
        state[(cw + tw + 2u * N_SEG) * n_inst + inst] = tw_volt_c;
    }
    if finished(a, total) {
        done[inst] = 1u;
    }
    acc[inst] = a;
}
