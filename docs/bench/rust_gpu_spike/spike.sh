#!/usr/bin/env bash
# The rust-gpu path measured on this machine (docs/bench/GENERATED_KERNELS.md, "The rust-gpu
# path, measured"): install rust-gpu 0.11's pinned nightly, build its compiler backend, compile
# ./shader to SPIR-V, and write it out as WGSL through naga (spike_output.wgsl). Not part of
# the product or of CI; run by hand, from this folder.
set -euo pipefail
cd "$(dirname "$0")"
tc=nightly-2026-08-15
/usr/bin/time -f "toolchain install: %e s" rustup toolchain install $tc --profile minimal -c rust-src -c rustc-dev -c llvm-tools
(cd builder && /usr/bin/time -f "backend build (rustc_codegen_spirv, spirv-tools-sys, naga): %e s, peak %M KB" cargo +$tc build --release)
export LD_LIBRARY_PATH="$PWD/builder/target/release:$(rustc +$tc --print sysroot)/lib"
/usr/bin/time -f "shader crate to WGSL: %e s" ./builder/target/release/spike-builder
