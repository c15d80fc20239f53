#!/bin/bash
# usage: rk4map.sh BIN N OUT DURATION METHOD FREQ_COUNT
exec $1 map --backend gpu --set beam.segments=$2 --set "integration.method=\"$5\"" --set 'integration.step="fixed"' --set integration.duration_s=$4 --set integration.transient_s=0.05 --set map.early_stop=false --set map.settle=false --set map.orbits=false --set map.transient_copies=0 --set 'map.metrics=["alpha_range","impacts_per_s"]' --set "map.axes=[{key=\"excitation.frequency_hz\",start=8.0,end=12.0,count=$6},{key=\"excitation.amplitude_m\",start=0.004,end=0.025,count=25}]" --quiet --force --out $3
