#!/usr/bin/env bash
# The Python package (python/, PyO3 + maturin): built into a virtual environment
# (target/python-venv) with `maturin develop --release`, then its pytest tests, which compare it
# with the command line (target/release/realcam with --release, else target/debug/realcam).
# Run by scripts/test.sh after `cargo test`; installs Debian's python3-venv where it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
profile=debug
for a in "$@"; do [ "$a" = --release ] && profile=release; done
if ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then
  echo "installing: python3-venv"
  if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends python3-venv
fi
# Cargo's target folder: CARGO_TARGET_DIR where it is set, as cargo itself does.
target=${CARGO_TARGET_DIR:-$PWD/target}
venv=$target/python-venv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check 'maturin>=1.5,<2' numpy pytest
cargo build --locked $([ $profile = release ] && echo --release) --bin realcam
# The extension shares target/ with the repository's build (same dependency versions).
(cd python && VIRTUAL_ENV=$venv PATH="$venv/bin:$PATH" CARGO_TARGET_DIR=$target maturin develop --release --locked -q)
REALCAM_BIN=$target/$profile/realcam "$venv/bin/python" -m pytest -q python/tests
