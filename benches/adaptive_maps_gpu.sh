#!/usr/bin/env bash
# Adaptive steps on the default map (N = 3) on the GPU engine, whatever adapter there is
# (lavapipe without a GPU): fixed steps, then each pair at the default tolerances (RK4(3), which
# `auto` picks at N = 3, and IMEX). Regime counts and wall times. Then the upper half of the
# 192-cell subgrid at N = 17 (96 cells over 14 s, the pair benches/gpu_lease.sh times on a
# hardware GPU), fixed and adaptive (IMEX). About 6 minutes on lavapipe.
# Usage: benches/adaptive_maps_gpu.sh OUT.md   (needs numpy: PY=path/to/python)
set -euo pipefail
B=${PENDULUM_ATLAS:-target/release/pendulum-atlas}
PY=${PY:-python3}
OUT=${1:?output markdown}
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
A='integration.step="adaptive"'
$B map --backend gpu --quiet --set 'integration.step="fixed"' --out "$W/fixed" >/dev/null 2>&1
. "$(dirname "${BASH_SOURCE[0]}")/half17.sh"
for s in fixed adaptive; do
  $B map --backend gpu --quiet "${HALF17[@]}" --set "integration.step=\"$s\"" --out "$W/half17_$s" \
    >/dev/null 2>&1
done
for m in rk4 imex; do
  $B map --backend gpu --quiet --set "$A" --set "integration.method=\"$m\"" --out "$W/adaptive_$m" \
    >/dev/null 2>&1
done
"$PY" - "$W" > "$W/out.md" <<'PYEOF'
import json, sys
w = sys.argv[1]
runs = {d: json.load(open(f"{w}/{d}/map.json")) for d in ("fixed", "adaptive_rk4", "adaptive_imex")}
names = {"fixed": "fixed (RK4, automatic step)", "adaptive_rk4": "adaptive RK4(3), rtol 1e-3 / atol 1e-5",
         "adaptive_imex": "adaptive IMEX, rtol 1e-3 / atol 1e-5"}
print("# Adaptive steps on the default map, GPU engine\n")
print(f"Written by `benches/adaptive_maps_gpu.sh` on {runs['fixed']['adapter']}: the default map "
      "(N = 3, 64 × 48), each invocation its own steps. One run each; wall times are the map's "
      "`timings_s.total_s`.\n")
print("| steps | wall (s) | × fixed | chaotic | periodic | regular | undecided |")
print("|---|---|---|---|---|---|---|")
fixed = runs["fixed"]["timings_s"]["total_s"]
for d, j in runs.items():
    c, t = j["regime"]["counts"], j["timings_s"]["total_s"]
    print(f"| {names[d]} | {t:.1f} | {t / fixed:.2f} | {c['chaotic']} | {c['periodic']} | "
          f"{c['regular']} | {c['undecided']} |")
print("\nThe upper half of the 192-cell subgrid at N = 17 (`configs/maps/default_subgrid.toml`, "
      "f 8.06–11.6 Hz, 96 cells over 14 s with a 2 s transient; K and period), IMEX:\n")
print("| steps | wall (s) | × adaptive | cells with equal period (of those periodic in both) |")
print("|---|---|---|---|")
import numpy as np
half = {d: json.load(open(f"{w}/half17_{d}/map.json")) for d in ("fixed", "adaptive")}
p = {d: np.load(f"{w}/half17_{d}/period.npy") for d in half}
both = (p["fixed"] > 0) & (p["adaptive"] > 0)
same = int((p["fixed"][both] == p["adaptive"][both]).sum())
ta = half["adaptive"]["timings_s"]["total_s"]
for d in ("fixed", "adaptive"):
    t = half[d]["timings_s"]["total_s"]
    print(f"| {d} | {t:.1f} | {t / ta:.2f} | {same} of {int(both.sum())} |")
PYEOF
mv "$W/out.md" "$OUT"
echo "wrote $OUT"
