#!/usr/bin/env bash
# Peers over real LCM in a private network namespace: 2, 3 and 4
# simulate-peer processes run the thesis' scene (figure 5.3, level 5, 1 s
# at dt = 0.01 s) in lock-step, and the owner's result is compared with a
# single process running the same scene.  Tolerances (docs/peers.md):
# symplectic Euler splits exactly (to rounding, 1e-12 of the motion); rk4
# with the boundary extrapolated over the step 1% (measured 0.4%); with 5%
# and 20% loss the run completes and its error is reported (lock-step
# re-sends recover every lost tile, so it stays as small).
. "$(dirname "$0")/netns.bash"
. "$(dirname "$0")/lib.sh"

SCENE=$NDO_ROOT/samples/thesis-fig5.3.scene
remesh --shape wavy -l 5 -o wavy5.tgrid 2>/dev/null || fail "remesh"

# The largest position difference of A from B over B's largest
# displacement, the number of peers in A's owner channel, A's step.
compare() {
	/usr/bin/python3 - "$1" "$2" "$NDO_ROOT/tests/e2e" <<'PY'
import sys
sys.path.insert(0, sys.argv[3])
import numpy as np, tgrid
_, sa, _, a = tgrid.read(sys.argv[1])
_, sb, _, b = tgrid.read(sys.argv[2])
d = np.abs(a["position"] - b["position"]).max()
m = np.abs(b["position"] - b["rest"]).max()
owners = len(np.unique(a["owner"])) if "owner" in a else 0
print(f"{d / m:.3g} {owners} {sa} {sb}")
PY
}

solo() { # solo NAME INTEGRATOR
	simulate-peer -q wavy5.tgrid -s "$SCENE" -i "$2" --dt 0.01 -t 1 -o "$1" 2>>solo.err
}

# run_peers N INTEGRATOR OUT [options for every peer...]: the owner and
# N-1 joiners; every exit status must be 0.
run_peers() {
	local n=$1 integ=$2 out=$3; shift 3
	local pois=(0 1000 2500 3500) pids=() k
	simulate-peer --owner wavy5.tgrid -s "$SCENE" -i "$integ" --dt 0.01 -t 1 --peers "$n" \
		--start-timeout 30 -o "$out" "$@" 2>owner.err &
	pids+=($!)
	for ((k = 1; k < n; k++)); do
		simulate-peer --join --poi "${pois[$k]}" --start-timeout 30 "$@" 2>"joiner$k.err" &
		pids+=($!)
	done
	local bad=0
	for k in "${!pids[@]}"; do
		wait "${pids[$k]}" || { bad=1; echo "    peer $k: exit $?"; }
	done
	if [ $bad -ne 0 ]; then
		sed 's/^/    owner: /' owner.err | tail -3
		for ((k = 1; k < n; k++)); do sed "s/^/    joiner $k: /" "joiner$k.err" | tail -3; done
	fi
	return $bad
}

solo solo-rk4.tgrid rk4 && solo solo-se.tgrid symplectic-euler || fail "single process"

for n in 2 3 4; do
	SECONDS=0
	if run_peers "$n" rk4 peers$n.tgrid; then
		read -r rel owners step _ < <(compare peers$n.tgrid solo-rk4.tgrid)
		if awk "BEGIN{exit !($rel < 0.01)}" && [ "$owners" = "$n" ] && [ "$step" = 100 ]; then
			pass "$n peers, rk4: the result differs from the single process by $rel of the motion (tolerance 0.01), $owners owners, ${SECONDS}s"
		else
			fail "$n peers, rk4" "difference $rel (tolerance 0.01), $owners owners, step $step"
		fi
	else
		fail "$n peers, rk4" "a peer failed"
	fi
done

if run_peers 4 symplectic-euler peers-se.tgrid; then
	read -r rel owners _ < <(compare peers-se.tgrid solo-se.tgrid)
	if awk "BEGIN{exit !($rel < 1e-12)}"; then
		pass "4 peers, symplectic Euler: differs by $rel (tolerance 1e-12: splits exactly)"
	else
		fail "4 peers, symplectic Euler" "difference $rel (tolerance 1e-12)"
	fi
else
	fail "4 peers, symplectic Euler" "a peer failed"
fi

for drop in 0.05 0.2; do
	SECONDS=0
	if run_peers 3 rk4 lossy.tgrid --drop "$drop" --delay 1 --jitter 2 --reorder 0.05; then
		read -r rel _ < <(compare lossy.tgrid solo-rk4.tgrid)
		stats=$(grep -o '[0-9]* timed out' owner.err | head -1)
		resends=$(grep -o '[0-9]* re-sends' owner.err | head -1)
		drops=$(grep -o 'injected [0-9]*' owner.err | head -1)
		if awk "BEGIN{exit !($rel < 0.02)}"; then
			pass "3 peers, ${drop} loss: completed in ${SECONDS}s, differs by $rel (the owner: $drops dropped, $resends, steps $stats)"
		else
			fail "3 peers, ${drop} loss" "difference $rel"
		fi
	else
		fail "3 peers, ${drop} loss" "a peer failed"
	fi
done
