#!/usr/bin/env bash
# Run the GPU peers at N = 3, 9, 17 on the cases `pendulum-atlas bench --cpu-throughput` wrote
# (docs/bench/cpu/ holds them): the CUDA kernel (built here with nvcc for the local GPU) and
# JAX (researcher and tuned variants) on the same GPU, f32, 100 000 instances. Usage:
#   benches/peers/run_gpu_peers.sh CASES_DIR OUT_DIR [PYTHON]
# then pass OUT_DIR to `pendulum-atlas bench --throughput --peers OUT_DIR`.
set -euo pipefail
cases=${1:?folder with peer_case_N*.json}
out=${2:?folder for the jax_gpu_*.json and cuda_*.json results}
py=${3:-python3}
here=$(dirname "$0")
mkdir -p "$out"
nvcc -O3 -arch=native -o "$out/rk4_chain" "$here/cuda/rk4_chain.cu"
for spec in 3:2000 9:500 17:200; do
  n=${spec%%:*}; steps=${spec##*:}
  "$py" "$here/cuda/run_cuda_peer.py" --binary "$out/rk4_chain" --case "$cases" --segments "$n" \
    --instances 100000 --steps "$steps" --repeat 3 --json "$out/cuda_rk4_N${n}.json"
  for variant in tuned researcher; do
    "$py" "$here/jax_gpu.py" --case "$cases" --segments "$n" --instances 100000 \
      --steps "$steps" --variant "$variant" --repeat 3 --json "$out/jax_gpu_${variant}_N${n}.json"
  done
done
