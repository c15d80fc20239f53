#!/usr/bin/env bash
# Everything issue 16 measures on a hardware GPU, in as few device calls as possible.
#
# A lent GPU machine (the `device` tool) has CUDA, nvcc and JAX but no Rust toolchain and no
# package registry, and it may lack the Vulkan loader. So the kit is made here and carried:
#
#   benches/gpu_lease.sh prepare          # here: a portable release binary (x86-64-v3, not
#                                         # this CPU's `native`) and the Vulkan loader's .deb,
#                                         # into .gpu-kit/ (git-ignored, about 40 MB); and the
#                                         # same binary of BASE_REV (default 1a7506a, the last
#                                         # hand-written kernels; BASE_REV= for none), whose
#                                         # study `run` repeats last, side by side (issue 73)
#   device run, carry [".gpu-kit"]:       # there, from the repository root:
#       benches/gpu_lease.sh run
#   benches/gpu_lease.sh unpack FILE      # here: the results into docs/bench/gpu/<adapter>/
#
# `run` checks that a hardware adapter is listed (not only llvmpipe), runs the default map as
# the README runs it (auto backend: what the hardware probe picks), then `bench --throughput`
# at N = 3, 9 and 17, RK4 and IMEX, 10^3 to 10^6 instances (GPU rows only, each within 6 s;
# kernel time from the device's clock beside wall time), the N = 17 default plane (34 s,
# adaptive steps, lambda1 and the regime, raw as issue 58's target reads it), the map as
# written (N = 3, 64 x 48) on the GPU and on the CPU engine for parity, the same map at fixed
# steps without lambda1 and the early stop, and last the GPU peers (benches/peers/run_gpu_peers.sh: the CUDA kernel and JAX on
# the same GPU, at most 80 s).
# Last, where the kit has the base build, its own throughput study at N = 3 and 17 (GPU_base.md,
# 60 s at most), so the kernels before and after a change are measured on the same device.
# Each step is bounded by `timeout` (575 s in all, 635 s with the base study); its log and results go under $OUT as they
# finish, so a call cut short still brings back what it had: one tarball, gpu_lease.tar.gz,
# plus GPU.md, AGREEMENT.md (benches/kernels_agree.py: GPU against CPU held against each other,
# where numpy is) and the log to read at once.
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
  # The base build first, so that target/portable is left with this checkout's.
  local base_rev=${BASE_REV-1a7506a}
  if [ -n "$base_rev" ]; then
    local tree
    tree=$(mktemp -d)
    git worktree add -q --detach "$tree/base" "$base_rev"
    RUSTFLAGS="-C target-cpu=x86-64-v3" CARGO_TARGET_DIR=target/portable \
      cargo build --release --bin pendulum-atlas --manifest-path "$tree/base/Cargo.toml"
    cp target/portable/release/pendulum-atlas "$kit/pendulum-atlas-base"
    git worktree remove --force "$tree/base"
    echo "$base_rev" > "$kit/base_rev.txt"
  else
    rm -f "$kit/pendulum-atlas-base" "$kit/base_rev.txt"
  fi
  # RUSTFLAGS replaces .cargo/config.toml's target-cpu=native: the device's CPU may differ.
  RUSTFLAGS="-C target-cpu=x86-64-v3" CARGO_TARGET_DIR=target/portable \
    cargo build --release --bin pendulum-atlas
  cp target/portable/release/pendulum-atlas "$kit/pendulum-atlas"
  # The Vulkan loader and the GL dispatch libraries NVIDIA's ICD (libGLX_nvidia) loads.
  (cd "$kit/gl" && apt-get download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
  du -sh "$kit"
}

