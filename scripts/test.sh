#!/usr/bin/env bash
# Quick start 2: every test, on whatever Vulkan device is present (lavapipe on CI), with the
# Khronos validation layer and synchronization validation on in every GPU test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
# openjd-cli (Open Job Description) in target/openjd-venv, for the test that runs
# jobs/realcam.yaml with `openjd run`; Debian's python3 needs python3-venv for `python3 -m venv`.
OPENJD_VENV=target/openjd-venv
if [ ! -x "$OPENJD_VENV/bin/openjd" ]; then
  if ! python3 -c 'import ensurepip, venv' 2>/dev/null; then
    if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends python3 python3-venv
  fi
  rm -rf "$OPENJD_VENV"
  python3 -m venv "$OPENJD_VENV"
  "$OPENJD_VENV/bin/pip" install -q 'openjd-cli==0.8.0'
fi
export REALCAM_OPENJD="$PWD/$OPENJD_VENV/bin/openjd" REALCAM_REQUIRE_OPENJD=1
# Blender 4.2 LTS as a Python module (bpy, 350 MB from PyPI) in target/bpy-venv, for the test
# of a camera that Blender's USD exporter writes (tests/shot_camera.rs): Debian's Blender 3.4
# is built without USD. The add-on's tests use Debian's Blender (scripts/test-blender.sh).
BPY_VENV=target/bpy-venv
if [ ! -x "$BPY_VENV/bin/python" ] || ! "$BPY_VENV/bin/python" -c 'import bpy' 2>/dev/null; then
  rm -rf "$BPY_VENV"
  python3 -m venv "$BPY_VENV"
  "$BPY_VENV/bin/pip" install -q 'bpy==4.2.23'
fi
export REALCAM_BPY_PYTHON="$PWD/$BPY_VENV/bin/python" REALCAM_REQUIRE_BPY=1
cargo test --locked "$@"
bash scripts/test-python.sh "$@"   # the Python package (python/) against the CLI, pytest
bash scripts/test-blender.sh "$@"   # the Blender add-on (addons/) in headless Blender
