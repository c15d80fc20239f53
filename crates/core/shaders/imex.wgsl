// The IMEX method of src/engine/imex.rs in f32: ARK3(2)4L[2]SA with the joint springs and
// dampers implicit. Tableaux (IMEX_AE, IMEX_AI, IMEX_B, IMEX_B_HAT, IMEX_C, IMEX_GAMMA) come
// from the generated header; the matrices M0⁻¹, S⁻¹ and M0 of the instance's structure and
// step from imex_mats at P.imex_offset (N × N each, row-major, in that order). With adaptive
// steps, S⁻¹ of the ladder's levels 1 … MAX_LEVEL follow (block 2 + k), and `imex_level`
// picks the one of the step being taken (src/engine/adaptive.rs).

// The ω-part of L U_j of each stage (the stage derivatives are common.wgsl's f_th, f_om, f_v).
var<private> l_om: array<array<f32, MAX_SEG>, 4>;
// Scratch: joint couples, the implicit right-hand side, R_θ.
var<private> qv: array<f32, MAX_SEG>;
var<private> rv: array<f32, MAX_SEG>;
// The ladder level k of the step being taken (h = P.dt / 2^k): which S⁻¹ the solve reads.
var<private> imex_level: u32;

// qv = −(K θ + C ω) at the stage state (sth, som); the dampers only when `damp` is 1.
fn imex_couples(damp: f32) {
    qv[0] = root_couple(sth[0], som[0], damp);
    for (var i = 1u; i < N_SEG; i++) {
        qv[i] = 0.0;
    }
    for (var i = 1u; i < N_SEG; i++) {
        let tau = joint_couple(sth[i] - sth[i - 1u], som[i] - som[i - 1u], damp);
        qv[i] += tau;
        qv[i - 1u] -= tau;
    }
}

// The first word of row i of the matrix `which` (0: M0⁻¹, 1: S⁻¹ of the current level, 2: M0).
fn mat_row_base(which: u32, i: u32) -> u32 {
    var block = which;
    if ADAPTIVE && which == 1u && imex_level > 0u {
        block = 2u + imex_level;
    }
    return P.imex_offset + block * N_SEG * N_SEG + i * N_SEG;
}

// Row i of the matrix `which` times qv or rv.
fn mat_row_q(which: u32, i: u32) -> f32 {
    let base = mat_row_base(which, i);
    var s = 0.0;
    for (var j = 0u; j < N_SEG; j++) {
        s += imex_mats[base + j] * qv[j];
    }
    return s;
}

fn mat_row_r(which: u32, i: u32) -> f32 {
    let base = mat_row_base(which, i);
    var s = 0.0;
    for (var j = 0u; j < N_SEG; j++) {
        s += imex_mats[base + j] * rv[j];
    }
    return s;
}

// The derivative of stage j at the stage state, stored; and L's ω-part when later stages need it.
fn imex_eval(j: u32, cart_a: f32) {
    derivative(cart_a);
    keep_stage(j);
    if j < 3u {
        imex_couples(1.0);
        for (var i = 0u; i < N_SEG; i++) {
            l_om[j][i] = mat_row_q(0u, i);
        }
    }
}

// Stage i: R = y + h Σ_{j<i} (a^E_ij N_j + a^I_ij L_j), then (I − hγL) U = R into (sth, som, svolt).
fn imex_implicit_stage(i: u32, h: f32) {
    for (var s = 0u; s < N_SEG; s++) {
        var rt = th[s];
        var ro = om[s];
        for (var j = 0u; j < i; j++) {
            let ae = IMEX_AE[i * 4u + j];
            let ai = IMEX_AI[i * 4u + j];
            rt += h * ai * f_th[j][s];
            ro += h * (ae * f_om[j][s] + (ai - ae) * l_om[j][s]);
        }
        sth[s] = rt;
        som[s] = ro;
    }
    svolt = volt;
    for (var j = 0u; j < i; j++) {
        svolt += h * IMEX_AE[i * 4u + j] * f_v[j];
    }
    // S U_ω = M0 R_ω − hγ K R_θ; U_θ = R_θ + hγ U_ω.
    let hg = h * IMEX_GAMMA;
    imex_couples(0.0);
    for (var s = 0u; s < N_SEG; s++) {
        rv[s] = som[s];
    }
    for (var s = 0u; s < N_SEG; s++) {
        // qv becomes the right-hand side M0 R_ω + hγ q_spring(R_θ).
        qv[s] = mat_row_r(2u, s) + hg * qv[s];
    }
    for (var s = 0u; s < N_SEG; s++) {
        let u_om = mat_row_q(1u, s);
        som[s] = u_om;
        sth[s] += hg * u_om;
    }
}

// One IMEX step from phase `ph` within the forcing period (imex_finish, y += h Σ b_j f_j
// compensated, is generated from src/engine/imex.rs).
fn imex_step(ph: u32, h: f32) {
    imex_stages(ph, 0.0, 1.0, h);
    imex_finish(h);
}

// The four stages of a step of length h that starts at fraction `start` of the base step from
// phase `ph` and spans `width` of it (0 and 1 for a whole step); the state is not advanced.
fn imex_stages(ph: u32, start: f32, width: f32, h: f32) {
    for (var i = 0u; i < N_SEG; i++) {
        sth[i] = th[i];
        som[i] = om[i];
    }
    svolt = volt;
    // The stages written out, not looped: once the driver inlines, every tableau and stage
    // index is a constant, so the stage arrays stay in registers and the tableaux fold. With
    // a loop over the stages this step ran 4.1× slower on lavapipe at N = 3 (docs/bench/README.md).
    imex_eval(0u, cart_acc(ph, start + IMEX_C[0] * width));
    imex_implicit_stage(1u, h);
    imex_eval(1u, cart_acc(ph, start + IMEX_C[1] * width));
    imex_implicit_stage(2u, h);
    imex_eval(2u, cart_acc(ph, start + IMEX_C[2] * width));
    imex_implicit_stage(3u, h);
    imex_eval(3u, cart_acc(ph, start + IMEX_C[3] * width));
}

// The scaled error of the stages just computed (AdaptiveImex::error of src/engine/adaptive.rs):
// the embedded error e = h Σ (b_j − b̂_j) f_j (the generated imex_embedded_error, into sth,
// rv and svolt) filtered through the implicit solve,
// x = (I − hγL)⁻¹ e (Imex::filtered_error: S x_ω = M0 e_ω − hγ K e_θ, x_θ = e_θ + hγ x_ω; the
// voltage unfiltered), then max over the state of |x| / (atol + rtol |y|), y the state before
// the step. A NaN component is passed over, as f64::max does on the CPU. The stage state
// (sth, som) serves as scratch: the stages are done with it.
fn imex_error(h: f32) -> f32 {
    imex_embedded_error(h);
    let hg = h * IMEX_GAMMA;
    imex_couples(0.0);
    for (var s = 0u; s < N_SEG; s++) {
        qv[s] = mat_row_r(2u, s) + hg * qv[s];
    }
    var e = 0.0;
    for (var s = 0u; s < N_SEG; s++) {
        let x_om = mat_row_q(1u, s);
        e = scaled_max(e, sth[s] + hg * x_om, th[s], P.rtol, P.atol);
        e = scaled_max(e, x_om, om[s], P.rtol, P.atol);
    }
    if HAS_PIEZO {
        e = scaled_max(e, svolt, volt, P.rtol, P.atol);
    }
    return e;
}
