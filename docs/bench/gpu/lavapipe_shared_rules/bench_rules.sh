#!/usr/bin/env bash
# The kernels before the shared rules (2790600 build, /tmp/pa_new) against after (/tmp/pa_rules)
# on lavapipe: throughput one call each, then the default map's settings (adaptive RK4, early
# stop, settling, transient copies, verdict) at 24 x 16 cells on the GPU with each build, every
# .npy compared byte for byte.
set -e
cd /work/main
out=docs/bench/gpu/lavapipe_shared_rules
for side in old new; do
  bin=/tmp/pa_new; [ $side = new ] && bin=/tmp/pa_rules
  $bin bench --throughput --no-cpu --segments 3,9,17 --max-instances 10000 --row-budget-s 4 --out /tmp/tp_rules_$side --force >/dev/null
  cp /tmp/tp_rules_$side/GPU.md $out/GPU_$side.md
  cp /tmp/tp_rules_$side/gpu_throughput.json $out/gpu_throughput_$side.json
done
ax='map.axes=[{key="excitation.frequency_hz",start=4.0,end=12.0,count=24},{key="excitation.amplitude_m",start=0.004,end=0.025,count=16}]'
for side in old new; do
  bin=/tmp/pa_new; [ $side = new ] && bin=/tmp/pa_rules
  /usr/bin/time -f "$side default-settings map 24x16 on lavapipe: %e s" \
    $bin map --backend gpu --set "$ax" --quiet --force --out /tmp/rules_maps/$side
done
same=0; differ=0
for f in /tmp/rules_maps/old/*.npy; do
  b=$(basename "$f")
  if cmp -s "$f" "/tmp/rules_maps/new/$b"; then same=$((same+1)); else differ=$((differ+1)); echo "differs: $b"; fi
done
echo "npy files: $same the same, $differ different"
