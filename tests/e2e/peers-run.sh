#!/usr/bin/env bash
# Peers over real LCM in a private network namespace: 2, 3 and 4
# simulate-peer processes run the thesis' scene (figure 5.3, level 4, 10 s
# at each method's automatic step) in lock-step, and the owner's result is
# compared with a single process running the same scene.  Lock-step
# exchanges halos (docs/peers.md): euler, symplectic Euler, midpoint and
# rk4 must give the single process's positions bit for bit (difference 0),
# with one exchange per step and with one per 4 steps; the thesis' held
# boundary (--boundary hold) must not.  With 5% and 20% loss the run
# completes, still bit for bit (lock-step re-sends recover every lost tile).
# At level 8, 2 and 3 peers (their regions through RK4's pipeline) too.
# The owner's default partition from level 3 is bands of whole grid rows;
# with --partition quadtree (regions grown from the POIs, borders across
# rows), 2-4 peers, midpoint and rk4, and 2 peers at level 8, bit for bit too.
. "$(dirname "$0")/netns.bash"
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/peers.bash"

SCENE=$NDO_ROOT/samples/thesis-fig5.3.scene
remesh --shape wavy -l 4 -o wavy4.tgrid 2>/dev/null || fail "remesh"

# Forward Euler is stable on this scene only at a 0.085 ms step (damping
# bound): 10 s would take 118549 steps, so it runs 0.1 s (1186 steps).
dur() { [ "$1" = euler ] && echo 0.1 || echo "${RUN_TIME:-10}"; }

solo() { # solo NAME INTEGRATOR
	simulate-peer -q wavy4.tgrid -s "$SCENE" -i "$2" -t "$(dur "$2")" -o "$1" 2>>solo.err
}

# run_peers N INTEGRATOR OUT [options for every peer...]: the owner and
# N-1 joiners; every exit status must be 0.  $OWNER_OPTS: the owner's own
# options, $RUN_TIME the simulated seconds (10), $GRID the grid (wavy4.tgrid).
run_peers() {
	local n=$1 integ=$2 out=$3; shift 3
	local pids=()
	simulate-peer --owner "${GRID:-wavy4.tgrid}" -s "$SCENE" -i "$integ" -t "$(dur "$integ")" --peers "$n" \
		--start-timeout 30 -o "$out" ${OWNER_OPTS:-} "$@" 2>owner.err &
	pids+=($!)
	joiners "$n" "$@"
}

METHODS="euler symplectic-euler midpoint rk4"
for m in $METHODS; do solo "solo-$m.tgrid" "$m" || fail "single process, $m"; done

# exact NAME N METHOD OUT [options]: N peers give the single process's result
# ($SOLO: its grid, solo-METHOD.tgrid)
exact() {
	local name=$1 n=$2 m=$3 out=$4; shift 4
	SECONDS=0
	if run_peers "$n" "$m" "$out" "$@"; then
		read -r rel owners step sstep < <(compare "$out" "${SOLO:-solo-$m.tgrid}")
		if [ "$rel" = 0 ] && [ "$owners" = "$n" ] && [ "$step" = "$sstep" ]; then
			pass "$name: bit for bit the single process at step $step, $owners owners, ${SECONDS}s"
		else
			fail "$name" "difference $rel (expected 0), $owners owners, step $step of $sstep"
		fi
	else
		fail "$name" "a peer failed"
	fi
}

for n in 2 3 4; do
	for m in $METHODS; do
		exact "$n peers, $m, $(dur "$m") s" "$n" "$m" "p$n-$m.tgrid"
	done
done
# the quad-tree's regions instead of the default bands of whole grid rows
for n in 2 3 4; do
	for m in midpoint rk4; do
		OWNER_OPTS="--partition quadtree" exact "$n peers, $m, quad-tree regions" "$n" "$m" "q$n-$m.tgrid"
	done
