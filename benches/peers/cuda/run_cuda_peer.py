#!/usr/bin/env python3
"""Run the CUDA peer (rk4_chain.cu) on a peer case: check its model, then time it.

1. The check: the case's 16 instances for its `check_steps` RK4 steps in f64; the largest
   |Δy| against our f64 engine's state `y_check` must be below 1e-9 (else exit status 1).
2. The timing: `--instances` instances (instance i is case instance i mod 16) for `--steps`
   steps in f32; the binary times the kernel with CUDA events (median of `--repeat` after a
   warm-up run).

The result is written as JSON in the fields `pendulum-atlas bench --throughput --peers DIR`
reads (file name cuda_rk4_N<N>.json). With a binary built by `g++ -DHOST_ONLY` (no GPU) the
check is the same, but the time is the CPU's and `device` says so: use it to check the model,
never as a GPU figure.

Usage:
    python3 benches/peers/cuda/run_cuda_peer.py --binary BIN --case DIR_OR_FILE --segments N \
        --instances M --steps S [--repeat 3] [--json OUT]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

TAU = 2.0 * np.pi


def load_case(path, n):
    if os.path.isdir(path):
        path = os.path.join(path, f"peer_case_N{n}.json")
    with open(path) as fh:
        case = json.load(fh)
    if case["segments"] != n:
        sys.exit(f"{path}: the case has N = {case['segments']}, --segments says {n}")
    for k, inst in enumerate(case["instances"]):
        p = inst["params"]
        if p["piezo"] is not None:
            sys.exit(f"{path}: instance {k} has a piezo; this peer has none")
        if p["cart"]["kind"].get("kind") != "harmonic":
            sys.exit(f"{path}: instance {k}: only harmonic forcing is supported")
    return case


def line(inst, n):
    """One input line: l m J tip Jh g k k0 b b0 gap kc cc law dt spp aw2 lev[N] y0[2N+1]."""
    p = inst["params"]
    c = p["contact"]
    lev = [0.0] * n
    gap, kc, cc, law = 1e9, 0.0, 0.0, 0.0
    if c is not None:
        lev[: len(c["levers_m"])] = c["levers_m"]
        gap, kc, cc = c["gap_m"], c["stiffness_n_per_m"], c["damping_ns_per_m"]
        law = 0.0 if c["law"] == "loading" else 1.0
    w = TAU * p["cart"]["kind"]["frequency_hz"]
    vals = [p["seg_length_m"], p["seg_mass_kg"], p["seg_inertia_kgm2"], p["tip_mass_kg"],
            p["holder_inertia_kgm2"], p["g_m_s2"], p["joint_stiffness_nm"],
            p["root_stiffness_nm"], p["joint_damping_nms"], p["root_damping_nms"], gap, kc, cc,
            law, inst["dt_s"], inst["spp"], p["cart"]["amplitude_m"] * w * w]
    return " ".join(repr(float(v)) for v in vals + lev + list(inst["y0"]))


def run(binary, case, n, m, steps, precision, repeat):
    insts = case["instances"]
    with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as fh:
        fh.write(f"{n} {m} {steps}\n")
        for i in range(m):
            fh.write(line(insts[i % len(insts)], n) + "\n")
        path = fh.name
    try:
        out = subprocess.run([binary, path, precision, str(repeat)], check=True,
                             capture_output=True, text=True).stdout.splitlines()
    finally:
        os.unlink(path)
    y = np.array([[float(v) for v in ln.split()] for ln in out[:-1]])
    return y, float(out[-1].split()[1])


def device_name(binary):
    try:
        q = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"],
                           capture_output=True, text=True, check=True)
        return q.stdout.splitlines()[0].strip()
    except (OSError, subprocess.CalledProcessError, IndexError):
        return f"host CPU ({os.path.basename(binary)}, no GPU: not a GPU figure)"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--binary", required=True)
    ap.add_argument("--case", required=True)
    ap.add_argument("--segments", type=int, required=True)
    ap.add_argument("--instances", type=int, required=True)
    ap.add_argument("--steps", type=int, required=True)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json")
    a = ap.parse_args()
    if a.instances < 1 or a.steps < 1 or a.repeat < 1:
        ap.error("--instances, --steps and --repeat must be at least 1")
    case = load_case(a.case, a.segments)
    k = len(case["instances"])
    y, _ = run(a.binary, case, a.segments, k, case["check_steps"], "f64", 1)
    ref = np.array([inst["y_check"] for inst in case["instances"]])
    err = float(np.max(np.abs(y - ref))) if np.all(np.isfinite(y)) else float("inf")
    ok = err < 1e-9
    print(f"check N={a.segments}: {case['check_steps']} steps x {k} instances, f64 max|dy| = "
          f"{err:.3e}" + ("" if ok else "   ** FAILED: the model differs from the Rust engine **"))
    y, seconds = run(a.binary, case, a.segments, a.instances, a.steps, "f32", a.repeat)
    ips = a.instances * a.steps / seconds
    res = {
        "peer": "cuda", "variant": "rk4_thread_per_instance", "device": device_name(a.binary),
        "segments": a.segments, "instances": a.instances, "steps": a.steps,
        "median_s": seconds, "instance_steps_per_s": ips, "check_max_abs_err": err,
        "check_passed": ok, "finite_instances": int(np.isfinite(y).all(axis=1).sum()),
    }
    print(f"cuda N={a.segments} M={a.instances} S={a.steps}: {seconds:.4f} s -> "
          f"{ips:.4e} instance-steps/s on {res['device']}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=2)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
