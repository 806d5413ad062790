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

# Two and three peers in a private network namespace (samples/peers.sh
# makes its own), and the whole demo on a small grid and a short run.
remesh --shape wavy -l 3 -o wavy3.tgrid
for n in 2 3; do
	if OWNER_ARGS='-t 0.3' "$S/peers.sh" -n "$n" wavy3.tgrid "$S/thesis-fig5.3.scene" "peers$n" >peers.log 2>&1 &&
		[ -s "peers$n/end.tgrid" ] && grep -q "$n peers at the end" "peers$n/peer-0.log"; then
		pass "peers.sh -n $n: the run completes, the owner writes the object"
	else
		fail "peers.sh -n $n" "$(tail -2 peers.log) $(tail -2 "peers$n/peer-0.log" 2>/dev/null)"
	fi
done
if LEVEL=3 OWNER_ARGS='-t 0.2' "$S/demo.sh" >demo.log 2>&1 && grep -q "in all" demo.log &&
	[ -s "$OUT/peers/end.tgrid" ] && [ -s "$OUT/bunny-end.obj" ] && ls "$OUT"/png/*.png >/dev/null; then
	pass "demo.sh runs end to end (level 3, 0.2 s)"
else
	fail "demo.sh" "$(tail -3 demo.log)"
fi
# Its pictures show the two peers in two colours, whatever their random
# ids (issue 16: colour by id mod 10 merged them in 1 run of 5).
pngs=("$OUT"/png/*.png) bad=0
for f in "${pngs[@]}"; do
	/usr/bin/python3 "$NDO_ROOT/tests/e2e/render_check.py" colors "$f" 2 >>colors.log 2>&1 || bad=$((bad + 1))
done
if [ -f "${pngs[0]}" ] && [ $bad -eq 0 ]; then
	pass "demo.sh: every one of its ${#pngs[@]} pictures shows 2 peer colours"
else
	fail "demo.sh pictures" "$bad of ${#pngs[@]} do not show 2 colours: $(grep -m1 render_check colors.log)"
fi
