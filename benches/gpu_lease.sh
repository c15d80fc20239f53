#!/usr/bin/env bash
# Everything issue 16 measures on a hardware GPU, in as few device calls as possible.
#
# A lent GPU machine (the `device` tool) has CUDA, nvcc and JAX but no Rust toolchain and no
# package registry, and it may lack the Vulkan loader. So the kit is made here and carried:
#
#   benches/gpu_lease.sh prepare          # here: a portable release binary (x86-64-v3, not
#                                         # this CPU's `native`) and the Vulkan loader's .deb,
#                                         # into .gpu-kit/ (git-ignored, about 17 MB)
#   device run, carry [".gpu-kit"]:       # there, from the repository root:
#       benches/gpu_lease.sh run
#   benches/gpu_lease.sh unpack FILE      # here: the results into docs/bench/gpu/<adapter>/
#
# `run` checks that a hardware adapter is listed (not only llvmpipe), runs the GPU peers
# (benches/peers/run_gpu_peers.sh: the CUDA kernel and JAX on the same GPU) and then
# `bench --throughput --peers` (GPU rows only: the CPU rows are the committed lavapipe file's),
# then the default map (N = 17 and the grid a probe picks on a hardware GPU). Each step's log
# and results go under $OUT as they finish, so a call cut short still brings back what it had;
# the whole is one tarball, gpu_lease.tar.gz, plus GPU.md and the log to read at once.
# Budget: one call of under 10 minutes on an H100 (the study's rows are each bounded by
# --row-budget-s); give the call timeout_s 600.
#
# `run --dry` does the same plumbing on whatever adapter there is (lavapipe here) with a tiny
# study and no peers, to check the script without a GPU.
set -euo pipefail
cd "$(dirname "$0")/.."
kit=.gpu-kit

prepare() {
  grep -qx '/.gpu-kit/' .gitignore || { echo "add /.gpu-kit/ to .gitignore first" >&2; exit 2; }
  mkdir -p "$kit/gl"
  # RUSTFLAGS replaces .cargo/config.toml's target-cpu=native: the device's CPU may differ.
  RUSTFLAGS="-C target-cpu=x86-64-v3" CARGO_TARGET_DIR=target/portable \
    cargo build --release --bin pendulum-atlas
  cp target/portable/release/pendulum-atlas "$kit/pendulum-atlas"
  (cd "$kit/gl" && apt-get download libvulkan1)
  du -sh "$kit"
}

# The Vulkan loader from the kit when the machine has none, and NVIDIA's ICD where the
# driver mount keeps it.
vulkan_env() {
  if ! ldconfig -p | grep -q libvulkan.so.1; then
    for f in "$kit"/gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
  fi
  local icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  if [ -f "$icd" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
    export VK_DRIVER_FILES=$icd
  fi
}

run() {
  local dry=${1:-}
  local out=${OUT:-/tmp/gpu_lease_out}
  local work=/tmp/gpu_lease
  local bin=$kit/pendulum-atlas
  [ -x "$bin" ] || { echo "no $bin: run 'benches/gpu_lease.sh prepare' here and carry .gpu-kit" >&2; exit 2; }
  rm -rf "$work"; mkdir -p "$work" "$out"
  exec > >(tee "$out/log.txt") 2>&1
  [ -n "$dry" ] || vulkan_env
  export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg}; mkdir -p -m700 "$XDG_RUNTIME_DIR"
  echo "== machine"; nproc; (nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv || true)
  echo "== adapters"; "$bin" adapters | tee "$work/adapters.txt"
  if [ -z "$dry" ] && ! grep -q -v "software" "$work/adapters.txt"; then
    echo "no hardware adapter listed: Vulkan loader or ICD missing (see .library/device/README.md)" >&2
    exit 3
  fi
  local study=(--no-cpu --row-budget-s 30)
  local peers_rc=0
  if [ -n "$dry" ]; then
    study=(--no-cpu --segments 3 --max-instances 1000 --row-budget-s 5)
  else
    echo "== peers"
    SECONDS=0
    benches/peers/run_gpu_peers.sh docs/bench/cpu "$work/peers" || peers_rc=$?
    [ "$peers_rc" -eq 0 ] || echo "peers failed (rc $peers_rc): the study runs with what they wrote"
    rm -f "$work/peers/rk4_chain"
    echo "peers: ${SECONDS} s"
    study+=(--peers "$work/peers")
  fi
  echo "== bench --throughput ${study[*]}"
  SECONDS=0
  "$bin" bench --throughput "${study[@]}" --out "$work/gpu" --force
  echo "study: ${SECONDS} s"
  cp "$work/gpu/GPU.md" "$out/GPU.md"
  tar -czf "$out/gpu_lease.tar.gz" -C "$work" .
  echo "== default map"
  SECONDS=0
  if [ -n "$dry" ]; then
    "$bin" map --set 'map.axes=[{key="excitation.frequency_hz",start=11.0,end=12.0,count=4},{key="excitation.amplitude_m",start=0.004,end=0.025,count=4}]' \
      --backend gpu --out "$work/map" --force
  else
    "$bin" map --backend gpu --out "$work/map" --force
  fi
  echo "default map: ${SECONDS} s"
  rm -f "$work/map"/*.npy
  tar -czf "$out/gpu_lease.tar.gz" -C "$work" .
  ls -la "$out"
  if [ "$peers_rc" -ne 0 ]; then
    echo "the peers failed (rc $peers_rc); everything else was written" >&2
    exit 4
  fi
}

unpack() {
  local file=${1:?the gpu_lease.tar.gz a run brought back}
  local tmp; tmp=$(mktemp -d)
  tar -xzf "$file" -C "$tmp"
  local name; name=$(sed -n 's/^# Ensemble throughput on //p' "$tmp/gpu/GPU.md" | head -1)
  local slug; slug=$(echo "$name" | tr '[:upper:]' '[:lower:]' | tr -cs 'a-z0-9' '-' | sed 's/^-//; s/-$//')
  local dest=docs/bench/gpu/$slug
  mkdir -p "$dest"
  cp -r "$tmp/gpu/." "$dest/"
  [ -d "$tmp/peers" ] && cp -r "$tmp/peers" "$dest/peers"
  [ -d "$tmp/map" ] && cp "$tmp/map/map.json" "$dest/default_map.json"
  cp "$tmp/adapters.txt" "$dest/adapters.txt"
  rm -rf "$tmp"
  echo "results in $dest"
}

case "${1:-}" in
  prepare) prepare ;;
  run) run "${2:+dry}" ;;
  unpack) unpack "${2:-}" ;;
  *) echo "usage: benches/gpu_lease.sh prepare | run [--dry] | unpack FILE" >&2; exit 2 ;;
esac
