#!/usr/bin/env python3
"""JAX (jit + vmap) peer of pendulum-atlas's CPU RK4 engine: integration throughput on the CPU.

The model is the chain of N rigid segments on a horizontally shaken cart of `docs/model.md`:

    M(θ) θ̈ = Q(θ, θ̇, t)                                         (docs/model.md §2)

with the joint springs and dampers of §2-§3, the two point bumpers of §4 (exact law, both
damping laws), the optional piezo circuit of §5, and the harmonic cart of
`src/model/excitation.rs` evaluated from the integer step, as `src/engine/plan.rs::cart_at` does:

    φ = ((step mod spp) + c) / spp  cycles,   ẍ0 = −A ω² sin 2πφ,   c ∈ {0, ½, ½, 1}
                                                (the RK4 stage fractions, src/engine/rk4.rs)

State y = [θ_0 … θ_{N−1}; ω_0 … ω_{N−1}; v] (v: piezo voltage, 0 without a piezo).

Three variants:

* ``researcher`` — what a researcher would write: per instance, the dense mass matrix M(θ) and
  force vector Q (dense.rs), ``jnp.linalg.solve``, ``jax.vmap`` over instances, classical RK4
  inside one jitted ``lax.fori_loop`` over steps. Default JAX/XLA settings (one CPU device).
* ``tuned`` — by hand: no matrix at all, the O(N) articulated-body recursion of
  ``src/model/chain.rs`` (``solve_accelerations``) on a structure-of-arrays layout (state
  (2N+1, M), instances along the fast axis, so every operation is an elementwise loop over
  instances that XLA fuses and vectorises); its two sweeps are ``lax.scan``s over the segments
  (why not unrolled in Python: see the comment above ``tuned_constants``); per-instance constants
  precomputed once outside the step loop; the structure (contact levers, law, root spring,
  piezo) fixed at trace time; and the instance axis split over every CPU core:
  ``XLA_FLAGS=--xla_force_host_platform_device_count=<cores>`` is set before jax is imported and
  the step loop runs under ``shard_map`` over a 1-D mesh of those devices (no communication).
* ``cramer`` — N = 3 only: the researcher's dense M(θ) and Q per instance (same code), but the
  3×3 system solved by Cramer's rule written out (cofactors of the symmetric M, one division)
  instead of ``jnp.linalg.solve``, and the batch split over every CPU core exactly as
  ``tuned`` does (same XLA_FLAGS, same padding, ``shard_map`` over the same 1-D mesh).

All integrate y += inc without the Kahan compensation of the Rust engine unless ``--kahan``.
No variant counts anything (no K, no reductions): only integration is timed.

Usage (see benches/peers/README.md):

    python benches/peers/jax_cpu.py --case DIR_OR_FILE --segments N --instances M --steps S \
        --precision f32|f64 --variant researcher|tuned|cramer [--repeat 3] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time

# ---------------------------------------------------------------------------------------------
# Command line (parsed before jax is imported: the tuned and cramer variants must set XLA_FLAGS
# first).
# ---------------------------------------------------------------------------------------------


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", required=True,
                    help="a case file, or a folder holding peer_case_N<N>.json")
    ap.add_argument("--segments", type=int, required=True, help="N (must match the case)")
    ap.add_argument("--instances", type=int, required=True,
                    help="M timed instances; instance i uses case instance i mod 16")
    ap.add_argument("--steps", type=int, required=True, help="S timed RK4 steps")
    ap.add_argument("--precision", choices=["f32", "f64"], required=True)
    ap.add_argument("--variant", choices=list(VARIANTS), required=True)
    ap.add_argument("--repeat", type=int, default=3, help="timed runs; the median is reported")
    ap.add_argument("--json", default=None, help="write the result here")
    ap.add_argument("--devices", type=int, default=None,
                    help="tuned and cramer only: host devices (shards) to split the instances "
                         "over (default: the CPU cores this process may use)")
    ap.add_argument("--kahan", action="store_true",
                    help="add each step's increment with Kahan compensation, as the Rust engine "
                         "does (off by default: the peer then does plain y += inc)")
    a = ap.parse_args(argv)
    if a.variant == "cramer" and a.segments != CRAMER_N:
        # argparse's error(): the usage line, this message, exit status 2
        ap.error(f"--variant cramer writes out the {CRAMER_N}x{CRAMER_N} solve by Cramer's rule "
                 f"and runs at N = {CRAMER_N} only (got --segments {a.segments}); use "
                 "--variant researcher or tuned for other N")
    return a


VARIANTS = ("researcher", "tuned", "cramer")
SHARDED = ("tuned", "cramer")  # the variants split over host devices with shard_map
CRAMER_N = 3                   # the only N the cramer variant solves


ARGS = parse_args() if __name__ == "__main__" else None


def usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


if ARGS is not None and ARGS.variant in SHARDED:
    _n_dev = ARGS.devices or usable_cores()
    _flags = os.environ.get("XLA_FLAGS", "")
    if "xla_force_host_platform_device_count" not in _flags:
        os.environ["XLA_FLAGS"] = (
            _flags + f" --xla_force_host_platform_device_count={_n_dev}").strip()

import numpy as np  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from jax import lax  # noqa: E402

jax.config.update("jax_enable_x64", True)  # the check runs in f64; f32 runs cast explicitly

try:  # jax >= 0.6
    from jax import shard_map as _shard_map
except ImportError:  # older jax
    from jax.experimental.shard_map import shard_map as _shard_map
from jax.sharding import Mesh, NamedSharding, PartitionSpec as PS  # noqa: E402

TAU = 2.0 * math.pi


# ---------------------------------------------------------------------------------------------
# Case files
# ---------------------------------------------------------------------------------------------


def load_case(path: str, n: int) -> dict:
    """Read `peer_case_N<n>.json` (or the file given) and refuse what this peer cannot run."""
    if os.path.isdir(path):
        path = os.path.join(path, f"peer_case_N{n}.json")
    with open(path) as fh:
        case = json.load(fh)
    case["path"] = os.path.abspath(path)
    if case["segments"] != n:
        sys.exit(f"{path}: the case has N = {case['segments']}, --segments says {n}")
    if case.get("method", "rk4") != "rk4":
        sys.exit(f"{path}: method {case['method']!r}; this peer integrates classical RK4 only")
    for k, inst in enumerate(case["instances"]):
        p = inst["params"]
        if p["segments"] != n or len(inst["y0"]) != 2 * n + 1:
            sys.exit(f"{path}: instance {k} has the wrong size")
        kind = p["cart"]["kind"]
        if kind.get("kind") != "harmonic":
            sys.exit(f"{path}: instance {k}: cart kind {kind.get('kind')!r}; "
                     "only harmonic forcing is supported (sweeps need at_time)")
        c = p.get("contact")
        if c is not None and c["law"] not in ("loading", "kelvin_voigt"):
            sys.exit(f"{path}: instance {k}: unknown contact law {c['law']!r}")
    return case


def structure(case: dict, n: int) -> dict:
    """The trace-time structure shared by every instance (the tuned variant specialises on it).

    Coefficients may differ per instance; the structure must not (the Rust ensembles share it
    too: N, bumpers present, piezo present)."""
    ps = [inst["params"] for inst in case["instances"]]
    has_contact = {p["contact"] is not None for p in ps}
    has_piezo = {p["piezo"] is not None for p in ps}
    if len(has_contact) != 1 or len(has_piezo) != 1:
        sys.exit("the case mixes instances with and without bumpers/piezo; not supported")
    s = {"n": n, "contact": has_contact.pop(), "piezo": has_piezo.pop()}
    s["levers"] = max(len(p["contact"]["levers_m"]) for p in ps) if s["contact"] else 0
    laws = {p["contact"]["law"] for p in ps} if s["contact"] else set()
    # one law for all (fixed at trace time), or 'mixed' (selected per instance), or None
    s["law"] = (laws.pop() if len(laws) == 1 else "mixed") if s["contact"] else None
    s["piezo_last"] = None
    if s["piezo"]:
        lasts = {p["piezo"]["last_segment"] for p in ps}
        if len(lasts) != 1:
            sys.exit("the case's piezo patches span different segments; not supported")
        s["piezo_last"] = lasts.pop()
    # A hinged root has neither spring nor damper: the tuned variant then drops the term.
    s["root"] = any(p["root_stiffness_nm"] != 0.0 or p["root_damping_nms"] != 0.0 for p in ps)
    return s


def instance_table(case: dict, n: int, count: int) -> dict:
    """Per-instance coefficient arrays (float64 numpy) for `count` instances, instance i being
    case instance i mod 16. Names follow src/model/params.rs."""
    insts = [case["instances"][i % len(case["instances"])] for i in range(count)]
    col = lambda f: np.array([f(inst) for inst in insts], dtype=np.float64)  # noqa: E731
    P = lambda key: col(lambda i: i["params"][key])  # noqa: E731
    t = {
        "l": P("seg_length_m"), "m": P("seg_mass_kg"), "J": P("seg_inertia_kgm2"),
        "tip": P("tip_mass_kg"), "Jh": P("holder_inertia_kgm2"), "g": P("g_m_s2"),
        "k": P("joint_stiffness_nm"), "k0": P("root_stiffness_nm"),
        "b": P("joint_damping_nms"), "b0": P("root_damping_nms"),
        "dt": col(lambda i: i["dt_s"]),
        "spp": np.array([i["spp"] for i in insts], dtype=np.int32),
    }
    # Cart: A ω², ω = 2π f (excitation.rs `amplitudes`: A * w.powi(2)).
    w = TAU * col(lambda i: i["params"]["cart"]["kind"]["frequency_hz"])
    t["aw2"] = col(lambda i: i["params"]["cart"]["amplitude_m"]) * (w * w)
    # Bumpers (§4): levers padded to N, gap, k_c, c_c, law (0 loading, 1 Kelvin–Voigt).
    lev = np.zeros((count, n))
    gap, kc, cc, law = (np.zeros(count) for _ in range(4))
    # Piezo (§5): coupling Θ, 1/C_p, 1/R_L, and a one-hot of the last patched segment.
    theta_p, inv_c, inv_r = (np.zeros(count) for _ in range(3))
    e_last = np.zeros((count, n))
    for r, inst in enumerate(insts):
        c = inst["params"]["contact"]
        if c is not None:
            lev[r, : len(c["levers_m"])] = c["levers_m"]
            gap[r], kc[r], cc[r] = c["gap_m"], c["stiffness_n_per_m"], c["damping_ns_per_m"]
            law[r] = 0.0 if c["law"] == "loading" else 1.0
        z = inst["params"]["piezo"]
        if z is not None:
            theta_p[r] = z["coupling_nm_per_v"]
            inv_c[r], inv_r[r] = 1.0 / z["capacitance_f"], 1.0 / z["load_ohm"]
            e_last[r, z["last_segment"]] = 1.0
    t.update(levers=lev, gap=gap, kc=kc, cc=cc, law=law,
             theta_p=theta_p, inv_c=inv_c, inv_r=inv_r, e_last=e_last)
    t["y0"] = np.array([inst["y0"] for inst in insts], dtype=np.float64)  # (count, 2N+1)
    return t


# ---------------------------------------------------------------------------------------------
# Shared pieces: the cart, the bumper law
# ---------------------------------------------------------------------------------------------


def cart_acc(step, frac, spp, aw2, dtype):
    """ẍ0 at `frac` of step `step` (plan.rs `cart_at` + excitation.rs `at_phase`):
    φ = ((step mod spp) + frac)/spp cycles, ẍ0 = −Aω² sin 2πφ. `step` is an integer scalar,
    `spp` an int32 array, so the phase is exact in integers before any float sees it."""
    ph = jnp.remainder(step.astype(spp.dtype), spp).astype(dtype)
    cycles = (ph + frac) / spp.astype(dtype)
    return -aw2 * jnp.sin(TAU * cycles)


def bumper_force(delta, rate, kc, cc, law):
    """The exact bumper law (chain.rs `bumper_mode` + `bumper_force`, docs/model.md §4).

    law 0, "loading":      F = k_c δ + c_c max(δ̇, 0)       while δ > 0, else 0
    law 1, "kelvin_voigt": F = max(0, k_c δ + c_c δ̇)       while δ > 0, else 0
    `law` is a float flag array, or the Python string of a law fixed at trace time."""
    spring = kc * delta
    zero = jnp.zeros_like(spring)
    loading = spring + cc * jnp.maximum(rate, zero)
    kelvin = jnp.maximum(spring + cc * rate, zero)
    if isinstance(law, str):  # fixed at trace time
        f = loading if law == "loading" else kelvin
    else:
        f = jnp.where(law == 0.0, loading, kelvin)
    return jnp.where(delta > 0.0, f, zero)


# ---------------------------------------------------------------------------------------------
# Variant "researcher": dense M(θ) θ̈ = Q per instance, jnp.linalg.solve, vmap, RK4
# ---------------------------------------------------------------------------------------------


def researcher_derivative(n: int, solve=jnp.linalg.solve):
    """ẏ = f(y, ẍ0; p) for ONE instance, the dense Lagrange form of docs/model.md §2
    (src/model/dense.rs) plus the applied couples of chain.rs `generalised_forces`.
    `solve(M, Q)` gives θ̈: `jnp.linalg.solve` (researcher) or `cramer3_solve` (cramer)."""
    idx = np.arange(n)
    above = (n - 1 - idx).astype(np.float64)  # segments above segment i (0-based)
    imax = np.maximum(idx[:, None], idx[None, :])
    eye = np.eye(n)

    def f(y, a, p):
        dt = y.dtype
        th, om, v = y[:n], y[n:2 * n], y[2 * n]
        l, m = p["l"], p["m"]
        # carried mass w_i = m/2 + m(N−i) + M (params.rs `carried_mass_kg`), and
        # μ_ij = w_max(i,j), μ_ii = w_i − m/4 (params.rs `mu_kg`)                      §2
        w = 0.5 * m + m * above.astype(dt) + p["tip"]
        mu = w[imax] - 0.25 * m * eye.astype(dt)
        diff = th[:, None] - th[None, :]
        l2mu = l * l * mu
        # M_ij = ℓ² μ_ij cos(θ_i − θ_j) + δ_ij J (+ J_h at (1,1))                         §2
        M = l2mu * jnp.cos(diff) + p["J"] * eye.astype(dt)
        M = M.at[0, 0].add(p["Jh"])
        s, c = jnp.sin(th), jnp.cos(th)
        # Q_i = −Σ_j ℓ²μ_ij sin(θ_i−θ_j) θ̇_j² + w_i ℓ g sin θ_i − w_i ℓ ẍ0 cos θ_i      §2
        Q = -(l2mu * jnp.sin(diff)) @ (om * om) + w * l * (p["g"] * s - a * c)
        # root spring/damper on the holder, joint springs/dampers                          §2-3
        Q = Q.at[0].add(-p["k0"] * th[0] - p["b0"] * om[0])
        tau = -p["k"] * (th[1:] - th[:-1]) - p["b"] * (om[1:] - om[:-1])
        Q = Q.at[1:].add(tau).at[:-1].add(-tau)
        # bumpers: x = Σ λ_i sin θ_i, ẋ = Σ λ_i cos θ_i θ̇_i; Q_i += (F_L − F_R) λ_i cos θ_i  §4
        lev = p["levers"]
        x, xd = jnp.dot(lev, s), jnp.dot(lev * c, om)
        fr = bumper_force(x - p["gap"], xd, p["kc"], p["cc"], p["law"])
        fl = bumper_force(-x - p["gap"], -xd, p["kc"], p["cc"], p["law"])
        Q = Q + (fl - fr) * lev * c
        # piezo: Q_1 += Θ v, Q_{p+1} −= Θ v; v̇ = (Θ (θ̇_{p+1} − θ̇_1) − v/R_L)/C_p          §5
        e0 = jnp.zeros(n, dt).at[0].set(1.0)
        Q = Q + p["theta_p"] * v * (e0 - p["e_last"])
        dv = (p["theta_p"] * (jnp.dot(p["e_last"], om) - om[0]) - v * p["inv_r"]) * p["inv_c"]
        acc = solve(M, Q)
        return jnp.concatenate([om, acc, dv[None]])

    return f


# The per-instance coefficients the dense derivative reads; the step loop also reads dt, spp and
# aw2 (the step and the cart), and y0 is the state.
DENSE_PARAM_KEYS = ("l", "m", "J", "tip", "Jh", "g", "k", "k0", "b", "b0", "levers", "gap",
                    "kc", "cc", "law", "theta_p", "inv_c", "inv_r", "e_last")


def make_researcher(n: int, steps: int, kahan: bool):
    """The jitted batch integrator: y (M, 2N+1), params dict of per-instance arrays."""
    return jax.jit(dense_loop(researcher_derivative(n), steps, kahan))


def dense_loop(f1, steps: int, kahan: bool):
    """The un-jitted RK4 step loop over a batch, y (M, 2N+1), of the one-instance dense
    derivative `f1`, vmapped over the instances (researcher and cramer share it)."""
    f = jax.vmap(f1)  # over instances: y (M,2N+1), a (M,), p (M,...)
    param_keys = DENSE_PARAM_KEYS

    def run(y, P):
        dtype = y.dtype
        p = {k: P[k] for k in param_keys}
        dt = P["dt"][:, None]

        def step(i, carry):
            y, comp = carry
            a0 = cart_acc(i, 0.0, P["spp"], P["aw2"], dtype)
            am = cart_acc(i, 0.5, P["spp"], P["aw2"], dtype)
            a1 = cart_acc(i, 1.0, P["spp"], P["aw2"], dtype)
            # classical RK4, cart at 0, ½, ½, 1 of the step (src/engine/rk4.rs)
            k0 = f(y, a0, p)
            k1 = f(y + (dt * 0.5) * k0, am, p)
            k2 = f(y + (dt * 0.5) * k1, am, p)
            k3 = f(y + dt * k2, a1, p)
            inc = dt * (1.0 / 6.0) * (k0 + 2.0 * (k1 + k2) + k3)
            return add_increment(y, comp, inc, kahan)

        y, _ = lax.fori_loop(0, steps, step, (y, jnp.zeros_like(y)))
        return y

    return run


def add_increment(y, comp, inc, kahan):
    """y += inc, plainly or with Kahan compensation (stepper.rs `compensated_add`)."""
    if not kahan:
        return y + inc, comp
    corrected = inc - comp
    s = y + corrected
    return s, (s - y) - corrected


# ---------------------------------------------------------------------------------------------
# Variant "cramer": the researcher's dense M(θ), Q; the 3×3 solve by Cramer's rule; sharded
# ---------------------------------------------------------------------------------------------


def cramer3_solve(M, Q):
    """θ̈ = M⁻¹ Q for ONE 3×3 system by Cramer's rule, written out.

    θ̈_k = det(M with column k replaced by Q) / det M. Expanding each determinant along the
    replaced column gives θ̈_k = Σ_j Q_j C_jk / det M, with C the cofactors of M; det M is
    expanded along row 0. M is symmetric by construction (ℓ²μ_ij cos(θ_i − θ_j) + δ_ij J), so
    only its upper triangle is read and C is symmetric too: 6 cofactors, one division."""
    a00, a01, a02 = M[0, 0], M[0, 1], M[0, 2]
    a11, a12, a22 = M[1, 1], M[1, 2], M[2, 2]
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22  # = C_10
    c02 = a01 * a12 - a02 * a11  # = C_20
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12  # = C_21
    c22 = a00 * a11 - a01 * a01
    inv_det = 1.0 / (a00 * c00 + a01 * c01 + a02 * c02)
    q0, q1, q2 = Q[0], Q[1], Q[2]
    return jnp.stack([q0 * c00 + q1 * c01 + q2 * c02,
                      q0 * c01 + q1 * c11 + q2 * c12,
                      q0 * c02 + q1 * c12 + q2 * c22]) * inv_det


def make_cramer(n: int, steps: int, kahan: bool, mesh: Mesh, keys):
    """The researcher's step loop (dense M, Q per instance, vmap, RK4 in one fori_loop) with
    `cramer3_solve`, under `shard_map` over `mesh` as the tuned variant runs: y (M, 2N+1) and
    every per-instance array (`keys`) split along the instance axis (the first here), each
    device integrating its own block of instances, no communication. Returns the jitted
    function and the partition spec of each input array."""
    if n != CRAMER_N:
        raise ValueError(f"the cramer variant solves N = {CRAMER_N} only, not N = {n}")
    run = dense_loop(researcher_derivative(n, solve=cramer3_solve), steps, kahan)
    specs = {k: PS("i") for k in keys}
    sharded = _shard_map(run, mesh=mesh, in_specs=(PS("i"), specs), out_specs=PS("i"))
    return jax.jit(sharded), specs


# ---------------------------------------------------------------------------------------------
# Variant "tuned": O(N) recursion, structure of arrays, specialised at trace time, sharded
# ---------------------------------------------------------------------------------------------
#
# Why the recursion runs as `lax.scan` over the segments and is not unrolled in Python: fully
# unrolled, the articulated-body recursion is a deep elementwise graph in which every level's
# values feed several consumers. XLA:CPU's fusion pass duplicates cheap elementwise producers
# into every consumer kernel, so the unrolled graph is recomputed many times over: we measured
# a 284 s compile and ~100x lower throughput at N = 17 (optimisation barriers do not help: the
# CPU pipeline strips them before fusion). A scan body is a fusion boundary, so each segment's
# level is computed once per stage. Partial unrolling (scan unroll = 2, 3) was slower again,
# for the same reason.


def tuned_constants(t: dict, s: dict) -> dict:
    """Per-instance constants, computed once in float64 before the step loop (not per stage)."""
    n = s["n"]
    l, m = t["l"], t["m"]
    base_d = t["J"] + m * l * l * 0.25  # J + mℓ²/4 (chain.rs `base_d`)
    c = {
        "l": l, "ll": l * l, "m": m, "k": t["k"], "b": t["b"],
        "hml": 0.5 * m * l,                         # mℓ/2
        "hl": 0.5 * l,                              # ℓ/2
        "twol": 2.0 * l,                            # 2ℓ
        "mg": m * t["g"],                           # m g
        "tip": t["tip"], "tipg": t["tip"] * t["g"],  # tip: K = diag(M, M), p = (0, M g)
        # d_i's constant part per segment: J + mℓ²/4, plus J_h on the holder (segment 0)
        "bd": np.stack([base_d + (t["Jh"] if i == 0 else 0.0) for i in range(n)]),
        "h": 0.5 * t["dt"], "dt": t["dt"], "dt6": t["dt"] * (1.0 / 6.0),
        "aw2": t["aw2"], "spp": t["spp"], "tau_spp": TAU / t["spp"],  # cart: Aω², 2π/spp
    }
    if s["root"]:  # clamped root or bearing damper; a free hinge drops the term
        c["k0"], c["b0"] = t["k0"], t["b0"]
    if s["contact"]:
        c["lev"] = np.ascontiguousarray(t["levers"][:, : s["levers"]].T)  # (levers, M)
        c.update(gap=t["gap"], kc=t["kc"], cc=t["cc"])
        if s["law"] == "mixed":
            c["law"] = t["law"]
    if s["piezo"]:
        c.update(theta_p=t["theta_p"], inv_c=t["inv_c"], inv_r=t["inv_r"])
    return c


# Which constants are laid out (rows, M) rather than (M,): their instance axis is the last.
ROW_CONSTANTS = ("bd", "lev")


def tuned_derivative(s: dict):
    """ẏ for a batch laid out (N, M) (segment-major, instances along the fast axis): the
    segment-wise work on whole (N, M) arrays, the two sweeps of chain.rs
    `solve_accelerations` as `lax.scan`s over the segments."""

    def f(th, om, v, a, C):
        sn, cs = jnp.sin(th), jnp.cos(th)
        # --- generalised forces Q (chain.rs `generalised_forces`, docs/model.md §2-5) ---
        # joint i (2..N): τ_i = −k(θ_i − θ_{i−1}) − b(θ̇_i − θ̇_{i−1}); Q_i += τ_i, Q_{i−1} −= τ_i
        tau = -C["k"] * (th[1:] - th[:-1]) - C["b"] * (om[1:] - om[:-1])
        zrow = jnp.zeros_like(th[:1])
        q = jnp.concatenate([zrow, tau]) - jnp.concatenate([tau, zrow])
        if s["root"]:  # Q_1 += −k_0 θ_1 − b_root θ̇_1
            q = q.at[0].add(-C["k0"] * th[0] - C["b0"] * om[0])
        if s["contact"]:  # bumpers, §4: Q_i += (F_L − F_R) λ_i cos θ_i
            nl = s["levers"]
            lev = C["lev"]
            lc = lev * cs[:nl]
            x = jnp.sum(lev * sn[:nl], axis=0)   # x_c − x0 = Σ λ_i sin θ_i
            xd = jnp.sum(lc * om[:nl], axis=0)   # ẋ_c − ẋ0 = Σ λ_i cos θ_i θ̇_i
            law = C["law"] if s["law"] == "mixed" else s["law"]
            fx = (bumper_force(-x - C["gap"], -xd, C["kc"], C["cc"], law)
                  - bumper_force(x - C["gap"], xd, C["kc"], C["cc"], law))
            q = q.at[:nl].add(fx * lc)
        dv = None
        if s["piezo"]:  # §5: Q_1 += Θv, Q_{p+1} −= Θv; v̇ = (Θ(θ̇_{p+1} − θ̇_1) − v/R_L)/C_p
            last = s["piezo_last"]
            tv = C["theta_p"] * v
            q = q.at[0].add(tv).at[last].add(-tv)
            dv = (C["theta_p"] * (om[last] - om[0]) - v * C["inv_r"]) * C["inv_c"]
        w2 = om * om
        l, ll, hml, m, twol, mg = C["l"], C["ll"], C["hml"], C["m"], C["twol"], C["mg"]

        # --- backward sweep, tip to pivot: articulated inertia K (2×2) and bias p ---
        def back(carry, xs):
            kxx, kxy, kyy, px, py = carry
            si, ci, w2i, qi, bd = xs
            nx, ny = ci, -si  # n = ∂u/∂θ, u = (sin θ, cos θ)
            knx = kxx * nx + kxy * ny
            kny = kxy * nx + kyy * ny
            kux = kxx * si + kxy * ci
            kuy = kxy * si + kyy * ci
            hx = hml * nx + l * knx
            hy = hml * ny + l * kny
            d = bd + ll * (nx * knx + ny * kny)
            ex = -(hml * si + l * kux) * w2i + px
            ey = -(hml * ci + l * kuy) * w2i + py + mg
            b2x = -(hml * si + twol * kux) * w2i + 2.0 * px
            b2y = -(hml * ci + twol * kuy) * w2i + 2.0 * py + mg
            beta = -C["hl"] * (nx * b2x + ny * b2y) + qi
            inv_d = 1.0 / d
            hbd = beta * inv_d
            new = (m + kxx - hx * hx * inv_d, kxy - hx * hy * inv_d, m + kyy - hy * hy * inv_d,
                   ex + hx * hbd, ey + hy * hbd)
            return new, (hx, hy, inv_d, beta)

        z = jnp.zeros_like(th[0])
        tip = C["tip"] + z
        _, (hx, hy, inv_d, beta) = lax.scan(back, (tip, z, tip, z, C["tipg"] + z),
                                            (sn, cs, w2, q, C["bd"]), reverse=True)

        # --- forward sweep, pivot to tip: θ̈_i, then the acceleration of node i ---
        def fwd(carry, xs):
            ax, ay = carry
            hxi, hyi, idi, bi, si, ci, w2i = xs
            acc = (bi - hxi * ax - hyi * ay) * idi
            return (ax + l * (ci * acc - si * w2i), ay - l * (si * acc + ci * w2i)), acc

        # the pivot moves with the cart: (ẍ0, 0)
        _, acc = lax.scan(fwd, (a, z), (hx, hy, inv_d, beta, sn, cs, w2))
        return acc, dv

    return f


def make_tuned(s: dict, steps: int, kahan: bool, mesh: Mesh, C: dict):
    """Jitted batch integrator, sharded over `mesh`: y (2N+1, M) component-major, constants
    (M,) or (rows, M); each device integrates its own block of instances, no communication.
    Returns the jitted function and the partition spec of each constant."""
    n = s["n"]
    f = tuned_derivative(s)
    has_v = s["piezo"]

    def cart(i, frac, C, dtype):
        # φ = ((i mod spp) + frac)/spp cycles; 2πφ = ((i mod spp) + frac)·(2π/spp)
        ph = jnp.remainder(i.astype(C["spp"].dtype), C["spp"]).astype(dtype)
        return -C["aw2"] * jnp.sin((ph + frac) * C["tau_spp"])

    def local(y, C):
        dtype = y.dtype
        h, dt, dt6 = C["h"], C["dt"], C["dt6"]

        def deriv(y, a):
            om = y[n:2 * n]
            acc, dv = f(y[:n], om, y[2 * n] if has_v else None, a, C)
            return jnp.concatenate([om, acc] + ([dv[None]] if has_v else []))

        def step(i, carry):
            y, comp = carry
            a0, am, a1 = (cart(i, c, C, dtype) for c in (0.0, 0.5, 1.0))
            # classical RK4, cart at 0, ½, ½, 1 of the step (src/engine/rk4.rs)
            k0 = deriv(y, a0)
            k1 = deriv(y + h * k0, am)
            k2 = deriv(y + h * k1, am)
            k3 = deriv(y + dt * k2, a1)
            return add_increment(y, comp, dt6 * (k0 + 2.0 * (k1 + k2) + k3), kahan)

        # Without a piezo, v stays 0: integrate the 2N mechanical rows only.
        yy = y if has_v else y[:2 * n]
        yy, _ = lax.fori_loop(0, steps, step, (yy, jnp.zeros_like(yy)))
        return yy if has_v else jnp.concatenate([yy, y[2 * n:]])

    specs = {k: (PS(None, "i") if k in ROW_CONSTANTS else PS("i")) for k in C}
    sharded = _shard_map(local, mesh=mesh, in_specs=(PS(None, "i"), specs),
                         out_specs=PS(None, "i"))
    return jax.jit(sharded), specs


# ---------------------------------------------------------------------------------------------
# Driver
# ---------------------------------------------------------------------------------------------


class Peer:
    """Builds the variant for one instance count and steps, and puts the inputs in place."""

    def __init__(self, variant, case, s, count, steps, precision, kahan):
        self.variant, self.s, self.steps = variant, s, steps
        self.dtype = np.float64 if precision == "f64" else np.float32
        t = instance_table(case, s["n"], count)
        self.count = count
        cast = lambda v: v if v.dtype.kind == "i" else v.astype(self.dtype)  # noqa: E731
        if variant == "researcher":
            self.fn = make_researcher(s["n"], steps, kahan)
            self.y0 = jnp.asarray(t["y0"].astype(self.dtype))
            self.P = {k: jnp.asarray(cast(v)) for k, v in t.items() if k != "y0"}
            return
        devs = jax.devices()
        # Sharded variants: pad the instance axis to a multiple of the device count
        # (continuing the tiling); only the first `count` instances are reported.
        padded = -(-count // len(devs)) * len(devs)
        if padded != count:
            t = instance_table(case, s["n"], padded)
        self.padded = padded
        self.mesh = Mesh(np.array(devs), ("i",))
        if variant == "cramer":  # instance-major (M, ...) as the researcher variant
            keys = DENSE_PARAM_KEYS + ("dt", "spp", "aw2")
            self.fn, specs = make_cramer(s["n"], steps, kahan, self.mesh, keys)
            self.P = {k: jax.device_put(cast(t[k]), NamedSharding(self.mesh, specs[k]))
                      for k in keys}
            self.y0 = jax.device_put(t["y0"].astype(self.dtype),
                                     NamedSharding(self.mesh, PS("i")))
        else:
            C = tuned_constants(t, s)
            self.fn, specs = make_tuned(s, steps, kahan, self.mesh, C)
            self.P = {k: jax.device_put(v if v.dtype.kind == "i" else v.astype(self.dtype),
                                        NamedSharding(self.mesh, specs[k]))
                      for k, v in C.items()}
            self.y0 = jax.device_put(np.ascontiguousarray(t["y0"].T.astype(self.dtype)),
                                     NamedSharding(self.mesh, PS(None, "i")))

    def compile(self):
        t0 = time.perf_counter()
        self.exe = self.fn.lower(self.y0, self.P).compile()
        return time.perf_counter() - t0

    def run(self):
        out = self.exe(self.y0, self.P)
        out.block_until_ready()
        return out

    def result(self, out):
        """The final states as (count, 2N+1) float64."""
        y = np.asarray(out, dtype=np.float64)
        if self.variant == "tuned":
            y = y.T
        return y[: self.count]


def check(variant, case, s, precision, kahan):
    """Integrate the 16 case instances for check_steps steps; max |Δy| against y_check."""
    peer = Peer(variant, case, s, len(case["instances"]), case["check_steps"], precision, kahan)
    peer.compile()
    y = peer.result(peer.run())
    ref = np.array([inst["y_check"] for inst in case["instances"]], dtype=np.float64)
    err = np.abs(y - ref)
    return float(np.nanmax(err)) if np.all(np.isfinite(y)) else float("inf")


def main(a):
    n = a.segments
    case = load_case(a.case, n)
    s = structure(case, n)
    devices = jax.devices()

    # 1. The check, in f64 always (the model must agree with the Rust f64 engine), and in f32
    #    when timing f32 (its error is the f32 rounding, for information).
    err64 = check(a.variant, case, s, "f64", a.kahan)
    err32 = check(a.variant, case, s, "f32", a.kahan) if a.precision == "f32" else None
    ok = err64 < 1e-9
    print(f"check N={n} {a.variant}: {case['check_steps']} steps x {len(case['instances'])} "
          f"instances, f64 max|dy| = {err64:.3e}"
          + (f", f32 max|dy| = {err32:.3e}" if err32 is not None else "")
          + ("" if ok else "   ** FAILED: the model differs from the Rust engine **"),
          flush=True)

    # 2. The timing: compile excluded (ahead-of-time compile, then one warm-up run).
    peer = Peer(a.variant, case, s, a.instances, a.steps, a.precision, a.kahan)
    compile_s = peer.compile()
    t0 = time.perf_counter()
    out = peer.run()
    warmup_s = time.perf_counter() - t0
    seconds = []
    for _ in range(a.repeat):
        t0 = time.perf_counter()
        out = peer.run()
        seconds.append(time.perf_counter() - t0)
    y = peer.result(out)
    finite = int(np.isfinite(y).all(axis=1).sum())
    med = statistics.median(seconds)
    ips = a.instances * a.steps / med
    res = {
        "peer": "jax_cpu",
        "variant": a.variant,
        "precision": a.precision,
        "segments": n,
        "instances": a.instances,
        "steps": a.steps,
        "seconds": seconds,
        "median_s": med,
        "instance_steps_per_s": ips,
        "segment_steps_per_s": ips * n,
        "check_max_abs_err": err64,
        "check_f32_max_abs_err": err32,
        "check_passed": ok,
        "check_steps": case["check_steps"],
        "kahan": a.kahan,
        "compile_s": compile_s,
        "warmup_s": warmup_s,
        "finite_instances": finite,
        "case": case["path"],
        "structure": {k: s[k] for k in ("contact", "levers", "law", "piezo", "root")},
        "jax_version": jax.__version__,
        "jaxlib_version": getattr(__import__("jaxlib"), "__version__", None),
        "numpy_version": np.__version__,
        "python": platform.python_version(),
        "devices": [str(d) for d in devices],
        "threads": {
            "cpu_count": os.cpu_count(),
            "usable_cores": usable_cores(),
            "jax_devices": len(devices),
            "sharded_over_devices": len(devices) if a.variant in SHARDED else 1,
            "padded_instances": getattr(peer, "padded", a.instances),
            "XLA_FLAGS": os.environ.get("XLA_FLAGS", ""),
            "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS"),
        },
        "host": platform.node(),
        "machine": platform.machine(),
    }
    # The backend JAX ran on (cpu or gpu): jax_gpu.py runs this same loop on a GPU.
    print(f"jax ({devices[0].platform}) {a.variant} {a.precision} N={n} M={a.instances} S={a.steps}: "
          f"median {med:.4f} s of {a.repeat} -> {ips:.4e} instance-steps/s, "
          f"{ips * n:.4e} segment-steps/s (compile {compile_s:.1f} s, "
          f"{len(devices)} device(s), {finite}/{a.instances} finite)", flush=True)
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=2)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(ARGS))
