// The early stop of an instance whose periodic orbit is confirmed: the rings and the
// continuation of src/engine/early.rs (EarlyTracker; its rules are shared, written in
// src/engine/early_rule.rs) and the phases of the CPU hook (src/engine/cpu/hook.rs: watch,
// measured, period_end), step for step. The rings live in `early`, the phase in `acc`.

const EARLY_WATCHING: u32 = 0u;
const EARLY_MEASURING: u32 = 1u;
const EARLY_CLOSING: u32 = 2u;
const EARLY_OFF: u32 = 3u;

// Word `w` of the state ring slot of instant `abs`.
fn early_state_word(abs: u32, c: u32) -> u32 {
    return (abs % (ctl.e_p_max + 1u)) * (2u * N_SEG + 1u) + c;
}

fn early_alpha(inst: u32, abs: u32) -> f32 {
    return early[at(inst, ctl.e_alpha_off + abs % (ctl.e_window + ctl.e_p_max))];
}

// EarlyTracker::at_strobe: keep the state at instant `abs`; the period of the orbit when it
// is confirmed there (0: not).
fn early_keep(inst: u32, abs: u32, a: ptr<function, Accum>) -> u32 {
    for (var c = 0u; c < N_SEG; c++) {
        early[at(inst, early_state_word(abs, c))] = th[c];
        early[at(inst, early_state_word(abs, N_SEG + c))] = om[c];
    }
    early[at(inst, early_state_word(abs, 2u * N_SEG))] = volt;
    early[at(inst, ctl.e_alpha_off + abs % (ctl.e_window + ctl.e_p_max))] = th[0];
    (*a).e_seen += 1u;
    (*a).e_last = abs;
    let w = ctl.e_window;
    for (var p = 1u; p <= ctl.e_p_max; p++) {
        if (*a).e_seen < w + p {
            continue;
        }
        var same = true;
        for (var j = abs + 1u - w; j <= abs && same; j++) {
            same = early_close(early_alpha(inst, j), early_alpha(inst, j - p), ctl.e_tol);
        }
        for (var c = 0u; c < 2u * N_SEG + 1u && same; c++) {
            same = early_close(
                early[at(inst, early_state_word(abs, c))],
                early[at(inst, early_state_word(abs - p, c))],
                ctl.e_tol,
            );
        }
        if same {
            return p;
        }
    }
    return 0u;
}

// The hook's `watch` at instant `abs` (before the twin's sample, which a confirmed orbit may
// restart): a confirmed orbit closes, or, with λ1, has its twin measure it first.
fn early_watch(inst: u32, abs: u32, a: ptr<function, Accum>) {
    let p = early_keep(inst, abs, a);
    if (*a).e_phase != EARLY_WATCHING || p == 0u {
        return;
    }
    (*a).e_p = p;
    if !WANT_TWIN {
        (*a).e_phase = EARLY_CLOSING;
        return;
    }
    let window = early_twin_window(p);
    let until = abs + P.twin_align + window;
    if until >= (*a).tw_start {
        (*a).e_phase = EARLY_OFF;
        return;
    }
    twin_restart(a, abs, window);
    (*a).e_phase = EARLY_MEASURING;
    (*a).e_until = until;
}

// The twin starts over at instant `abs` with `window` renormalisations (TwinTracker::restart).
fn twin_restart(a: ptr<function, Accum>, abs: u32, window: u32) {
    (*a).tw_start = abs;
    (*a).tw_window = window;
    (*a).twin_flags = 0u;
    (*a).lyap_n = 0u;
    for (var b = 0u; b < LYAPUNOV_BLOCK_COUNT; b++) {
        (*a).lyap_sums[b] = 0.0;
    }
}

// The hook's `measured`: once the twin's window on the confirmed orbit is complete, close when
// λ1 shrinks within EARLY_LYAPUNOV_REL_SE of itself (early_lyapunov_stops_at); short of that
// precision double the window in place while it still ends before the map's (TwinTracker::
// extend); else send the twin back to the map's window (TwinTracker::reset).
fn early_measured(abs: u32, a: ptr<function, Accum>) {
    if (*a).e_phase != EARLY_MEASURING || abs < (*a).e_until {
        return;
    }
    let l = lyap_estimate(a, (*a).tw_window, P.period_s);
    if l.z > 0.5 && early_lyapunov_stops_at(l.x, l.y, P.period_s) {
        (*a).e_phase = EARLY_CLOSING;
        return;
    }
    let w = (*a).tw_window;
    let end = (*a).tw_start + P.twin_align + 2u * w;
    if l.z > 0.5 && end < P.twin_start + P.transient_periods {
        twin_extend(a, w);
        (*a).e_until = end;
        return;
    }
    twin_restart(a, P.twin_start + P.transient_periods, P.twin_window);
    (*a).e_phase = EARLY_OFF;
}

