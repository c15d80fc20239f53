#!/usr/bin/env bash
# Run by hand with /tmp/pa_rules (old) and /tmp/pa_imex (imex_finish.diff applied) built.
# CPU IMEX maps at N = 9, f64 and f32, fixed and adaptive steps, old (/tmp/pa_rules) and new (/tmp/pa_imex).
ax='map.axes=[{key="excitation.frequency_hz",start=5.0,end=11.0,count=4},{key="excitation.amplitude_m",start=0.006,end=0.02,count=3}]'
same=0; differ=0
for prec in f64 f32; do for step in fixed adaptive; do
  for side in old new; do
    bin=/tmp/pa_rules; [ $side = new ] && bin=/tmp/pa_imex
    $bin map --backend cpu --precision $prec --set beam.segments=9 --set 'integration.method="imex"' --set "integration.step=\"$step\"" \
      --set integration.duration_s=22 --set integration.transient_s=2 --set "$ax" --quiet --force --out /tmp/ci_${prec}_${step}_$side >/dev/null 2>&1
  done
  for f in /tmp/ci_${prec}_${step}_old/*.npy; do
    if cmp -s "$f" /tmp/ci_${prec}_${step}_new/$(basename $f); then same=$((same+1)); else differ=$((differ+1)); echo "differs: $prec $step $(basename $f)"; fi
  done
done; done
echo "CPU IMEX maps N = 9: $same .npy the same, $differ different"
