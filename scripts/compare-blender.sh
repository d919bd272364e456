#!/usr/bin/env bash
# realcam against Blender's Defocus compositor node on the same colour and depth passes: whole
# process (start, EXR read, depth of field, EXR write, exit) timed from the shell, runs interleaved,
# median of each; with ground truths, each one's rmse_matched (`realcam compare`).
# Blender is optional for realcam: this script is the only thing that needs it.
#
#   scripts/compare-blender.sh --scene-a      # scene A (${SCENE_A:-<repo>/../shared/data/sceneA}), f/2 and f/5.6
#   scripts/compare-blender.sh --color C.exr --depth D.exr --fstop 2 [--gt GT.exr] [--fstop 4 [--gt GT4.exr]] \
#       [--focus 2] [--focal-length 50] [--sensor-width 36] [--blades 6] [--runs 3] [--blur-max PX]
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)

usage() { sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-2}"; }
die() { echo "compare-blender.sh: $*" >&2; exit 1; }

cmd=() color= depth= focus=2 focal=50 sensor_w=36 blades=6 runs=3 blur_max=
fstops=() gts=()
while [ $# -gt 0 ]; do
  case "$1" in --scene-a|-h|--help) ;; *) [ $# -ge 2 ] || die "$1 needs a value" ;; esac
  case "$1" in
    --scene-a)
      dir=${SCENE_A:-$repo/../shared/data/sceneA}
      [ -d "$dir" ] || die "scene A not found at $dir (set SCENE_A=/path/to/sceneA)"
      color=$dir/color.exr depth=$dir/depth.exr focus=2 focal=50 sensor_w=36 blades=6
      fstops=(2 5.6) gts=("$dir/gt_dof_f2.0.exr" "$dir/gt_dof_f5.6.exr"); shift ;;
    --color) color=$2; shift 2 ;;
    --depth) depth=$2; shift 2 ;;
    --fstop) fstops+=("$2"); shift 2 ;;
    --gt) gts+=("$2"); shift 2 ;;
    --focus) focus=$2; shift 2 ;;
    --focal-length) focal=$2; shift 2 ;;
    --sensor-width) sensor_w=$2; shift 2 ;;
    --blades) blades=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --blur-max) blur_max=$2; shift 2 ;;
    -h|--help) usage 0 ;;
    *) echo "compare-blender.sh: unknown argument $1" >&2; usage ;;
  esac
