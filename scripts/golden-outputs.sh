#!/usr/bin/env bash
# Renders a fixed matrix of scenes and settings that exercises every pass, and prints one
# SHA-256 per output EXR. Run it before and after a refactoring that must not change pixels:
#   scripts/golden-outputs.sh [REALCAM_BINARY] > before.txt ... > after.txt; diff before.txt after.txt
# Rendering is deterministic on one device (lavapipe on CI), so the hashes must be equal.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-target/release/realcam}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
t=testdata
# SHA-256 of an EXR's pixel chunks, from the first chunk on: the header (realcam writes its
# attributes in name order now; older builds did not) and the offset table (its offsets move
# with the header's length) are left out.
pixel_hash() {
  python3 - "$1" <<'PY'
import hashlib, struct, sys
data = open(sys.argv[1], "rb").read()
pos = 8  # magic and version
while data[pos] != 0:  # attributes: name\0 type\0 size value, until an empty name
    name_end = data.index(b"\0", pos)
    type_end = data.index(b"\0", name_end + 1)
    size = struct.unpack_from("<i", data, type_end + 1)[0]
    pos = type_end + 5 + size
first_chunk = struct.unpack_from("<Q", data, pos + 1)[0]
print(hashlib.sha256(data[first_chunk:]).hexdigest()[:16])
PY
}
render_hash() {
  local name=$1; shift
  "$bin" render "$@" --float -o "$out/$name.exr" >/dev/null 2>"$out/$name.log" || { echo "$name FAILED"; cat "$out/$name.log" >&2; return; }
  echo "$(pixel_hash "$out/$name.exr")  $name"
}
# --film-in-exr: the film curve in the EXR as before it became a switch (the EXR is scene-referred
# by default now), so that every hash but the last covers the film pass as it did.
film_in_exr=$("$bin" render --help | grep -o -- --film-in-exr | head -1 || true)
run() {
  local name=$1; shift
  render_hash "$name" "$@" $film_in_exr
}
demo=(--color $t/demo_color.exr --depth $t/demo_depth.exr)
run demo-tiled "${demo[@]}" --fstop 2 --focus 2
run demo-reference "${demo[@]}" --fstop 2 --focus 2 --bokeh reference
run demo-diffraction "${demo[@]}" --fstop 2.8 --focus 2 --bokeh diffraction
run demo-f8-linear "${demo[@]}" --fstop 8 --focus 2 --film linear --no-exposure
run demo-nothing "${demo[@]}" --fstop 16 --focus 2 --film linear --no-exposure --no-vignetting
run demo-grain-film "${demo[@]}" --fstop 2 --focus 3 --grain 0.02 --seed 3 --film-file films/reversal-example.toml
run demo-blades "${demo[@]}" --fstop 2 --focus 1.5 --blades 6 --blade-rotation 10 --cats-eye 0.4 --spherical-aberration -0.5
run demo-tessar "${demo[@]}" --lens lenses/tessar-walch-lens.toml --fstop 2.8 --focus 2
run demo-tessar-ref "${demo[@]}" --lens lenses/tessar-walch-lens.toml --fstop 4 --focus 2 --bokeh reference
# A clamp in pixels on the 5 mm sensor: there is no clamp by default, and the reference
# gather's cost grows with the square of the largest CoC.
run demo-tessar-lca "${demo[@]}" --lens lenses/tessar-walch-lens.toml --fstop 2.8 --focus 2 --sensor 5x3 --max-coc 64
run demo-tessar-lca-ref "${demo[@]}" --lens lenses/tessar-walch-lens.toml --fstop 5.6 --focus 2 --sensor 5x3 --bokeh reference --max-coc 64
run demo-distagon "${demo[@]}" --lens lenses/zeiss-distagon-21-f2.8.toml --focal-length 21 --fstop 2.8 --focus 1
run demo-otus "${demo[@]}" --lens lenses/zeiss-otus-85-f1.4.toml --fstop 1.4 --focus 2
run demo-planar "${demo[@]}" --lens lenses/zeiss-planar-50-f1.4.toml --fstop 2 --focus 2 --sensor super35
# Ghosts: no testdata light is bright enough for the Tessar's ghosts to show, so a light is
# given (17 of the prescription's 21 ghosts, a 6-spike starburst and the halo, over the scene's
# own lights' glows): the ghost sprites' binning and summation order show in the hash.
run demo-tessar-ghosts "${demo[@]}" --lens lenses/tessar-walch-lens.toml --fstop 2.8 --focus 2 --blades 6 --flare-light 60,40,1e9
for s in point_bg point_fg point_focus edges; do
  run "$s-tiled" --color $t/${s}_color.exr --depth $t/${s}_depth.exr --fstop 2 --focus 2 --film linear --no-exposure --no-vignetting
  run "$s-reference" --color $t/${s}_color.exr --depth $t/${s}_depth.exr --fstop 2 --focus 2 --bokeh reference
done
# An aperture image (a triangle, written as a PNG by Python's zlib).
python3 - "$out/triangle.png" <<'PY'
import sys, zlib, struct
n = 32
rows = b"".join(b"\0" + bytes(255 if abs(x - n / 2) <= y / 2 else 0 for x in range(n)) for y in range(n))
chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", n, n, 8, 0, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")
open(sys.argv[1], "wb").write(png)
PY
run demo-aperture-image "${demo[@]}" --fstop 2 --focus 2 --aperture-image "$out/triangle.png"
run demo-aperture-image-ref "${demo[@]}" --fstop 2 --focus 2 --aperture-image "$out/triangle.png" --bokeh reference
# The default output: scene-referred (exposure and optics, no film curve).
render_hash demo-scene-referred "${demo[@]}" --fstop 2 --focus 2
