#!/usr/bin/env bash
# samples/demo.sh — the main job, end to end (run by `make demo`).
# Makes a sphere grid, refines it with butterfly subdivision and exports
# a mesh any viewer opens.
set -euo pipefail
cd "$(dirname "$0")/.."
out=build/demo
mkdir -p "$out"
PATH=$PWD/bin:$PATH
t0=$(date +%s.%N)
remesh --shape wavy -l 4 -o "$out/wavy-4.tgrid"
subdivide -v -l 3 "$out/wavy-4.tgrid" -o "$out/wavy-7.tgrid"
subdivide -l 0 "$out/wavy-7.tgrid" -o "$out/wavy-7.obj"
t1=$(date +%s.%N)
echo "demo: wrote $out/wavy-4.tgrid (level 4), $out/wavy-7.tgrid (level 7)"
echo "demo: and $out/wavy-7.obj ($(grep -c '^v ' "$out/wavy-7.obj") vertices, $(grep -c '^f ' "$out/wavy-7.obj") triangles)"
awk -v a="$t0" -v b="$t1" 'BEGIN { printf "demo: %.2f s in all\n", b - a }'
