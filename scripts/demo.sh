#!/usr/bin/env bash
# Quick start 1: render the bundled demo scene (testdata/demo_*.exr) with the default lens.
# Prints the pass plan and the GPU time of every pass; writes out/demo.exr and out/demo.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cargo build --release --locked
# The shaders compiled once into the driver's cache (a few seconds the first time, ~1 s after):
# the render below then runs as it would on a machine that has rendered before.
./target/release/realcam warm-up
mkdir -p out
./target/release/realcam render \
  --color testdata/demo_color.exr --depth testdata/demo_depth.exr \
  --fstop 2 --focus 2 \
  --explain --profile --trace out/demo-trace.json \
  -o out/demo.exr --png out/demo.png "$@"
