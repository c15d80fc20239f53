// Reductions, part 3: λ1 and its standard error from the twin's block sums
// (LyapunovSums::estimate of src/reduce/lyapunov.rs), then the cell's regime from λ1, the
// period and K (regime_code of src/reduce/regime.rs, a shared rule). Runs after k_final, which leaves K and
// the period in the accumulators. The thresholds and codes come from the generated header.

// Growths in block b of a window of w: k with ⌊k·B/w⌋ = b, i.e. ⌈b·w/B⌉ ≤ k < ⌈(b+1)·w/B⌉.
fn block_count(b: u32, w: u32) -> u32 {
    let hi = ((b + 1u) * w + LYAPUNOV_BLOCK_COUNT - 1u) / LYAPUNOV_BLOCK_COUNT;
    let lo = (b * w + LYAPUNOV_BLOCK_COUNT - 1u) / LYAPUNOV_BLOCK_COUNT;
    return hi - lo;
}

// λ1 and its standard error (1/s) from the twin's block sums of a window of `w` growths with
// forcing period `t` (LyapunovSums::estimate): (λ1, SE, 1) once all `w` growths are in and
// the twin never broke, else (0, 0, 0).
fn lyap_estimate(a: ptr<function, Accum>, w: u32, t: f32) -> vec3<f32> {
    if ((*a).twin_flags & TWIN_BROKEN) != 0u || (*a).lyap_n != w || w < LYAPUNOV_BLOCK_COUNT {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    var total = 0.0;
    var mean = 0.0;
    for (var b = 0u; b < LYAPUNOV_BLOCK_COUNT; b++) {
        total += (*a).lyap_sums[b];
        mean += (*a).lyap_sums[b] / (f32(block_count(b, w)) * t);
    }
    mean /= f32(LYAPUNOV_BLOCK_COUNT);
    var ss = 0.0;
    for (var b = 0u; b < LYAPUNOV_BLOCK_COUNT; b++) {
        let dev = (*a).lyap_sums[b] / (f32(block_count(b, w)) * t) - mean;
        ss += dev * dev;
    }
    let se = sqrt(ss / f32(LYAPUNOV_BLOCK_COUNT * (LYAPUNOV_BLOCK_COUNT - 1u)));
    return vec3<f32>(total / (f32(w) * t), se, 1.0);
}

@compute @workgroup_size(WG)
fn verdict(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = ctl.slice_first + gid.x;
    if inst >= ctl.slice_end {
        return;
    }
    var a = acc[inst];
    if a.status != STATUS_OK {
        a.regime = REGIME_FAILED;
        acc[inst] = a;
        return;
    }
    let t = params[inst].period_s;
    let l = lyap_estimate(&a, a.tw_window, t);
    let valid = l.z > 0.5;
    if valid {
        a.lyap = l.x;
        a.lyap_se = l.y;
    }
    // Not formed, λ1 is unresolved: undecided (the CPU's λ1 is NaN there).
    a.regime = REGIME_UNDECIDED;
    if valid {
        a.regime = regime_code(l.x * t, l.y * t, a.period > 0u, a.k, params[inst].strobe_count);
    }
    acc[inst] = a;
}
