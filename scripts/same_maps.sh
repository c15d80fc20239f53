#!/usr/bin/env bash
# Behaviour unchanged: the .npy files of five kinds of map (the default map, a map with
# several starts per cell, a continuation map run both ways, a refined map, a settled map)
# must be byte-identical when written by two builds. Used for restructurings (issues 42, 59):
#
#   scripts/same_maps.sh OLD_REV            # builds OLD_REV in a worktree, then this checkout
#   scripts/same_maps.sh OLD_BIN NEW_BIN    # two binaries already built
#
# The CPU engine (f64) by default; BACKEND=gpu runs both builds on the GPU (lavapipe where
# there is no hardware GPU): the same driver on both sides, so its numbers must match too.
# Exits 1 and names every file that differs; prints "N passed, 0 failed" when all are equal.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

if [ $# -eq 2 ]; then
  old_bin=$1 new_bin=$2
elif [ $# -eq 1 ]; then
  git worktree add -q --detach "$work/old" "$1"
  CARGO_TARGET_DIR="$PWD/target" cargo build -q --release --manifest-path "$work/old/Cargo.toml" --bin pendulum-atlas
  cp target/release/pendulum-atlas "$work/old_bin"
  git worktree remove --force "$work/old"
  cargo build -q --release --bin pendulum-atlas
  old_bin="$work/old_bin" new_bin=target/release/pendulum-atlas
else
  echo "usage: $0 OLD_REV | OLD_BIN NEW_BIN" >&2
  exit 2
fi

# name|arguments after `map --backend cpu --quiet --out DIR`
maps=(
  'default|'
  'starts|--set map.axes=[{key="excitation.frequency_hz",values=[7.8,8.0]},{key="excitation.amplitude_m",values=[0.001]}] --set beam.segments=3 --set integration.duration_s=30 --set integration.transient_s=15 --set map.initial_states=6'
  'continuation|--set map.axes=[{key="excitation.frequency_hz",values=[9.0,10.0,10.5,11.0,11.5,12.0]}] --set beam.segments=3 --set integration.duration_s=36 --set integration.transient_s=12 --set excitation.amplitude_m=0.001 --set map.metrics=["period","alpha_range","regime"] --set map.lyapunov_window_s=6 --set map.continuation=both'
  'refined|--set map.axes=[{key="excitation.frequency_hz",start=6.0,end=12.0,count=17},{key="excitation.amplitude_m",start=0.004,end=0.025,count=9}] --set map.refine=true --set map.refine_spacing=4'
  'settled|--set map.axes=[{key="excitation.frequency_hz",start=6.0,end=12.0,count=9},{key="excitation.amplitude_m",start=0.004,end=0.025,count=6}] --set map.settle_max_s=68'
)
backend=${BACKEND:-cpu}

passed=0 failed=0
for entry in "${maps[@]}"; do
  name=${entry%%|*}
  read -r -a args <<<"${entry#*|}"
  for side in old new; do
    bin_var=${side}_bin
    "${!bin_var}" map --backend "$backend" --quiet --out "$work/maps_$side/$name" "${args[@]}" >/dev/null 2>"$work/stderr" || { cat "$work/stderr" >&2; exit 1; }
  done
  for f in "$work/maps_old/$name"/*.npy; do
    rel=$name/$(basename "$f")
    if cmp -s "$f" "$work/maps_new/$rel"; then
      passed=$((passed + 1))
    else
      echo "DIFFERS: $rel"
      failed=$((failed + 1))
    fi
  done
  n_old=$(ls "$work/maps_old/$name"/*.npy | wc -l)
  n_new=$(ls "$work/maps_new/$name"/*.npy | wc -l)
  if [ "$n_old" != "$n_new" ]; then
    echo "DIFFERS: $name writes $n_old .npy files before and $n_new after"
    failed=$((failed + 1))
  fi
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
