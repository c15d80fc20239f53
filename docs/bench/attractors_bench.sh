B=${PENDULUM_ATLAS:-target/release/pendulum-atlas}
run() { # backend cells_f cells_a starts out
  COMMON="--backend $1 --quiet --force --set beam.segments=3 --set integration.duration_s=40 --set integration.transient_s=15 --set map.early_stop=false"
  AX2="{key=\"excitation.frequency_hz\",start=5.0,end=12.0,count=$2},{key=\"excitation.amplitude_m\",start=0.002,end=0.02,count=$3}"
  $B map $COMMON --out A_$1 --set "map.axes=[$AX2]" --set map.initial_states=$4 >/dev/null 2>&1
  $B map $COMMON --out B_$1 --set "map.axes=[$AX2,{key=\"limiter.stiffness_n_per_m\",start=10000.0,end=10000.0001,count=$4}]" --set 'map.metrics=["K","period","lyapunov","regime","alpha_range","hops"]' >/dev/null 2>&1
  python3 -c "
import json
a=json.load(open('A_$1/map.json')); b=json.load(open('B_$1/map.json'))
ea=a['timings_s']['integrate_s']+a['timings_s']['reduce_s']; eb=b['timings_s']['integrate_s']+b['timings_s']['reduce_s']
print('$1', a['attractors']['runs']['runs'], b['instances'], 'engine_with', round(ea,3), 'engine_without', round(eb,3), 'stage', a['timings_s']['attractors_s'], 'ratio', round(ea/eb,4), 'families', a['attractors']['labels'], 'device', a['adapter'])"
}
for i in 1 2 3; do run cpu 16 12 16; done
for i in 1 2 3; do run gpu 8 6 8; done
