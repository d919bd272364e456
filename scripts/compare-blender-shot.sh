#!/usr/bin/env bash
# A shot through realcam against Blender's compositor (issue 31, "Speed on a shot"): N frames of
# one multilayer EXR (Combined, Depth, Vector; scene A's passes by default) with depth of field at
# f/2 and motion blur, one process each, runs interleaved. realcam: `render --frames` (it prints
# the per-frame split of read, GPU and write); Blender: scripts/blender/shot.py (Defocus, then
# Vector Blur, rendered as an animation). Needs Blender (3.4) and a realcam binary.
#
#   scripts/compare-blender-shot.sh [--passes FILE] [--frames 12] [--runs 2] [--realcam BIN] [--motion-only]
#
# --motion-only: motion blur alone (realcam at f/1000, where its depth of field is skipped as
# invisible; Blender's Vector Blur without the Defocus node), issue 30's speed goal.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
passes=${SCENE_A:-$repo/../shared/data/sceneA}/passes.exr frames=12 runs=2 realcam=$repo/target/release/realcam
fstop=2 defocus=()
while [ $# -gt 0 ]; do
  case "$1" in
    --passes) passes=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --realcam) realcam=$2; shift 2 ;;
    --motion-only) fstop=1000 defocus=(--no-defocus); shift ;;
    *) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 2 ;;
  esac
done
[ -f "$passes" ] || { echo "compare-blender-shot.sh: no passes at $passes" >&2; exit 1; }
[ -x "$realcam" ] || { echo "compare-blender-shot.sh: no realcam at $realcam (cargo build --release)" >&2; exit 1; }
command -v blender >/dev/null || { echo "compare-blender-shot.sh: blender not found" >&2; exit 1; }
work=$(mktemp -d -t realcam-shot-XXXXXX)
trap 'rm -rf "$work"' EXIT
for f in $(seq -f %04g 1 "$frames"); do ln -s "$(realpath "$passes")" "$work/passes_$f.exr"; done
# The same camera on both sides: the thin lens of the renderer, 50 mm f/2 focused at 2 m, six
# blades, a 180-degree shutter at 24 fps; no exposure, vignetting, flare or film curve.
flags=(--lens ideal --focal-length 50 --fstop "$fstop" --focus 2 --blades 6 --blade-rotation 0 --no-flare --no-exposure
  --no-vignetting --film linear --fps 24 --shutter-angle 180)
seconds() { local t0 t1; t0=$(date +%s.%N); "$@" >"$work/log" 2>&1 || { cat "$work/log"; exit 1; }; t1=$(date +%s.%N); echo "$t1 - $t0" | bc; }
echo "device: $("$realcam" devices 2>/dev/null | head -n 1); $(blender --version 2>/dev/null | head -n 1); $frames frames of $(basename "$passes"); load $(cut -d' ' -f1-3 /proc/loadavg)"
for run in $(seq 1 "$runs"); do
  rm -f "$work"/out_* "$work"/blender_*
  r=$(seconds "$realcam" render --color "$work/passes_####.exr" --frames "1-$frames" -o "$work/out_####.exr" "${flags[@]}")
  split=$(grep '^per frame' "$work/log" || true)
  b=$(seconds blender -b --factory-startup -noaudio --python-exit-code 1 --python "$repo/scripts/blender/shot.py" -- \
    --passes "$work/passes_####.exr" --frames "$frames" --output "$work/blender_####.exr" --fstop 2 --focus 2 --shutter 0.5 "${defocus[@]}")
  echo "run $run: realcam $r s, Blender $b s: $(echo "scale=1; $b / $r" | bc)x; realcam $split"
done
