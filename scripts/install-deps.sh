#!/usr/bin/env bash
# Installs the system packages realcam needs on Debian 12 (as root), only those missing:
# the Vulkan loader and headers, lavapipe (Mesa's CPU Vulkan driver), the Khronos validation
# layer, shaderc with the glslang/SPIRV-Tools static libraries it links against, and the C/C++
# compilers the FLIP metric (nv-flip) builds with, and lensfun's lens database (XML; for
# `realcam lens import-lensfun` and --lens-lensfun).
set -euo pipefail
packages=(mesa-vulkan-drivers libvulkan1 libvulkan-dev vulkan-validationlayers libshaderc-dev glslang-dev spirv-tools gcc g++ liblensfun-data-v1)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found. Install a current Rust toolchain (rustup, https://rustup.rs; Rust 1.89 or newer)." >&2
  exit 1
fi
