#!/usr/bin/env bash
# Quick start 2: every test, on whatever Vulkan device is present (lavapipe on CI), with the
# Khronos validation layer and synchronization validation on in every GPU test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cargo test --locked "$@"
bash scripts/test-python.sh "$@"   # the Python package (python/) against the CLI, pytest
bash scripts/test-blender.sh "$@"   # the Blender add-on (addons/) in headless Blender