done
OWNER_OPTS="--halo-steps 4" exact "3 peers, rk4, a halo exchange every 4 steps" 3 rk4 wide.tgrid
OWNER_OPTS="--publish-every 0" \
	exact "2 peers, midpoint, whole regions only at the end" 2 midpoint quiet.tgrid
# Without CAP_NET_ADMIN (an unprivileged user's peers) the link cannot
# force the socket buffer it reads the group with on the stepping thread
# (lib/net/link_lcm.c) and receives through LCM's own reader thread: the
# same result.  Every other run here, as root, reads the group directly.
mkdir -p nocap
printf '#!/bin/sh\nexec setpriv --bounding-set -net_admin %s "$@"\n' "$(command -v simulate-peer)" \
	>nocap/simulate-peer && chmod +x nocap/simulate-peer
PATH=$PWD/nocap:$PATH exact "2 peers, rk4, without CAP_NET_ADMIN (LCM's reader thread)" 2 rk4 nocap.tgrid

# A free body drifts whole (the scene's force pushes one cap): at 400 s the
# scene has moved about 28 m, 8 diagonals of its rest box.  Until 2026-11-30
# receivers bounded positions to 4 diagonals from that box: the owner's -o
# kept the joiner's region of an earlier step (its last tiles dropped as
# `box`), exit 0.
simulate-peer -q wavy4.tgrid -s "$SCENE" -i rk4 -t 400 -o solo-drift.tgrid 2>>solo.err ||
	fail "single process, 400 s"
drift=$(/usr/bin/python3 - solo-drift.tgrid "$NDO_ROOT/tests/e2e" <<'PY'
import sys
sys.path.insert(0, sys.argv[2])
import numpy as np, tgrid
_, _, _, g = tgrid.read(sys.argv[1])
r = g["rest"].reshape(-1, 3)
u = (g["position"] - g["rest"]).reshape(-1, 3).mean(axis=0)
print(f"{np.linalg.norm(u) / np.linalg.norm(r.max(0) - r.min(0)):.1f}")
PY
)
if awk -v d="${drift:-0}" 'BEGIN { exit !(d > 4) }'; then
	SOLO=solo-drift.tgrid RUN_TIME=400 \
		exact "2 peers, rk4, 400 s: the body drifted $drift box diagonals" 2 rk4 drift.tgrid
else
	fail "a body drifting past 4 box diagonals" "it drifted ${drift:-?} diagonals"
fi

# A simulating peer takes of the others' whole regions only the last step's
# (the owner's -o, a joiner's own -o): it passes over their frames between,
# undecoded (the network line counts them), unless it writes frames itself.
# Both peers' -o are the single process's.  Frames every 10 steps: by default
# (--publish-rate 30) a level-4 run this short would send only its first and last.
for jopts in "-o joined.tgrid" "-o joined.tgrid --frames jf/f%03d.tgrid --frame-every 100"; do
	rm -f joined.tgrid
	simulate-peer --owner wavy4.tgrid -s "$SCENE" -i rk4 -t 10 --peers 2 --start-timeout 30 \
		--publish-every 10 -o owned.tgrid 2>owner.err &
	pids=($!)
	# shellcheck disable=SC2086
	simulate-peer --join --poi 250 --start-timeout 30 $jopts 2>joiner1.err &
	pids+=($!)
	if wait_peers 2 "${pids[@]}"; then
		read -r ro _ < <(compare owned.tgrid solo-rk4.tgrid)
		read -r rj _ < <(compare joined.tgrid solo-rk4.tgrid)
		po=$(grep -o '[0-9]* tiles not used here' owner.err | awk '{print $1}')
		pj=$(grep -o '[0-9]* tiles not used here' joiner1.err | awk '{print $1}')
		frames=$(find jf -name 'f*.tgrid' 2>/dev/null | wc -l)
		# the joiner passes over the owner's frames, unless it writes its own
		joiner_ok=0
		case $jopts in
		*--frames*) [ -z "$pj" ] && [ "$frames" -gt 0 ] && joiner_ok=1 ;;
		*) [ "${pj:-0}" -gt 0 ] && joiner_ok=1 ;;
		esac
		if [ "$ro" = 0 ] && [ "$rj" = 0 ] && [ "${po:-0}" -gt 0 ] && [ $joiner_ok = 1 ]; then
			pass "2 peers, rk4, a joiner with $jopts: both -o bit for bit; tiles passed over: owner ${po}, joiner ${pj:-0 (it writes frames: $frames)}"
		else
			fail "2 peers, rk4, a joiner with $jopts" "differences $ro / $rj, tiles passed over ${po:-0} / ${pj:-0}, $frames frames"
		fi
	else
		fail "2 peers, rk4, a joiner with $jopts" "a peer failed"
	fi