# The Vulkan loader from the kit when the machine has none, and NVIDIA's ICD where the
# driver mount keeps it.
vulkan_env() {
  for f in "$kit"/gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
  local icd
  for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json \
    /usr/share/vulkan/icd.d/nvidia_icd.json /etc/vulkan/icd.d/nvidia_icd.json; do
    if [ -f "$icd" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
      export VK_DRIVER_FILES=$icd
    fi
  done
  local egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
  [ -f "$egl" ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$egl
  echo "VK_DRIVER_FILES=${VK_DRIVER_FILES:-unset}"
}

# One step's output into the tarball as soon as it is written, so a call cut short still
# brings back what it had.
pack() { tar -czf "$out/gpu_lease.tar.gz" -C "$work" . ; }

# The start every lease mode shares: the output folders, the log, the Vulkan loader (not for
# a dry run), the machine and its adapters. Sets out, work and bin.
setup() {
  local dry=${1:-}
  out=${OUT:-/tmp/gpu_lease_out}
  work=${GPU_LEASE_WORK:-/tmp/gpu_lease}
  # PENDULUM_ATLAS_KIT_BIN: another binary (the test of `run --dry` passes the one cargo built).
  bin=${PENDULUM_ATLAS_KIT_BIN:-$kit/pendulum-atlas}
  # PENDULUM_ATLAS_KIT_BASE: the base build (`prepare` makes one; the dry test passes its own).
  base_bin=${PENDULUM_ATLAS_KIT_BASE:-$kit/pendulum-atlas-base}
  [ -x "$bin" ] || { echo "no $bin: run 'benches/gpu_lease.sh prepare' here and carry .gpu-kit" >&2; exit 2; }
  rm -rf "$work"; mkdir -p "$work" "$out"
  exec > >(tee "$out/log.txt") 2>&1
  [ -n "$dry" ] || vulkan_env
  export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg}; mkdir -p -m700 "$XDG_RUNTIME_DIR"
  echo "== machine"; nproc; (nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv || true)
  echo "== adapters"; "$bin" adapters | tee "$work/adapters.txt"
}

run() {
  local dry=${1:-}
  setup "$dry"
  if [ -z "$dry" ] && ! grep -q -v "software" "$work/adapters.txt"; then
    echo "no hardware adapter listed: Vulkan loader or ICD missing (see .library/device/README.md)" >&2
    exit 3
  fi
  local small=(--set 'map.axes=[{key="excitation.frequency_hz",start=11.0,end=12.0,count=4},{key="excitation.amplitude_m",start=0.004,end=0.025,count=4}]')
  # Order: what the lease is for first, the peers last; each step is bounded by `timeout`.
  echo "== default map (as the README runs it)"
  SECONDS=0
  if [ -n "$dry" ]; then
    "$bin" map "${small[@]}" --out "$work/map" --force
  else
    timeout 45 "$bin" map --out "$work/map" --force || echo "default map: rc $?"
  fi
  echo "default map: ${SECONDS} s"
  rm -f "$work/map"/*.npy "$work/map"/*.csv
  pack
  # The occupancy sweep: 10^3 to 10^6 instances at N = 3, 9, 17, RK4 and IMEX.
  local study=(--no-cpu --segments 3,9,17 --row-budget-s 6)
  [ -z "$dry" ] || study=(--no-cpu --segments 3 --max-instances 1000 --row-budget-s 2)
  echo "== bench --throughput ${study[*]}"
  SECONDS=0
  timeout 200 "$bin" bench --throughput "${study[@]}" --out "$work/gpu" --force || echo "study: rc $?"
  echo "study: ${SECONDS} s"
  [ -f "$work/gpu/GPU.md" ] && cp "$work/gpu/GPU.md" "$out/GPU.md"
  pack
  # The N = 17 default plane: 64 x 48 cells, 34 s, adaptive steps, lambda1 and the regime.
  echo "== N = 17 default plane"
  local plane=(--set beam.segments=17 --set map.settle=false)
  # --dry: the plumbing only (N = 17 on a software adapter takes minutes even on 16 cells).
  [ -z "$dry" ] || plane=(--set beam.segments=3 --set map.settle=false "${small[@]}")
  SECONDS=0
  timeout 80 "$bin" map --backend gpu "${plane[@]}" --out "$work/plane17_thread" --force \
    || echo "N = 17 plane: rc $?"
  echo "N = 17 plane: ${SECONDS} s"
  rm -f "$work"/plane17_*/*.png "$work"/plane17_*/*.csv
  pack
  # Parity on this hardware: the map as written (N = 3, 64 x 48) on the GPU and on the CPU
  # engine in f64; their .npy files come back to be compared cell by cell.
  echo "== parity maps"
  local parity=(--set beam.segments=3)
  [ -z "$dry" ] || parity+=("${small[@]}")
  SECONDS=0
  timeout 20 "$bin" map --backend gpu "${parity[@]}" --out "$work/parity_gpu" --force \
    || echo "parity map (GPU): rc $?"
  echo "parity map, GPU: ${SECONDS} s"
  SECONDS=0
  timeout 30 "$bin" map --backend cpu "${parity[@]}" --out "$work/parity_cpu" --force \
    || echo "parity map (CPU): rc $?"
  echo "parity map, CPU f64: ${SECONDS} s"
  # Fixed steps, no lambda1, no early stop: the integration alone.
  local fixed=(--set 'integration.step="fixed"' --set map.early_stop=false
    --set 'map.metrics=["K","R","period","hops","impacts_per_s","alpha_range"]')
  SECONDS=0
  timeout 20 "$bin" map --backend gpu "${parity[@]}" "${fixed[@]}" \
    --out "$work/parity_fixed_thread" --force || echo "fixed-step map: rc $?"
  echo "fixed-step map: ${SECONDS} s"
  rm -f "$work"/parity_*/*.png "$work"/parity_*/*.csv
  pack
  local peers_rc=0
  if [ -z "$dry" ]; then
    echo "== peers (at most 80 s)"
    SECONDS=0
    timeout 80 benches/peers/run_gpu_peers.sh docs/bench/cpu "$work/peers" || peers_rc=$?
    [ "$peers_rc" -eq 0 ] || echo "peers failed (rc $peers_rc): what they wrote comes back"
    rm -f "$work/peers/rk4_chain"
    echo "peers: ${SECONDS} s"
    pack
  fi
  # The maps held against each other (GPU against CPU), where numpy
  # is (JAX's machine has it; otherwise run the script on the unpacked folder).
  if python3 -c "import numpy" 2>/dev/null; then
    # (Into a temporary file first: a report cut short is not left as AGREEMENT.md.)
    if python3 benches/kernels_agree.py "$work" > "$work/agreement.tmp"; then
      mv "$work/agreement.tmp" "$work/AGREEMENT.md"
      cp "$work/AGREEMENT.md" "$out/AGREEMENT.md"
      cat "$work/AGREEMENT.md"
      pack
    else
      echo "agreement: rc $?"
    fi
  else
    echo "agreement: no numpy here; benches/kernels_agree.py DIR on the unpacked folder"
  fi
  base_study "$dry"
  ls -la "$out"
  if [ "$peers_rc" -ne 0 ]; then
    echo "the peers failed (rc $peers_rc); everything else was written" >&2
    exit 4
  fi
}

# The base build's throughput at N = 3 and 17 (GPU_base.md beside GPU.md), where the kit has
# one: the same rows on the same device before and after a change of the kernels.
base_study() {
  local dry=${1:-}
  if [ ! -x "$base_bin" ]; then
    echo "== no base build in the kit ($base_bin): only this build was measured"
    return
  fi
  local study=(--no-cpu --segments 3,17 --row-budget-s 2)
  [ -z "$dry" ] || study=(--no-cpu --segments 3 --max-instances 1000 --row-budget-s 1)
  echo "== base build $(cat "$kit/base_rev.txt" 2>/dev/null || echo "$base_bin"): bench --throughput ${study[*]}"
  SECONDS=0
  timeout 60 "$base_bin" bench --throughput "${study[@]}" --out "$work/gpu_base" --force \
    || echo "base study: rc $?"
  echo "base study: ${SECONDS} s"
  [ -f "$work/gpu_base/GPU.md" ] && cp "$work/gpu_base/GPU.md" "$out/GPU_base.md"
  pack
}

# A short second call: the default map as the README runs it (auto backend, the hardware
# probe's choice printed) and the N = 17 rows of the study, with the peers of an earlier call.
followup() {
  out=${OUT:-/tmp/gpu_lease_out}
  work=/tmp/gpu_lease
  local bin=$kit/pendulum-atlas peers=${1:?folder of the peers an earlier call wrote}
  rm -rf "$work"; mkdir -p "$work" "$out"
  exec > >(tee "$out/log.txt") 2>&1
  vulkan_env
  export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg}; mkdir -p -m700 "$XDG_RUNTIME_DIR"
  echo "== default map (auto)"
  SECONDS=0
  timeout 90 "$bin" map --out "$work/map" --force || echo "default map: rc $?"
  echo "default map: ${SECONDS} s"
  rm -f "$work/map"/*.npy "$work/map"/*.csv "$work/map"/*.png
  pack
  echo "== bench --throughput N = 17"
  SECONDS=0
  timeout 150 "$bin" bench --throughput --no-cpu --segments 17 --row-budget-s 6 --peers "$peers" \
    --out "$work/gpu" --force || echo "study: rc $?"
  echo "study: ${SECONDS} s"
  pack
}

# HALF17: the default subgrid's upper half at N = 17.
. "$(dirname "${BASH_SOURCE[0]}")/half17.sh"

# Issue 43 on a hardware GPU, in one call: fixed against adaptive steps on the GPU engine, the
# default map (N = 3) at both steps and at a 10x tighter tolerance, the 192-cell subgrid at
# N = 17 (configs/maps/default_subgrid.toml) at both steps and tighter, and the whole default
# plane adaptive at N = 9 and 17. Each map keeps its map.json and grid.csv; `adaptive.txt`
# lists the wall time of each. Compare locally with benches/adaptive_gpu.py.
adaptive() {
  local dry=${1:-}
  setup "$dry"
  local ad=(--set 'integration.step="adaptive"')
  local tight=("${ad[@]}" --set integration.rtol=1e-4 --set integration.atol=1e-6)
  local half=("${HALF17[@]}")
  local small=()
  # --dry: a 4 x 4 corner, to check the plumbing on lavapipe
  [ -z "$dry" ] || small=(--set 'map.axes=[{key="excitation.frequency_hz",start=11.0,end=12.0,count=4},{key="excitation.amplitude_m",start=0.004,end=0.025,count=4}]')
  one() {  # name, timeout (s), then the map's arguments
    local name=$1 limit=$2; shift 2
    [ -z "$dry" ] || limit=20
    SECONDS=0
    local rc=0
    timeout "$limit" "$bin" map --backend gpu "$@" "${small[@]}" --out "$work/$name" --force || rc=$?
    echo "$name: ${SECONDS} s (rc $rc, limit $limit s)" | tee -a "$work/adaptive.txt"
    rm -f "$work/$name"/*.png
    pack
  }
  # Most wanted first; the limits add up to 560 s (give the call timeout_s 600). The N = 17
  # half subgrid (96 cells, 14 s) is the pair to compare; the whole plane at N = 17 is the
  # issue's "a few minutes".
  local sub=configs/maps/default_subgrid.toml
  local fixed=(--set 'integration.step="fixed"')
  one n3_fixed 20 --set beam.segments=3 "${fixed[@]}"
  one n3_adaptive 40 --set beam.segments=3 "${ad[@]}"
  one n3_adaptive_imex 40 --set beam.segments=3 "${ad[@]}" --set 'integration.method="imex"'
  one half17_adaptive 100 "${half[@]}" "${ad[@]}"
  one half17_fixed 80 "${half[@]}" "${fixed[@]}"
  one full17_adaptive 150 --set beam.segments=17 "${ad[@]}"
  one n3_tight 40 --set beam.segments=3 "${tight[@]}"
  one sub17_adaptive 90 "$sub" --set beam.segments=17 "${ad[@]}"
  cp "$work/adaptive.txt" "$out/adaptive.txt"
  ls -la "$out"
}

# A second, shorter call when N = 17 does not finish in the first: the subgrid's upper half
# (f 8.06-11.6 Hz, 8 x 12 = 96 cells) over 14 s with a 2 s transient (96 stroboscopic samples
# at 8 Hz), fixed and adaptive, each within 150 s.
adaptive17() {
  setup
  local half=("${HALF17[@]}")
  local name rc
  for name in half17_adaptive half17_fixed; do
    local extra=(--set 'integration.step="fixed"')
    [ "$name" = half17_adaptive ] && extra=(--set 'integration.step="adaptive"')
    SECONDS=0; rc=0
    timeout 150 "$bin" map --backend gpu "${half[@]}" "${extra[@]}" --out "$work/$name" --force || rc=$?
    echo "$name: ${SECONDS} s (rc $rc, limit 150 s)" | tee -a "$work/adaptive.txt"
    rm -f "$work/$name"/*.png
    pack
  done
}

unpack() {
  local file=${1:?the gpu_lease.tar.gz a run brought back}
  local tmp; tmp=$(mktemp -d)
  tar -xzf "$file" -C "$tmp"
  local report; report=$(ls "$tmp"/gpu*/GPU.md | head -1)
  local name; name=$(sed -n 's/^# Ensemble throughput on //p' "$report" | head -1 | sed 's/ \[.*//')
  local slug; slug=$(echo "$name" | tr '[:upper:]' '[:lower:]' | tr -cs 'a-z0-9' '-' | sed 's/^-//; s/-$//')
  local dest=docs/bench/gpu/$slug
  mkdir -p "$dest"
  for d in "$tmp"/gpu*/; do cp -r "$d" "$dest/$(basename "$d")"; done
  [ -d "$tmp/peers" ] && cp -r "$tmp/peers" "$dest/peers"
  [ -d "$tmp/map" ] && cp "$tmp/map/map.json" "$dest/default_map.json"
  [ -f "$tmp/AGREEMENT.md" ] && cp "$tmp/AGREEMENT.md" "$dest/AGREEMENT.md"
  for d in "$tmp"/plane17_*/ "$tmp"/parity_*/; do
    [ -d "$d" ] && cp -r "$d" "$dest/$(basename "$d")"
  done
  cp "$tmp/adapters.txt" "$dest/adapters.txt"
  find "$dest" -name .pendulum-atlas.lock -delete   # the run's folder locks, not results
  rm -rf "$tmp"
  echo "results in $dest"
}

case "${1:-}" in
  prepare) prepare ;;
  run) run "${2:+dry}" ;;
  followup) followup "${2:-}" ;;
  adaptive) adaptive "${2:+dry}" ;;
  adaptive17) adaptive17 ;;
  unpack) unpack "${2:-}" ;;
  *) echo "usage: benches/gpu_lease.sh prepare | run [--dry] | adaptive [--dry] | unpack FILE" >&2; exit 2 ;;
esac
