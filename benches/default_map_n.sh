#!/usr/bin/env bash
# The default map's N against N = 17 (issue 43's revisit, docs/bench/DEFAULT_MAP_N.md), on both
# 192-cell subgrids of the default plane: A, every 4th frequency and amplitude from the first
# (configs/maps/default_subgrid.toml), and B, every 4th from the third (the verdict study's
# second subgrid). N = 3, 5, 9 and 17 at the default (adaptive) steps, CPU engine; per N the
# cells whose K class (K > 0.5) and period equal N = 17's, and the wall time. About 1 minute
# on 2 cores.
# Usage: benches/default_map_n.sh OUT.md   (needs numpy: PY=path/to/python)
set -euo pipefail
B=${PENDULUM_ATLAS:-target/release/pendulum-atlas}
PY=${PY:-python3}
OUT=${1:?output markdown}
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
SUB=configs/maps/default_subgrid.toml
# Subgrid B: indices 2, 6, … of the default axes (f 4–12 Hz in 64, A 4–25 mm in 48).
AXES_B=$("$PY" -c '
f = [4.0 + 8.0 * i / 63 for i in range(2, 64, 4)]
a = [0.004 + 0.021 * j / 47 for j in range(2, 48, 4)]
print("map.axes=[{key=\"excitation.frequency_hz\",values=%r},{key=\"excitation.amplitude_m\",values=%r}]" % (f, a))')
for n in 3 5 9 17; do
  $B map "$SUB" --backend cpu --quiet --set beam.segments=$n --out "$W/A_$n" >/dev/null 2>&1
  $B map "$SUB" --backend cpu --quiet --set beam.segments=$n --set "$AXES_B" --out "$W/B_$n" \
    >/dev/null 2>&1
done
"$PY" - "$W" > "$W/out.md" <<'PYEOF'
import json, sys
import numpy as np
w = sys.argv[1]
print("# The default map's N on two subgrids\n")
print("Written by `benches/default_map_n.sh`: each N against N = 17 on subgrid A "
      "(`configs/maps/default_subgrid.toml`, every 4th frequency and amplitude of the default "
      "map from the first) and subgrid B (every 4th from the third), 192 cells each, adaptive "
      "steps at the default tolerances (RK4(3) at N = 3, IMEX from N = 5), CPU engine f64, "
      "one run each. K class: K > 0.5.\n")
print("| subgrid | N | K class as at N = 17 | period as at N = 17 | wall (s) |")
print("|---|---|---|---|---|")
for g in ("A", "B"):
    k17 = np.load(f"{w}/{g}_17/K.npy") > 0.5
    p17 = np.load(f"{w}/{g}_17/period.npy")
    cells = k17.size
    for n in (3, 5, 9, 17):
        k = np.load(f"{w}/{g}_{n}/K.npy") > 0.5
        p = np.load(f"{w}/{g}_{n}/period.npy")
        t = json.load(open(f"{w}/{g}_{n}/map.json"))["timings_s"]["total_s"]
        if n == 17:
            print(f"| {g} | 17 | (reference: {int(k17.sum())} of {cells} chaotic) | | {t:.1f} |")
            continue
        kc, pc = int((k == k17).sum()), int((p == p17).sum())
        print(f"| {g} | {n} | {kc} of {cells} ({100 * kc / cells:.1f} %) | "
              f"{pc} ({100 * pc / cells:.1f} %) | {t:.1f} |")
PYEOF
mv "$W/out.md" "$OUT"
echo "wrote $OUT"