done

# Level 8: regions of many chunks step rk4 through the pipeline
# (lib/sim/rk4.c, with held nodes) on a grid where each unit waits for others.
# What this checks is the pipeline's exactness, not the heartbeat: under the
# sanitizers at load 9-11 (2026-12-01) one of 3 such peers went 2 s (the
# default --peer-timeout) without being scheduled, the owner dropped it and
# it ended non-zero, so they may be silent for 10 s.
remesh --shape wavy -l 8 -o wavy8.tgrid 2>/dev/null || fail "remesh level 8"
simulate-peer -q wavy8.tgrid -s "$SCENE" -t 0.1 -o solo8.tgrid 2>>solo.err || fail "single process, level 8"
for n in 2 3; do
	GRID=wavy8.tgrid SOLO=solo8.tgrid RUN_TIME=0.1 \
		exact "$n peers, rk4, level 8 (RK4's pipeline with held nodes)" "$n" rk4 "p$n-l8.tgrid" \
		--peer-timeout 10
done
GRID=wavy8.tgrid SOLO=solo8.tgrid RUN_TIME=0.1 OWNER_OPTS="--partition quadtree" \
	exact "2 peers, rk4, level 8, quad-tree regions" 2 rk4 "q2-l8.tgrid" --peer-timeout 10

if OWNER_OPTS="--boundary hold" run_peers 2 rk4 held.tgrid; then
	read -r rel _ < <(compare held.tgrid solo-rk4.tgrid)
	if awk "BEGIN{exit !($rel > 1e-4)}"; then
		pass "2 peers, rk4, the thesis' held boundary: differs by $rel (the lag's error)"
	else
		fail "2 peers, rk4, held boundary" "difference $rel: the reference mode should lag"
	fi
else
	fail "2 peers, rk4, held boundary" "a peer failed"
fi

for drop in 0.05 0.2; do
	SECONDS=0
	# a long step timeout: under the sanitizers a re-sent halo can take
	# longer than 0.5 s, and a step that gives up is no longer exact
	if RUN_TIME=2 OWNER_OPTS="--step-timeout 30" \
		run_peers 3 rk4 lossy.tgrid --drop "$drop" --delay 1 --jitter 2 --reorder 0.05; then
		solo_short=solo-rk4-2s.tgrid
		[ -e $solo_short ] || simulate-peer -q wavy4.tgrid -s "$SCENE" -i rk4 -t 2 -o $solo_short
		read -r rel _ < <(compare lossy.tgrid $solo_short)
		resends=$(grep -o '[0-9]* re-sends' owner.err | head -1)
		drops=$(grep -o 'injected [0-9]*' owner.err | head -1)
		if [ "$rel" = 0 ]; then
			pass "3 peers, ${drop} loss: completed in ${SECONDS}s, bit for bit (the owner: $drops dropped, $resends)"
		else
			fail "3 peers, ${drop} loss" "difference $rel (expected 0)"
		fi
	else
		fail "3 peers, ${drop} loss" "a peer failed"
	fi
done
