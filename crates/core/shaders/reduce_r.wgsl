// Reductions, part 1, on the uniform α series the integration recorded: its dominant line
// (src/reduce `line_of`), then the phase-synchronisation index R of α against the cart
// (src/analysis/phase.rs): a radix-2 FFT Hilbert transform of each signal, then R in the
// convention asked for.

fn cmul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

// In-place iterative radix-2 FFT of words off .. off + n of instance `inst` in rwork (n a power
// of two); `sign` is
// −1 for the forward transform and +1 for the (unscaled) inverse.
fn fft(inst: u32, off: u32, n: u32, sign: f32) {
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
            let t = rwork[at(inst, off + i)];
            rwork[at(inst, off + i)] = rwork[at(inst, off + j)];
            rwork[at(inst, off + j)] = t;
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
                let u = rwork[at(inst, off + start + k)];
                let v = cmul(rwork[at(inst, off + start + k + half)], w);
                rwork[at(inst, off + start + k)] = u + v;
                rwork[at(inst, off + start + k + half)] = u - v;
            }
        }
        len <<= 1u;
    }
}

// Analytic signal of the real parts of words off .. off + n of `inst` (mean removed), in place:
// FFT, weights h (1 at DC and Nyquist, 2 for positive, 0 for negative frequencies), inverse.
fn analytic(inst: u32, off: u32, n: u32) {
    var mean = 0.0;
    for (var j = 0u; j < n; j++) {
        mean += rwork[at(inst, off + j)].x;
    }
    mean /= f32(n);
    for (var j = 0u; j < n; j++) {
        rwork[at(inst, off + j)] = vec2<f32>(rwork[at(inst, off + j)].x - mean, 0.0);
    }
    fft(inst, off, n, -1.0);
    let half = n / 2u;
    for (var k = 1u; k < n; k++) {
        if k < half {
            rwork[at(inst, off + k)] *= 2.0;
        } else if k > half {
            rwork[at(inst, off + k)] = vec2<f32>(0.0, 0.0);
        }
    }
    fft(inst, off, n, 1.0);
}

// One-sided amplitude of bin k of an n-point transform at word off of `inst`, up to the common
// factor 1/Σw: 2|X_k|, but |X_k| at DC and Nyquist (src/analysis/spectrum.rs).
fn one_sided(inst: u32, off: u32, k: u32, n: u32) -> f32 {
    let a = length(rwork[at(inst, off + k)]);
    if k == 0u || k == n / 2u {
        return a;
    }
    return 2.0 * a;
}

// The dominant line of α over the forcing frequency, as `line_of` in src/reduce: the mean-removed
// R series times a periodic Hann window, copied into the cart's half of the work space (which
// r_cart fills afterwards), its FFT, the largest bin above DC (the last of equals), moved between
// bins by the vertex of a parabola through the log amplitudes of it and its neighbours. Bin k
// lies at k·(samples per period)/n forcing frequencies.
@compute @workgroup_size(WG)
fn line(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = ctl.slice_first + gid.x;
    if inst >= ctl.slice_end {
        return;
    }
    let nan = bitcast<f32>(0x7fc00000u);
    if acc[inst].status != STATUS_OK {
        acc[inst].line = nan;
        return;
    }
    let p = params[inst];
    let n = p.r_count;
    var mean = 0.0;
    for (var j = 0u; j < n; j++) {
        mean += rwork[at(inst, j)].x;
    }
    mean /= f32(n);
    for (var j = 0u; j < n; j++) {
        let w = 0.5 * (1.0 - cos_turn(f32(j) / f32(n)));
        rwork[at(inst, n + j)] = vec2<f32>((rwork[at(inst, j)].x - mean) * w, 0.0);
    }
    fft(inst, n, n, -1.0);
    let half = n / 2u;
    var k = 1u;
    var c = -1.0;
    for (var j = 1u; j <= half; j++) {
        let a = one_sided(inst, n, j, n);
        if a >= c {
            k = j;
            c = a;
        }
    }
    if !is_finite(c) || c <= 0.0 {
        acc[inst].line = nan;
        return;
    }
    var shift = 0.0;
    if k < half {
        let l = one_sided(inst, n, k - 1u, n);
        let r = one_sided(inst, n, k + 1u, n);
        if l > 0.0 && r > 0.0 {
            let curvature = log(l) - 2.0 * log(c) + log(r);
            if curvature < 0.0 {
                shift = 0.5 * (log(l) - log(r)) / curvature;
            }
        }
    }
    let per_period = f32(p.spp / p.r_every);
    acc[inst].line = (f32(k) + shift) * per_period / f32(n);
}

// Phase synchronisation R of α against the cart position x0 over the R series, in three
// kernels so that no invocation runs long loops (lavapipe stops any invocation after 65535
// loop iterations): the analytic signal of α, that of the cart, then R.
@compute @workgroup_size(WG)
fn r_alpha(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = ctl.slice_first + gid.x;
    if inst >= ctl.slice_end || acc[inst].status != STATUS_OK {
        return;
    }
    analytic(inst, 0u, params[inst].r_count);
}

@compute @workgroup_size(WG)
fn r_cart(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = ctl.slice_first + gid.x;
    if inst >= ctl.slice_end || acc[inst].status != STATUS_OK {
        return;
    }
    let p = params[inst];
    let n = p.r_count;
    for (var j = 0u; j < n; j++) {
        let s = p.r_start + j * p.r_every;
        let ph = f32(s % p.spp) / f32(p.spp) + p.phase0;
        rwork[at(inst, n + j)] = vec2<f32>(p.pos_amp * sin_turn(ph), 0.0);
    }
    analytic(inst, n, n);
}

@compute @workgroup_size(WG)
fn r_phase(@builtin(global_invocation_id) gid: vec3<u32>) {
    let inst = ctl.slice_first + gid.x;
    if inst >= ctl.slice_end {
        return;
    }
    if acc[inst].status != STATUS_OK {
        acc[inst].r = bitcast<f32>(0x7fc00000u);
        return;
    }
    let n = params[inst].r_count;
    var sum_c = 0.0;
    var sum_s = 0.0;
    for (var j = 0u; j < n; j++) {
        let za = rwork[at(inst, j)];
        let zc = rwork[at(inst, n + j)];
        var d = atan2(za.y, za.x) - atan2(zc.y, zc.x);
        if PAPER_CONVENTION {
            d = d - PI * floor((d + 0.5 * PI) / PI);
        }
        // d is within [-2π, 2π]: reduced to [-π, π] for sin and cos.
        d = d - TAU * round(d / TAU);
        sum_c += cos(d);
        sum_s += sin(d);
    }
    acc[inst].r = sqrt(sum_c * sum_c + sum_s * sum_s) / f32(n);
}
