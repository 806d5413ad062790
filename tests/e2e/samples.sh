#!/usr/bin/env bash
# The sample scripts a new user runs first (samples/), on small inputs.
. "$(dirname "$0")/lib.sh"
S=$NDO_ROOT/samples
export OUT=$T/out

remesh --shape ellipsoid -l 3 -o egg.obj
if "$S/convert-mesh.sh" "$PWD/egg.obj" 3 >convert.log 2>&1 &&
	[ -s "$OUT/egg.tgrid" ] && [ -s "$OUT/egg.png" ] && [ "$(grep -c '^v ' "$OUT/egg-fine.obj")" = 2050 ]; then
	pass "convert-mesh.sh: mesh → grid → finer mesh and picture"
else
	fail "convert-mesh.sh" "$(tail -3 convert.log)"
fi
if grep -q "Hausdorff" convert.log; then pass "convert-mesh.sh prints the quality report"; else fail "convert-mesh.sh report"; fi

if LEVEL=3 TIME=0.6 EVERY=2 "$S/render-sequence.sh" >seq.log 2>&1; then
	n=$(ls "$OUT/sequence/png" | wc -l)
	f=$(ls "$OUT/sequence/frames" | wc -l)
	if [ "$n" -ge 3 ] && [ "$n" = "$f" ]; then pass "render-sequence.sh: $n frames simulated and drawn"; else
		fail "render-sequence.sh" "$f frames, $n pictures"; fi
else
	fail "render-sequence.sh" "$(tail -3 seq.log)"
fi

for scene in "$S"/*.scene; do
	name=$(basename "$scene")
	if remesh --shape wavy -l 3 | simulate-peer -q -s "$scene" --time 0.2 -o end.tgrid 2>sim.log; then
		pass "$name runs"
	else
		fail "$name" "$(tail -1 sim.log)"
	fi
done
