#!/bin/bash
# The cells of a map folder whose own stable orbit's least period differs from the period
# detector's (docs/bench/ORBITS.md): each run alone for 1000 s at fixed 1e-4 s steps from the
# scene's start, without the orbit stage, and its period printed beside the map's and the orbit's.
#   benches/orbits_period_check.sh MAP_FOLDER_BEFORE_THE_CORRECTION
# The folder must come from a build that did not yet correct the period (or pass any folder:
# with the correction in, `period` equals `orbit_period` and no cell is listed).
set -euo pipefail
dir=${1:-runs/map}
bin=${PENDULUM_ATLAS_BIN:-target/release/pendulum-atlas}
python3 - "$dir" <<'PY' | while read -r f a p q; do
import sys
import numpy as np
d = sys.argv[1]
per, op, st = (np.load(f"{d}/{n}.npy") for n in ("period", "orbit_period", "orbit_status"))
a0, a1 = np.load(f"{d}/axis0.npy"), np.load(f"{d}/axis1.npy")
for i, j in zip(*np.nonzero((st == 0) & (op != per))):
    print(repr(float(a0[i])), repr(float(a1[j])), int(per[i, j]), int(op[i, j]))
PY
  out=$(mktemp -d)
  "$bin" map --backend cpu --quiet --force --out "$out" \
    --set "map.axes=[{key=\"excitation.frequency_hz\",values=[$f]},{key=\"excitation.amplitude_m\",values=[$a]}]" \
    --set integration.duration_s=1000 --set integration.transient_s=976 --set map.settle=false \
    --set map.early_stop=false --set map.orbits=false --set integration.step=fixed \
    --set integration.dt_s=1e-4 >/dev/null
  fixed=$(python3 -c "import numpy as np; print(int(np.load('$out/period.npy').ravel()[0]))")
  echo "$f Hz $a m: map $p, orbit $q, fixed 1e-4 s over 1000 s: $fixed"
  rm -rf "$out"
done
