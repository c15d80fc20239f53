#!/usr/bin/env bash
# The IMEX method's finish and embedded error generated (after: /tmp/pa_imex) against the
# build before it (/tmp/pa_rules, 8e2d0c9): the five kinds of map on the CPU and on lavapipe,
# lavapipe's first compile of IMEX kernels (Mesa's shader cache off), and lavapipe throughput.
set -e
cd /work/main
out=docs/bench/gpu/lavapipe_imex_finish
scripts/same_maps.sh /tmp/pa_rules /tmp/pa_imex 2>&1 | tail -1 | sed 's/^/CPU same_maps: /'
BACKEND=gpu scripts/same_maps.sh /tmp/pa_rules /tmp/pa_imex 2>&1 | tail -3 | sed 's/^/GPU same_maps: /' || true
ax='map.axes=[{key="excitation.frequency_hz",values=[6.0,9.0]},{key="excitation.amplitude_m",values=[0.01,0.02]}]'
for side in old new; do
  bin=/tmp/pa_rules; [ $side = new ] && bin=/tmp/pa_imex
  MESA_SHADER_CACHE_DISABLE=true /usr/bin/time -f "$side N=64 fixed-step IMEX stress map: %e s, peak %M KB" \
    $bin map configs/stress/sixty_four_segments.toml --backend gpu --set 'integration.method="imex"' --set 'integration.step="fixed"' --quiet --force --out /tmp/i64_$side
  MESA_SHADER_CACHE_DISABLE=true /usr/bin/time -f "$side N=17 2x2 0.5 s adaptive IMEX map: %e s, peak %M KB" \
    $bin map --backend gpu --set beam.segments=17 --set 'integration.method="imex"' --set 'integration.step="adaptive"' \
    --set integration.duration_s=0.5 --set integration.transient_s=0.1 --set map.settle=false --set map.orbits=false \
    --set map.transient_copies=0 --set 'map.metrics=["alpha_range","impacts_per_s"]' --set "$ax" --quiet --force --out /tmp/i17_$side
done
for f in /tmp/i64_old/*.npy; do cmp -s "$f" /tmp/i64_new/$(basename $f) || echo "N=64 differs: $(basename $f)"; done
for f in /tmp/i17_old/*.npy; do cmp -s "$f" /tmp/i17_new/$(basename $f) || echo "N=17 adaptive differs: $(basename $f)"; done
for side in old new; do
  bin=/tmp/pa_rules; [ $side = new ] && bin=/tmp/pa_imex
  $bin bench --throughput --no-cpu --segments 3,9,17 --max-instances 10000 --row-budget-s 4 --out /tmp/tpi_$side --force >/dev/null
  cp /tmp/tpi_$side/GPU.md $out/GPU_$side.md
  cp /tmp/tpi_$side/gpu_throughput.json $out/gpu_throughput_$side.json
done
echo done
