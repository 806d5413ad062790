#!/usr/bin/env bash
# docs/render-frame/figures.sh [OUTDIR] — make the figures of
# docs/render-frame.md (default OUTDIR: docs/render-frame).  The test
# tests/e2e/render-frame-reference.sh makes them again into a scratch
# directory and compares them with the ones in docs/, so these pictures are
# also the reference images.  Uses the binaries on PATH (bin/ by default).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-$root/docs/render-frame}
PATH=${NDO_BIN:-$root/bin}:$PATH
py=/usr/bin/python3
helper=$root/tests/e2e/render_check.py
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

remesh --shape sphere -l 4 -o "$tmp/sphere-4.tgrid"
remesh --shape sphere -l 5 -o "$tmp/sphere-5.tgrid"
remesh --shape wavy -l 5 -o "$tmp/wavy-5.tgrid"
$py "$helper" grid-owner "$tmp/wavy-5.tgrid" "$tmp/peers.tgrid" quadrants >/dev/null
$py "$helper" grid-rest "$tmp/wavy-5.tgrid" "$tmp/sphere-5.tgrid" "$tmp/moved.tgrid" >/dev/null

size=512x384
z="--compression 9 --msaa 4"
# Thesis figure 5.1a: Phong shading, rendered finer (level 7) than stored (5).
render-frame -s $size $z -k 2 "$tmp/sphere-5.tgrid" -o "$out/sphere.png"
# Thesis figure 5.1b: with the procedural cloth.
render-frame -s $size $z -k 2 --cloth "$tmp/wavy-5.tgrid" -o "$out/cloth.png"
# Thesis figures 5.3-5.6: one colour per peer (four quarters of the grid).
render-frame -s $size $z -k 2 --azimuth -60 --elevation 35 "$tmp/peers.tgrid" -o "$out/peers.png"
# Colour by a scalar: the displacement from the rest shape (the sphere).
render-frame -s $size $z -k 2 --color-by displacement "$tmp/moved.tgrid" -o "$out/displacement.png"
# The level-4 grid's edges on its level-6 butterfly surface, seen at corner
# B of the tetrahedron (the fold of the bottom row).
eye=$($py "$helper" grid-node "$tmp/sphere-4.tgrid" 16 0 4)
render-frame -s $size $z -k 2 --wireframe --eye "$eye" --center 0,0,0 \
    "$tmp/sphere-4.tgrid" -o "$out/wireframe.png"
echo "figures.sh: wrote $(cd "$out" && ls sphere.png cloth.png peers.png displacement.png wireframe.png | tr '\n' ' ')in $out"