done
[ -n "$color" ] && [ -n "$depth" ] && [ ${#fstops[@]} -gt 0 ] || usage
[ ${#gts[@]} -eq 0 ] || [ ${#gts[@]} -eq ${#fstops[@]} ] || die "give one --gt per --fstop, or none"
for f in "$color" "$depth" ${gts[@]+"${gts[@]}"}; do [ -f "$f" ] || die "no such file: $f"; done
color=$(realpath "$color") depth=$(realpath "$depth")
for i in "${!gts[@]}"; do gts[$i]=$(realpath "${gts[$i]}"); done
cd "$repo"
[[ $runs =~ ^[1-9][0-9]*$ ]] || die "--runs must be a positive integer"

blender=${BLENDER:-$(command -v blender || true)}
if [ -z "$blender" ] || ! [ -x "$blender" ]; then
  echo "compare-blender.sh: Blender not found. Install it (Debian/Ubuntu: sudo apt install blender;" >&2
  echo "  or unpack a release from https://www.blender.org/download/ and set BLENDER=/path/to/blender)." >&2
  exit 3
fi

cargo build --release --locked -q
realcam=$repo/target/release/realcam
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
log=$tmp/log

realcam_cmd() { # realcam_cmd N OUT [EXTRA...]: a thin lens at the pinhole, straight blades, linear output, no flare (the node draws none)
  cmd=("$realcam" render --color "$color" --depth "$depth" -o "$2" --lens ideal --coc-model renderer
    --focal-length "$focal" --sensor "${sensor_w}x24" --sensor-fit horizontal --fstop "$1" --focus "$focus"
    --blades "$blades" --blade-rotation 0 --blade-curvature 0 --bokeh tiled
    --no-exposure --no-vignetting --no-flare --film linear --float --compression none "${@:3}")
}
blender_cmd() { # blender_cmd N OUT BLUR_MAX
  cmd=("$blender" -b --factory-startup -noaudio --python-exit-code 1 --python "$repo/scripts/blender/defocus.py" --
    --color "$color" --depth "$depth" --output "$2" --fstop "$1" --focus "$focus"
    --focal-length "$focal" --sensor-width "$sensor_w" --blades "$blades" --blur-max "$3")
}
timed() { # timed CMD...: run it (output to the log), print its wall-clock and CPU (user + sys) seconds
  local TIMEFORMAT='%R %U %S' t
  if ! t=$( { time "$@" >>"$log" 2>&1; } 2>&1 ); then
    tail -n 20 "$log" >&2; die "failed: $*"
  fi
  awk '{printf "%s %.2f\n", $1, $2 + $3}' <<<"$t"
}
median() { printf '%s\n' "$@" | sort -g | awk '{v[NR]=$1} END {print (NR%2) ? v[(NR+1)/2] : (v[NR/2]+v[NR/2+1])/2}'; }
rmse() { "$realcam" compare "$1" "$2" | sed -n 's/.*rmse_matched \([0-9.eE+-]*\).*/\1/p'; }

# Untimed warm-up: realcam's pass plan gives its device and the largest CoC (Blender's blur_max is
# a radius that must cover it); one empty Blender start loads its binary into the page cache.
declare -A bmax
device=
for i in "${!fstops[@]}"; do
  n=${fstops[$i]}
  realcam_cmd "$n" "$tmp/warm.exr" --explain
  plan=$("${cmd[@]}" 2>&1) || { echo "$plan" >&2; die "realcam failed: ${cmd[*]}"; }
  device=$(sed -n 's/^device: //p' <<<"$plan" | head -n 1)
  coc=$(sed -n 's/.*CoC from \(-\{0,1\}[0-9.]*\) px.* to \(-\{0,1\}[0-9.]*\) px.*/\1 \2/p' <<<"$plan" | head -n 1)
  if [ -n "$blur_max" ]; then bmax[$i]=$blur_max
  elif [ -n "$coc" ]; then bmax[$i]=$(awk -v a="${coc% *}" -v b="${coc#* }" 'BEGIN {
      m = (a < 0 ? -a : a); if ((b < 0 ? -b : b) > m) m = (b < 0 ? -b : b); r = m / 2; print int(r) + 2 }')
  else bmax[$i]=32; echo "note: no CoC range in realcam's plan; Blender blur_max 32 px" >&2
  fi
done
"$blender" -b --factory-startup -noaudio --python-expr "pass" >>"$log" 2>&1 || { tail -n 20 "$log" >&2; die "$blender does not start"; }

load_before=$(cut -d' ' -f1-3 /proc/loadavg)
declare -A rt bt rc bc
for ((r = 1; r <= runs; r++)); do
  for i in "${!fstops[@]}"; do
    n=${fstops[$i]}
    realcam_cmd "$n" "$tmp/realcam_$i.exr"
    read -r w c < <(timed "${cmd[@]}")
    rt[$i]+=" $w" rc[$i]+=" $c"
    blender_cmd "$n" "$tmp/blender_$i.exr" "${bmax[$i]}"
    read -r w c < <(timed "${cmd[@]}")
    bt[$i]+=" $w" bc[$i]+=" $c"
  done
done
load_after=$(cut -d' ' -f1-3 /proc/loadavg)

echo "realcam device: ${device:-unknown}"
echo "CPU: $(nproc) cores, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n 1)"
echo "Blender: $("$blender" --version 2>/dev/null | head -n 1), Defocus node, tiled compositor (scripts/blender/defocus.py)"
echo "passes: $color + $depth; focus $focus m, ${focal} mm, sensor width $sensor_w mm, $blades blades"
echo "load average (1, 5, 15 min) before: $load_before, after: $load_after; $runs runs each, interleaved; $(date -u '+%Y-%m-%d %H:%M UTC')"
echo
echo "Wall-clock seconds of the whole process (median); CPU: user + sys seconds (median), steadier on a loaded machine."
echo
if [ ${#gts[@]} -gt 0 ]; then
  echo "| f-number | realcam median s | Blender median s | Blender / realcam | realcam rmse_matched | Blender rmse_matched | realcam CPU s | Blender CPU s |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
else
  echo "| f-number | realcam median s | Blender median s | Blender / realcam | realcam CPU s | Blender CPU s |"
  echo "| --- | --- | --- | --- | --- | --- |"
fi
for i in "${!fstops[@]}"; do
  # shellcheck disable=SC2086
  mr=$(median ${rt[$i]}) mb=$(median ${bt[$i]})
  row="| f/${fstops[$i]} | $mr | $mb | $(awk -v b="$mb" -v r="$mr" 'BEGIN {printf "%.2fx", b / r}') |"
  [ ${#gts[@]} -eq 0 ] || row+=" $(rmse "$tmp/realcam_$i.exr" "${gts[$i]}") | $(rmse "$tmp/blender_$i.exr" "${gts[$i]}") |"
  # shellcheck disable=SC2086
  echo "$row $(median ${rc[$i]}) | $(median ${bc[$i]}) |"
done
echo
for i in "${!fstops[@]}"; do
  echo "f/${fstops[$i]}: wall s, realcam:${rt[$i]}; Blender:${bt[$i]} (blur_max ${bmax[$i]} px)"
done
