#!/usr/bin/env bash
# Adaptive steps on maps (issue 43), on the CPU engine: the default map (N = 3) at fixed steps
# (SIMD loop, and the scalar loop for a like-for-like time), then with each pair (the explicit
# one, which `auto` picks at N = 3, and IMEX) at the default tolerances and at 10x tighter ones,
# and the explicit pair 100x tighter (SIMD lanes, each cell its own steps); and the 192-cell
# subgrid at N = 17 (configs/maps/default_subgrid.toml), fixed, adaptive and adaptive 10x
# tighter. Verdict counts, period agreement, wall times. About 6 minutes on 2 cores.
# Usage: benches/adaptive_maps.sh OUT.md   (needs numpy: PY=path/to/python)
set -euo pipefail
B=${PENDULUM_ATLAS:-target/release/pendulum-atlas}
PY=${PY:-python3}
OUT=${1:?output markdown}
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
A='integration.step="adaptive"'
F='integration.step="fixed"'
T=(--set integration.rtol=1e-4 --set integration.atol=1e-6)
$B map --backend cpu --quiet --set "$F" --out "$W/fixed" >/dev/null 2>&1
$B map --backend cpu --cpu-loop scalar --quiet --set "$F" --out "$W/fixed_scalar" >/dev/null 2>&1
for m in rk4 imex; do
  M="integration.method=\"$m\""
  $B map --backend cpu --quiet --set "$A" --set "$M" --out "$W/adaptive_$m" >/dev/null 2>&1
  $B map --backend cpu --quiet --set "$A" --set "$M" "${T[@]}" --out "$W/tight_$m" >/dev/null 2>&1
done
$B map --backend cpu --quiet --set "$A" --set 'integration.method="rk4"' \
  --set integration.rtol=1e-5 --set integration.atol=1e-7 --out "$W/tighter_rk4" >/dev/null 2>&1
$B map configs/maps/default_subgrid.toml --backend cpu --quiet --set "$F" --out "$W/sub_fixed" >/dev/null 2>&1
$B map configs/maps/default_subgrid.toml --backend cpu --quiet --set "$A" --out "$W/sub_adaptive" \
  >/dev/null 2>&1
$B map configs/maps/default_subgrid.toml --backend cpu --quiet --set "$A" "${T[@]}" \
  --out "$W/sub_tight" >/dev/null 2>&1
"$PY" - "$W" > "$W/out.md" <<'PYEOF'
import json, sys, numpy as np
w = sys.argv[1]
def load(d):
    j = json.load(open(f"{w}/{d}/map.json"))
    return j, {k: np.load(f"{w}/{d}/{k}.npy") for k in ("K", "period")}
print("# Adaptive steps on maps\n")
print("Written by `benches/adaptive_maps.sh` on the CPU engine in f64: fixed steps on the SIMD loop "
      "and on the scalar loop; adaptive steps of both pairs in the SIMD lanes (each lane its own "
      "steps). One run each; wall times are the map's `timings_s.total_s`.\n")
print("## The default map (N = 3, 64 × 48)\n")
print("| steps | wall (s) | chaotic | periodic | regular | undecided | device |")
print("|---|---|---|---|---|---|---|")
names = {"fixed": "fixed (RK4, automatic step)", "fixed_scalar": "fixed (RK4, automatic step), scalar loop",
         "adaptive_rk4": "adaptive RK4(3), rtol 1e-3 / atol 1e-5",
         "tight_rk4": "adaptive RK4(3), rtol 1e-4 / atol 1e-6",
         "adaptive_imex": "adaptive IMEX, rtol 1e-3 / atol 1e-5",
         "tight_imex": "adaptive IMEX, rtol 1e-4 / atol 1e-6",
         "tighter_rk4": "adaptive RK4(3), rtol 1e-5 / atol 1e-7"}
runs = {d: load(d) for d in names}
for d, (j, _) in runs.items():
    c = j["regime"]["counts"]
    print(f"| {names[d]} | {j['timings_s']['total_s']:.1f} | {c['chaotic']} | {c['periodic']} | "
          f"{c['regular']} | {c['undecided']} | {j['adapter']} |")
wall = {d: j["timings_s"]["total_s"] for d, (j, _) in runs.items()}
loop = lambda m: "simd" if "simd" in runs[f"adaptive_{m}"][0]["adapter"] else "scalar"
same = lambda m: "fixed" if loop(m) == "simd" else "fixed_scalar"
print()
for m, label in (("rk4", "RK4(3)"), ("imex", "IMEX")):
    pa, pt = runs[f"adaptive_{m}"][1]["period"], runs[f"tight_{m}"][1]["period"]
    both = (pa > 0) & (pt > 0)
    print(f"- {label}: periods equal between the default tolerance and one 10× tighter on "
          f"{int((pa[both] == pt[both]).sum())} of the {int(both.sum())} cells periodic in both "
          f"({100 * (pa[both] == pt[both]).mean():.1f} %). Wall time against fixed steps on the same "
          f"loop ({loop(m)}): {wall[f'adaptive_{m}'] / wall[same(m)]:.2f}×; against the SIMD loop's "
          f"fixed steps: {wall[f'adaptive_{m}'] / wall['fixed']:.2f}×.")
pt, px = runs["tight_rk4"][1]["period"], runs["tighter_rk4"][1]["period"]
both = (pt > 0) & (px > 0)
print(f"- RK4(3) one step tighter again: periods equal between 10× and 100× tighter tolerances on "
      f"{int((pt[both] == px[both]).sum())} of the {int(both.sum())} cells periodic in both "
      f"({100 * (pt[both] == px[both]).mean():.1f} %).")
print()
print("## The 192-cell subgrid at N = 17 (`configs/maps/default_subgrid.toml`, K and period)\n")
(jf, f), (ja, a), (jt, t) = load("sub_fixed"), load("sub_adaptive"), load("sub_tight")
print("| steps | wall (s) | steps integrated (adaptive: base steps; its sub-steps are not counted) | device |")
print("|---|---|---|---|")
for name, j in (("fixed (IMEX, automatic step)", jf), ("adaptive, rtol 1e-3 / atol 1e-5", ja),
                ("adaptive, rtol 1e-4 / atol 1e-6", jt)):
    print(f"| {name} | {j['timings_s']['total_s']:.1f} | {j['steps']['integrated_instance_steps']:.3e} | {j['adapter']} |")
agree = lambda x, y: (100 * ((x["K"] > 0.5) == (y["K"] > 0.5)).mean(), 100 * (x["period"] == y["period"]).mean())
print("\n| runs compared | same K class | same period |")
print("|---|---|---|")
for name, x, y in (("fixed, adaptive", f, a), ("fixed, adaptive 10× tighter", f, t),
                   ("adaptive, adaptive 10× tighter", a, t)):
    k, p = agree(x, y)
    print(f"| {name} | {k:.1f} % | {p:.1f} % |")
print(f"\nWall time fixed / adaptive: {jf['timings_s']['total_s'] / ja['timings_s']['total_s']:.2f}× "
      f"(adaptive 10× tighter: {jf['timings_s']['total_s'] / jt['timings_s']['total_s']:.2f}×).")
PYEOF
mv "$W/out.md" "$OUT"
echo "wrote $OUT"