// Double the twin's window `w` in place, its block sums merged in pairs
// (LyapunovSums::merge_pairs); it goes on from its last renormalisation.
fn twin_extend(a: ptr<function, Accum>, w: u32) {
    let half = LYAPUNOV_BLOCK_COUNT / 2u;
    for (var b = 0u; b < half; b++) {
        (*a).lyap_sums[b] = (*a).lyap_sums[2u * b] + (*a).lyap_sums[2u * b + 1u];
    }
    for (var b = half; b < LYAPUNOV_BLOCK_COUNT; b++) {
        (*a).lyap_sums[b] = 0.0;
    }
    (*a).tw_window = 2u * w;
    (*a).twin_flags = TWIN_RUNNING;
}

// Keep the tally of period `q` in its ring slot.
fn early_keep_period(inst: u32, q: u32, a: ptr<function, Accum>) {
    let base = ctl.e_period_off + (q % ctl.e_p_max) * 5u;
    early[at(inst, base)] = bitcast<f32>((*a).p_hops);
    early[at(inst, base + 1u)] = bitcast<f32>((*a).p_impacts);
    early[at(inst, base + 2u)] = (*a).p_power;
    early[at(inst, base + 3u)] = (*a).p_amin;
    early[at(inst, base + 4u)] = (*a).p_amax;
}

// Add one period's tally (hops, impacts, Σ v²/R_L with compensation, α range) to the run's.
fn add_period(a: ptr<function, Accum>, hops: u32, impacts: u32, power: f32, amin: f32, amax: f32) {
    (*a).hops += hops;
    (*a).impacts += impacts;
    let y = power - (*a).power_comp;
    let t = (*a).power_sum + y;
    (*a).power_comp = (t * ctl.one - (*a).power_sum) - y;
    (*a).power_sum = t;
    (*a).alpha_min = min((*a).alpha_min, amin);
    (*a).alpha_max = max((*a).alpha_max, amax);
}

// EarlyTracker::continue_orbit: what the run after period boundary `stop` would have added.
fn early_continue(inst: u32, stop: u32, a: ptr<function, Accum>) {
    let p = (*a).e_p;
    for (var q = max(stop, P.transient_periods); q < P.total_periods; q++) {
        let src = cycle_copy(q, stop - 1u, p);
        let base = ctl.e_period_off + (src % ctl.e_p_max) * 5u;
        add_period(
            a,
            bitcast<u32>(early[at(inst, base)]),
            bitcast<u32>(early[at(inst, base + 1u)]),
            early[at(inst, base + 2u)],
            early[at(inst, base + 3u)],
            early[at(inst, base + 4u)],
        );
    }
    let stop_step = stop * P.spp;
    if WANT_STROBE {
        for (var j = 0u; j < P.strobe_count; j++) {
            let abs = P.transient_periods + j;
            if abs * P.spp + P.strobe_offset > stop_step {
                let src = cycle_copy(abs, (*a).e_last, p);
                strobe[at(inst, j)] = early_alpha(inst, src);
            }
        }
    }
    if WANT_RSERIES {
        let cycle = p * P.spp;
        for (var j = 0u; j < P.r_count; j++) {
            let s = P.r_start + j * P.r_every;
            if s > stop_step {
                let src = cycle_copy(s, stop_step, cycle);
                let v = early[at(inst, ctl.e_r_off + (src / P.r_every) % ctl.e_r_len)];
                rwork[at(inst, j)] = vec2<f32>(v, 0.0);
            }
        }
    }
}

// After the integration, every instance that stopped early gets what the rest of its run
// would have added (early_continue from the period boundary it stopped at). A pass of its
// own: in the integration kernel these loops slowed every step (lavapipe: 1.1x).
@compute @workgroup_size(WG)
fn early_finish(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = gid.x;
    if inst >= ctl.n_inst {
        return;
    }
    var a = acc[inst];
    if a.stopped == 0u {
        return;
    }
    P = params[inst];
    early_continue(inst, a.step / P.spp, &a);
    acc[inst] = a;
}
