#!/usr/bin/env python3
"""JAX (jit + vmap) peer of pendulum-atlas's GPU engine: the models and variants of
jax_cpu.py (``researcher``: dense M(θ) and ``jnp.linalg.solve`` under vmap; ``tuned``: the O(N)
recursion of src/model/chain.rs, instances along the fast axis), run on JAX's default backend,
which is the GPU where jax[cuda] is installed. Timed in f32 (the GPU engine's precision); the
model check is the same as jax_cpu.py's (f64, against our engine's state after the case's
steps, |Δy| < 1e-9).

diffrax is not used: the cart is evaluated from the integer step (phase (step mod spp + c)/spp,
src/engine/plan.rs), which a time-based diffrax solve cannot reproduce step for step, and
fixed-step RK4 is what both sides integrate.

Usage (see benches/peers/README.md):

    python benches/peers/jax_gpu.py --case DIR_OR_FILE --segments N --instances M --steps S \
        --variant researcher|tuned [--repeat 3] [--json OUT] [--allow-cpu]

Without a GPU backend it refuses to run (exit status 2) unless --allow-cpu is given (to check
the script on a machine without one; the JSON then names the CPU as its device).
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", required=True)
    ap.add_argument("--segments", type=int, required=True)
    ap.add_argument("--instances", type=int, required=True)
    ap.add_argument("--steps", type=int, required=True)
    ap.add_argument("--variant", choices=["researcher", "tuned"], required=True)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json")
    ap.add_argument("--allow-cpu", action="store_true")
    a = ap.parse_args()
    import jax_cpu  # the models, the check and the timing loop (ARGS stays None on import)
    import jax

    dev = jax.devices()[0]
    if dev.platform != "gpu" and not a.allow_cpu:
        print(f"jax_gpu: JAX's default backend is {dev.platform!r}, not a GPU (install "
              "jax[cuda12]; --allow-cpu runs it anyway)", file=sys.stderr)
        return 2
    ns = argparse.Namespace(case=a.case, segments=a.segments, instances=a.instances,
                            steps=a.steps, precision="f32", variant=a.variant,
                            repeat=a.repeat, json=a.json, devices=1, kahan=False)
    rc = jax_cpu.main(ns)
    if a.json:
        with open(a.json) as fh:
            res = json.load(fh)
        res["peer"] = "jax"
        res["device"] = f"{dev.device_kind} ({dev.platform})"
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=2)
    return rc


if __name__ == "__main__":
    sys.exit(main())
