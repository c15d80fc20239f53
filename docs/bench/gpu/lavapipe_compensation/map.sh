#!/bin/bash
# usage: map.sh BIN OUT (the N = 3 plane on the GPU engine)
exec $1 map --backend gpu --set beam.segments=3 --set 'integration.step="fixed"' --set map.early_stop=false --set map.settle=false --set 'map.metrics=["K","R","period","hops","impacts_per_s","alpha_range"]' --set 'map.axes=[{key="excitation.frequency_hz",start=4.0,end=12.0,count=24},{key="excitation.amplitude_m",start=0.004,end=0.025,count=16}]' --quiet --force --out $2
