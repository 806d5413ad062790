#!/usr/bin/env bash
# samples/demo.sh — the main job, end to end (run by `make demo`):
#   1. the Stanford bunny (bunny00.off, Debian's libcgal-demo) → a level-5
#      grid, with remesh's quality report;
#   2. refined to level 6 by butterfly subdivision;
#   3. simulated by two peers over LCM in a private network namespace: the
#      thesis' sinusoidal-force experiment (samples/bunny.scene), the owner
#      keeping a frame every 20 steps;
#   4. the frames drawn one level finer, coloured by peer, and the final
#      state exported as a mesh for any viewer.
# It prints where the results are and what each stage cost.  Results go
# to $OUT (default build/demo).  LEVEL (default 5) is the grid level
# remesh makes; OWNER_ARGS goes to the simulation's owner (samples/peers.sh).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
PATH=${NDO_BIN:-$root/bin}:$PATH
out=${OUT:-$root/build/demo}
rm -rf "$out"
mkdir -p "$out/png"
report=()
now() { date +%s.%N; }
stage() { # stage NAME START: remember how long NAME took
	report+=("$(awk -v a="$2" -v b="$(now)" -v n="$1" 'BEGIN { printf "  %-50s %6.1f s", n, b - a }')")
}
t0=$(now)

t=$(now)
tar -xzf /usr/share/doc/libcgal-dev/data.tar.gz -C "$out" data/meshes/bunny00.off
mesh=$out/data/meshes/bunny00.off
L=${LEVEL:-5}
remesh "$mesh" -l "$L" --report -o "$out/bunny-remeshed.tgrid" 2>"$out/remesh.log"
stage "remesh bunny00.off (37,706 vertices) to level $L" "$t"
sed 's/^/demo: /' "$out/remesh.log" | grep -E 'parameterization|distance|fold-overs|→ level'

t=$(now)
subdivide -l 1 "$out/bunny-remeshed.tgrid" -o "$out/bunny-refined.tgrid"
stage "subdivide level $L to $((L + 1))" "$t"

t=$(now)
"$root/samples/peers.sh" -n 2 "$out/bunny-refined.tgrid" "$root/samples/bunny.scene" "$out/peers"
stage "simulate bunny.scene on 2 peers over LCM" "$t"
grep -h 'done (run complete)\|network:' "$out/peers/peer-0.log" | sed 's/^simulate-peer: /demo: owner: /'

t=$(now)
# the bunny (y up) from its front left, face and ears in view (azimuth 60
# showed its back)
render-frame -k 1 --msaa 4 --up 0,1,0 --azimuth 240 --elevation 15 \
	-o "$out/png/f%04d.png" "$out"/peers/frames/*.tgrid
stage "render $(ls "$out/png" | wc -l) frames at level $((L + 2)), coloured by peer" "$t"

t=$(now)
subdivide -l 1 "$out/peers/end.tgrid" -o "$out/bunny-end.obj"
stage "export the final state (level $((L + 2))) as OBJ" "$t"

echo "demo: results in $out/"
echo "  bunny-remeshed.tgrid            the level-$L grid (remesh's report: remesh.log)"
echo "  bunny-refined.tgrid             level $((L + 1)), what the peers simulate"
echo "  peers/end.tgrid                 the final state, with the owner channel"
echo "  peers/frames/, png/             $(ls "$out/png" | wc -l) frames as grids and as pictures ($(ls "$out/png" | tail -1) is the last)"
echo "  bunny-end.obj                   the final state as a mesh for any viewer"
echo "demo: what each stage cost"
printf '%s\n' "${report[@]}"
awk -v a="$t0" -v b="$(now)" 'BEGIN { printf "  %-50s %6.1f s\n", "in all", b - a }'
