#!/usr/bin/env bash
# Run the JAX CPU peer at N = 3, 9, 17 in the researcher and tuned variants and both precisions,
# and the cramer variant (N = 3 only) in both precisions, 1024 instances each, on the cases
# `pendulum-atlas bench --cpu-throughput` wrote. Usage:
#   benches/peers/run_cpu_peers.sh CASES_DIR OUT_DIR [PYTHON]
# then pass OUT_DIR to `pendulum-atlas bench --cpu-throughput --peers OUT_DIR`.
set -euo pipefail
cases=${1:?folder with peer_case_N*.json}
out=${2:?folder for the jax_*.json results}
py=${3:-/tmp/peer-venv/bin/python}
here=$(dirname "$0")
mkdir -p "$out"
# Steps per N: enough for a stable median, few enough that the researcher variant at N = 17
# (dense solves) takes seconds.
for spec in 3:2000 9:500 17:200; do
  n=${spec%%:*}; steps=${spec##*:}
  for variant in tuned researcher; do
    for precision in f64 f32; do
      "$py" "$here/jax_cpu.py" --case "$cases" --segments "$n" --instances 1024 --steps "$steps" \
        --precision "$precision" --variant "$variant" --repeat 3 \
        --json "$out/jax_${variant}_${precision}_N${n}.json"
    done
  done
done
# The hand-tuned dense peer: Cramer's rule for the 3x3 solve, the batch split over every core.
# It exists at N = 3 only (jax_cpu.py refuses --variant cramer at other N, exit status 2).
for precision in f64 f32; do
  "$py" "$here/jax_cpu.py" --case "$cases" --segments 3 --instances 1024 --steps 2000 \
    --precision "$precision" --variant cramer --repeat 3 \
    --json "$out/jax_cramer_${precision}_N3.json"
done
