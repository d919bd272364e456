#!/usr/bin/env bash
# The Blender add-on (addons/realcam_blender) in Blender itself: Debian's blender, headless,
# renders a tiny Cycles scene, runs the add-on's operator and checks the defocused disc against
# eq 5.3 (tests/blender/test_addon.py); then a 5-frame range with a keyframed f-stop through the
# animation operator, each frame's aperture and disc, and no temporary folder left behind
# (tests/blender/test_addon_animation.py). Installs blender where it is missing (apt-get);
# skipped, saying why, only where it cannot be installed. Run by scripts/test.sh after `cargo
# test`. REALCAM_BIN set: that binary, nothing built; else cargo builds the repository's.
set -euo pipefail
cd "$(dirname "$0")/.."
profile=debug
for a in "$@"; do [ "$a" = --release ] && profile=release; done
if ! command -v blender >/dev/null 2>&1; then
  echo "installing: blender"
  if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
  if ! { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends blender; }; then
    echo "SKIPPED: the Blender add-on test: blender is not installed and apt-get could not install it" >&2
    exit 0
  fi
fi
if [ -z "${REALCAM_BIN:-}" ]; then
  cargo build --locked $([ $profile = release ] && echo --release) --bin realcam
  REALCAM_BIN=${CARGO_TARGET_DIR:-$PWD/target}/$profile/realcam
fi
export REALCAM_BIN REALCAM_VALIDATE=1
for test in tests/blender/test_addon.py tests/blender/test_addon_animation.py; do
  echo "blender: $test"
  blender -b --factory-startup -noaudio --python-exit-code 1 -P "$test" 2>&1 | grep -v '^Fra:'
done
