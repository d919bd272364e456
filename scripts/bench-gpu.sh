#!/usr/bin/env bash
# The numbers of a real GPU (issue 33 item 4): the bench's GPU time per pass as multiples of a
# bare pass (depth of field, motion blur, flare), and the demo end to end at 1080p, 4K and 8K
# with every effect on (the Tessar with its prescription: ghosts and aberrations; motion blur;
# depth of field; grain), written to docs/bench-<device>.md. Within 5 minutes on a discrete GPU.
#
#   scripts/bench-gpu.sh            # every resolution
#   scripts/bench-gpu.sh --quick    # 1080p only, the bench at 1280x720 once, one light (a CPU device)
#
# REALCAM=path/to/realcam picks the binary (default: target/release/realcam, built if missing);
# REALCAM_DEVICE picks the device (`realcam devices`).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${REALCAM:-target/release/realcam}
[ -x "$bin" ] || cargo build --release --locked
quick=${1:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

device=$("$bin" devices | sed -n 's/^\[[0-9]*\] //p' | head -1)
[ -n "${REALCAM_DEVICE:-}" ] && device=$("$bin" devices | grep -i -- "$REALCAM_DEVICE" | sed 's/^\[[0-9]*\] //' | head -1)
slug=$(printf '%s' "${device%% (*}" | tr 'A-Z' 'a-z' | sed 's/[^a-z0-9]\{1,\}/-/g; s/^-//; s/-$//')
doc=docs/bench-${slug}.md
if [ "$quick" = --quick ]; then
  resolutions=1280x720; scales=3; runs=1; lights=1
else
  resolutions=1920x1080,3840x2160; scales="3 6 12"; runs=5; lights=1,4,16
fi

{
  echo "# realcam on ${device}"
  echo
  echo "Written by \`scripts/bench-gpu.sh $quick\` on $(date -u +%Y-%m-%d), $(git rev-parse --short HEAD 2>/dev/null || echo 'no git')."
  echo "GPU times are the passes' timestamp queries; \"x bare\" is a multiple of the bare pass (one"
  echo "read and write of the frame) measured in the same run."
  echo
  echo "## Depth of field against the CoC radius"
  echo
} > "$work/doc.md"

"$bin" bench --resolutions "$resolutions" --runs "$runs" --out "$work/dof.md" > /dev/null
cat "$work/dof.md" >> "$work/doc.md"
printf '\n## Motion blur against the longest blur\n\n' >> "$work/doc.md"
"$bin" bench --motion-blur --resolutions "$resolutions" --runs "$runs" --out "$work/motion.md" > /dev/null
cat "$work/motion.md" >> "$work/doc.md"
printf '\n## Lens flare against the number of lights\n\n' >> "$work/doc.md"
"$bin" bench --flare --lights "$lights" --runs "$runs" --out "$work/flare.md" > /dev/null
cat "$work/flare.md" >> "$work/doc.md"

{
  echo
  echo "## The demo end to end, every effect on"
  echo
  echo "\`realcam synth --demo-scale K\` (the README demo K times as large, the subject and the pillar"
  echo "moving), rendered with \`--lens lenses/tessar-walch-lens.toml --fstop 4 --focus 2 --fps 24"
  echo "--shutter-angle 180 --grain 0.02 --flare --profile\`: the frame's GPU time per pass (ms; a pass"
  echo "that runs in several bands or runs sums them) and the whole process's wall time."
  echo
} >> "$work/doc.md"
for k in $scales; do
  "$bin" synth --demo-scale "$k" --out "$work" > "$work/synth.txt"
  color=$(sed -n 's/^wrote \(.*_color.exr\)$/\1/p' "$work/synth.txt")
  size=$(basename "$color" _color.exr); size=${size#demo_}
  start=$(date +%s.%N)
  "$bin" render --color "$color" --depth "${color%_color.exr}_depth.exr" \
    --velocity "${color%_color.exr}_vector.exr" --velocity-format blender \
    --lens lenses/tessar-walch-lens.toml --fstop 4 --focus 2 --fps 24 --shutter-angle 180 \
    --grain 0.02 --flare --explain --profile -o "$work/out.exr" > "$work/render.txt" 2>&1
  end=$(date +%s.%N)
  wall=$(awk "BEGIN { printf \"%.2f\", $end - $start }")
  echo "### ${size}, whole process ${wall} s" >> "$work/doc.md"
  echo >> "$work/doc.md"
  grep -E '^  in bands:' "$work/render.txt" | sed 's/^  /- /' >> "$work/doc.md" || true
  echo '```' >> "$work/doc.md"
  sed -n '/^GPU time per pass/,/^  total/p' "$work/render.txt" >> "$work/doc.md"
  echo '```' >> "$work/doc.md"
  echo >> "$work/doc.md"
  rm -f "$work"/demo_* "$work/out.exr"
done
mv "$work/doc.md" "$doc"
echo "wrote $doc"
