#!/usr/bin/env bash
# Old (db7da84 build, /tmp/pa_head) against new (/tmp/pa_new): kernel compile + run with the
# Mesa shader cache off, then lavapipe throughput.
# The last line of compile_and_maps.log (the build that writes the RK4 functions as a loop above
# N = 24, 2790600) is the first command of the loop below, run by hand with that build as /tmp/pa_loop.
set -e
cd /work/main
ax='map.axes=[{key="excitation.frequency_hz",values=[6.0,9.0]},{key="excitation.amplitude_m",values=[0.01,0.02]}]'
for side in old new; do
  bin=/tmp/pa_head; [ $side = new ] && bin=/tmp/pa_new
  MESA_SHADER_CACHE_DISABLE=true /usr/bin/time -f "$side N=64 RK4 stress map (the scene's adaptive steps): %e s, peak %M KB" \
    $bin map configs/stress/sixty_four_segments.toml --backend gpu --set 'integration.method="rk4"' --quiet --force --out /tmp/c64_$side
  MESA_SHADER_CACHE_DISABLE=true /usr/bin/time -f "$side N=17 2x2 0.5 s adaptive RK4 map: %e s, peak %M KB" \
    $bin map --backend gpu --set beam.segments=17 --set 'integration.method="rk4"' --set 'integration.step="adaptive"' \
    --set integration.duration_s=0.5 --set integration.transient_s=0.1 --set map.settle=false --set map.orbits=false \
    --set map.transient_copies=0 --set 'map.metrics=["alpha_range","impacts_per_s"]' --set "$ax" --quiet --force --out /tmp/c17_$side
done
for side in old new; do
  bin=/tmp/pa_head; [ $side = new ] && bin=/tmp/pa_new
  $bin bench --throughput --no-cpu --segments 3,9,17 --max-instances 10000 --row-budget-s 4 --out /tmp/tp_$side --force >/dev/null
done
echo done
# Agreement of the maps: N = 3, fixed RK4, 24 x 16 cells (GENERATED_KERNELS.md, "Agreement of the maps").
args=(--set beam.segments=3 --set 'integration.method="rk4"' --set 'integration.step="fixed"' --set map.early_stop=false
  --set map.settle=false --set map.orbits=false --set map.transient_copies=0
  --set 'map.metrics=["K","R","period","hops","impacts_per_s","alpha_range"]'
  --set 'map.axes=[{key="excitation.frequency_hz",start=4.0,end=12.0,count=24},{key="excitation.amplitude_m",start=0.004,end=0.025,count=16}]'
  --quiet --force)
/tmp/pa_head map --backend gpu "${args[@]}" --out /tmp/cmpmaps/old
/tmp/pa_new map --backend gpu "${args[@]}" --out /tmp/cmpmaps/new
/tmp/pa_new map --backend cpu --precision f32 "${args[@]}" --out /tmp/cmpmaps/cpu32
/tmp/pyvenv/bin/python benches/kernels_agree.py /tmp/cmpmaps old new
/tmp/pyvenv/bin/python benches/kernels_agree.py /tmp/cmpmaps old cpu32
/tmp/pyvenv/bin/python benches/kernels_agree.py /tmp/cmpmaps new cpu32
echo maps done
