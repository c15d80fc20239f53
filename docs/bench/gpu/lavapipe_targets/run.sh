#!/usr/bin/env bash
# Issue 73's throughput targets, measured side by side on one machine (README.md here):
#  1. lavapipe throughput of the hand-written kernels (1a7506a, before the issue) against the
#     generated ones, N = 3, 9, 17, RK4 and IMEX: `bench --throughput` calls alternating
#     OLD, NEW, OLD, NEW (throughput.txt, GPU_*.md);
#  2. the CPU engine in f32 against lavapipe on the default map, one run of each after the
#     other (map.json's `throughput`), twice (maps.txt).
#
#   docs/bench/gpu/lavapipe_targets/run.sh OLD_BIN NEW_BIN OUT_DIR
#
# The paired whole-map runs (paired.txt) and the lanes' comparison (lanes.txt) time whole
# processes A B A B ... after a warm-up of each, the ratio taken pair by pair:
#   paired.txt: A = paired_map.sh NEW 3 /tmp/a 200 rk4 40, B = the same with OLD (and 50 imex;
#               paired_map.sh from ../lavapipe_imex_finish/), 4 pairs;
#   lanes.txt:  A = NEW map --backend cpu [--precision f32] --quiet --force --out /tmp/a,
#               B = the same with the build before the AVX-512 lanes, 3 pairs.
set -euo pipefail
old=$1 new=$2 out=$3
mkdir -p "$out"
tp=(bench --throughput --no-cpu --segments 3,9,17 --max-instances 10000 --row-budget-s 4 --force)
for round in 1 2; do
  for side in old new; do
    bin=${!side}
    /usr/bin/time -f "%e s" "$bin" "${tp[@]}" --out "$out/tp_${side}_$round" >"$out/tp_${side}_$round.log" 2>&1
  done
done
for round in 1 2; do
  "$new" map --backend cpu --precision f32 --quiet --force --out "$out/map_cpu32_$round"
  "$new" map --backend gpu --quiet --force --out "$out/map_gpu_$round"
done
