// Reductions, part 2: the 0–1 test for chaos K (src/analysis/zero_one.rs, correlation method)
// on the stroboscopic samples, one dispatch per c value, then the median over c and the period
// of the section (src/analysis/periodicity.rs).

// cos and sin of (j · c) from the fixed-point turn fraction: exact modular phase.
fn turn_cos_sin(j: u32, turns: u32) -> vec2<f32> {
    let frac = f32(j * turns) * 2.3283064365386963e-10; // 2^-32
    let ang = TAU * (frac - round(frac)); // within [-π, π]
    return vec2<f32>(cos(ang), sin(ang));
}

// The 0–1 test for chaos, correlation method, as analysis::zero_one_test computes it:
// K_c for the c value `ctl.c_index` (one dispatch per c), into kc[inst * N_C + c_index].
@compute @workgroup_size(WG)
fn k_pass(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = ctl.slice_first + gid.x;
    if inst >= ctl.slice_end || acc[inst].status != STATUS_OK {
        return;
    }
    let n = params[inst].strobe_count;
    let n_cut = (n + 5u) / 10u;
    var lo = strobe[at(inst, 0u)];
    var hi = strobe[at(inst, 0u)];
    var mean = 0.0;
    for (var j = 0u; j < n; j++) {
        let v = strobe[at(inst, j)];
        lo = min(lo, v);
        hi = max(hi, v);
        mean += v;
    }
    mean /= f32(n);
    var k_c = 0.0;
    // A constant series is the most regular motion there is: K_c = 0.
    let spread = hi - lo;
    if !is_finite(spread) || spread > 1e-12 * max(abs(lo), abs(hi)) {
        let turns = cturns[ctl.c_index];
        var sp = 0.0;
        var sq = 0.0;
        for (var j = 0u; j < n; j++) {
            let v = strobe[at(inst, j)];
            let e = turn_cos_sin(j + 1u, turns);
            sp += v * e.x;
            sq += v * e.y;
            rwork[at(inst, j)] = vec2<f32>(sp, sq);
        }
        let mean_sq = mean * mean;
        let one_minus_cos_c = 1.0 - turn_cos_sin(1u, turns).x;
        // D_c(lag) = M_c(lag) − (Eφ)² (1 − cos(lag c))/(1 − cos c), kept after the (p, q) sums.
        // Four lags per pass over j: each (p, q)(j) is read once for all four, and each lag's
        // sum still runs over j in order (the same sums, bit for bit, as one lag at a time).
        var d_sum = 0.0;
        for (var lag0 = 1u; lag0 <= n_cut; lag0 += 4u) {
            var sum = vec4<f32>(0.0);
            for (var j = 0u; j + lag0 < n; j++) {
                let pj = rwork[at(inst, j)];
                let d0 = rwork[at(inst, j + lag0)] - pj;
                sum.x += dot(d0, d0);
                if j + lag0 + 1u < n {
                    let d1 = rwork[at(inst, j + lag0 + 1u)] - pj;
                    sum.y += dot(d1, d1);
                }
                if j + lag0 + 2u < n {
                    let d2 = rwork[at(inst, j + lag0 + 2u)] - pj;
                    sum.z += dot(d2, d2);
                }
                if j + lag0 + 3u < n {
                    let d3 = rwork[at(inst, j + lag0 + 3u)] - pj;
                    sum.w += dot(d3, d3);
                }
            }
            for (var k = 0u; k < 4u && lag0 + k <= n_cut; k++) {
                let lag = lag0 + k;
                let m = sum[k] / f32(n - lag);
                let dv = m - mean_sq * (1.0 - turn_cos_sin(lag, turns).x) / one_minus_cos_c;
                rwork[at(inst, n + lag - 1u)] = vec2<f32>(dv, 0.0);
                d_sum += dv;
            }
        }
        let d_mean = d_sum / f32(n_cut);
        let xi_mean = (f32(n_cut) + 1.0) * 0.5;
        var sxy = 0.0;
        var sxx = 0.0;
        var syy = 0.0;
        for (var lag = 1u; lag <= n_cut; lag++) {
            let dy = rwork[at(inst, n + lag - 1u)].x - d_mean;
            let dx = f32(lag) - xi_mean;
            sxy += dx * dy;
            sxx += dx * dx;
            syy += dy * dy;
        }
        if syy > 0.0 && sxx > 0.0 {
            k_c = sxy / sqrt(sxx * syy);
        }
    }
    kc[at(inst, ctl.c_index)] = k_c;
}

// Sorting space of k_final: one row of N_C values per invocation, sized by overrides.
var<workgroup> kc_rows: array<f32, WG_K * N_C>;

// K = median of K_c, and the period of the stroboscopic section.
@compute @workgroup_size(WG_K)
fn k_final(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let inst = ctl.slice_first + gid.x;
    if inst >= ctl.slice_end {
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
            let v = kc[at(inst, i)];
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
    acc[inst].period = detect_period(inst, params[inst].strobe_count);
}
// analysis::detect_period on the stroboscopic samples: the smallest p ≤ period_max with the
// last `period_window` samples repeating within tol · max(1, max|x|); 0 when none.
fn detect_period(inst: u32, n: u32) -> u32 {
    let m = ctl.period_window;
    if m == 0u || m > n {
        return 0u;
    }
    var scale = 0.0;
    for (var k = n - m; k < n; k++) {
        scale = max(scale, abs(strobe[at(inst, k)]));
    }
    let bound = ctl.period_tol * max(scale, 1.0);
    for (var p = 1u; p <= ctl.period_max; p++) {
        if m + p > n {
            break;
        }
        var fits = true;
        for (var k = n - m; k < n; k++) {
            let diff = abs(strobe[at(inst, k)] - strobe[at(inst, k - p)]);
            if !is_finite(diff) || diff > bound {
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
