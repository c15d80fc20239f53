#!/usr/bin/env bash
# Adaptive steps on the default map (N = 3) on the GPU engine, whatever adapter there is
# (lavapipe without a GPU): fixed steps, then each pair at the default tolerances (RK4(3), which
# `auto` picks at N = 3, and IMEX). Regime counts and wall times. About 2 minutes on lavapipe.
# Usage: benches/adaptive_maps_gpu.sh OUT.md   (needs numpy: PY=path/to/python)
set -euo pipefail
B=${PENDULUM_ATLAS:-target/release/pendulum-atlas}
PY=${PY:-python3}
OUT=${1:?output markdown}
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
A='integration.step="adaptive"'
$B map --backend gpu --quiet --set 'integration.step="fixed"' --out "$W/fixed" >/dev/null 2>&1
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
PYEOF
mv "$W/out.md" "$OUT"
echo "wrote $OUT"
