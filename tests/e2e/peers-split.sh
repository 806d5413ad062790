#!/usr/bin/env bash
# rkf45 and the implicit methods over real LCM in a private network
# namespace (docs/peers.md, "rkf45 and the implicit methods"): their
# lock-step steps take several exchanges (solve_t).  On the thesis' scene
# (figure 5.3, level 4, 10 s), 2, 3 and 4 peers, the owner's result against
# a single process:
#   rkf45: the same sub-steps, bit for bit (difference 0);
#   backward Euler and the trapezoid (conjugate gradients over the peers,
#   preconditioned by the diagonal, and with 2 peers by each region's block
#   too): within 1e-10 of the largest displacement;
#   the trapezoid with --boundary hold (the thesis' reference mode): not;
#   rkf45 and the trapezoid, 3 peers, 2 s under 10 % loss: the same bounds.
. "$(dirname "$0")/netns.bash"
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/peers.bash"

SCENE=$NDO_ROOT/samples/thesis-fig5.3.scene
remesh --shape wavy -l 4 -o wavy4.tgrid 2>/dev/null || fail "remesh"

# physics NAME: the run of each method (rkf45 has no stable step to pick,
# the implicit methods are stable at any step: both take one given)
# (RUN_TIME: simulated seconds, default 10)
physics() {
	case $1 in
	rkf45) echo "-i rkf45 --dt 0.02 -t ${RUN_TIME:-10}" ;;
	*) echo "-i $1 --dt 0.05 -t ${RUN_TIME:-10}" ;;
	esac
}

# run_peers N METHOD OUT [owner options...]: the owner and N-1 joiners
# (JOINER_OPTS: the joiners' options too); every exit status must be 0.
run_peers() {
	local n=$1 m=$2 out=$3; shift 3
	local pois=(0 250 600 900) pids=() k
	# shellcheck disable=SC2046
	simulate-peer --owner wavy4.tgrid -s "$SCENE" $(physics "$m") --peers "$n" \
		--start-timeout 30 --step-timeout 30 -o "$out" "$@" 2>owner.err &
	pids+=($!)
	for ((k = 1; k < n; k++)); do
		# shellcheck disable=SC2086
		simulate-peer --join --poi "${pois[$k]}" --start-timeout 30 ${JOINER_OPTS:-} \
			2>"joiner$k.err" &
		pids+=($!)
	done
	wait_peers "$n" "${pids[@]}"
}

for m in rkf45 backward-euler trapezoid; do
	# shellcheck disable=SC2046
	simulate-peer -q wavy4.tgrid -s "$SCENE" $(physics "$m") -o "solo-$m.tgrid" 2>>solo.err ||
		fail "single process, $m"
done

# split NAME N METHOD BOUND [owner options...]: N peers end within BOUND
# (0: bit for bit) of the single process (solo-METHOD.tgrid; with RUN_TIME,
# solo-METHOD-RUN_TIMEs.tgrid)
split() {
	local name=$1 n=$2 m=$3 bound=$4 out=p$2-$3.tgrid solo=solo-$3${RUN_TIME:+-${RUN_TIME}s}.tgrid
	shift 4
	SECONDS=0
	if run_peers "$n" "$m" "$out" "$@"; then
		read -r rel owners step sstep < <(compare "$out" "$solo")
		local how loss
		how=$(grep -o 'exact: [^;]*' owner.err | head -1)
		loss=$(grep -o 'injected [0-9]*' owner.err | head -1)
		[ -n "$loss" ] && how="$how; the owner: $loss dropped, $(grep -o '[0-9]* re-sends' owner.err | head -1)"
		if awk "BEGIN{exit !($rel <= $bound)}" && [ "$owners" = "$n" ] && [ "$step" = "$sstep" ]
		then
			pass "$name: difference $rel (at most $bound) at step $step, $owners owners, ${SECONDS}s ($how)"
		else
			fail "$name" "difference $rel (at most $bound), $owners owners, step $step of $sstep"
		fi
	else
		fail "$name" "a peer failed: $(tail -1 owner.err)"
	fi
}

for n in 2 3 4; do
	split "$n peers, rkf45, 10 s" "$n" rkf45 0
	split "$n peers, backward Euler, 10 s" "$n" backward-euler 1e-10
	split "$n peers, trapezoid, 10 s" "$n" trapezoid 1e-10
done
# each region's block (CHOLMOD) as the preconditioner instead of the
# diagonal, on every peer: the same bound
JOINER_OPTS="--precondition block" split "2 peers, backward Euler, 10 s, --precondition block" \
	2 backward-euler 1e-10 --precondition block

# under loss over real LCM (10 %, 1 ms delay, 2 ms jitter, 5 % reordered, on
# every peer): a lost phase or halo is sent again, and the result is the
# same (in one process: test_peer's split_steps_survive_loss)
lossy="--drop 0.1 --delay 1 --jitter 2 --reorder 0.05"
for m in rkf45 trapezoid; do
	bound=0
	[ $m = trapezoid ] && bound=1e-10
	# shellcheck disable=SC2046
	simulate-peer -q wavy4.tgrid -s "$SCENE" $(RUN_TIME=2 physics "$m") -o "solo-$m-2s.tgrid" ||
		fail "single process, $m, 2 s"
	# shellcheck disable=SC2086
	RUN_TIME=2 JOINER_OPTS="$lossy" split "3 peers, $m, 2 s, 10% loss" 3 $m $bound $lossy
done

if run_peers 2 trapezoid held.tgrid --boundary hold; then
	read -r rel _ < <(compare held.tgrid solo-trapezoid.tgrid)
	if awk "BEGIN{exit !($rel > 1e-4)}"; then
		pass "2 peers, trapezoid, the thesis' held boundary: differs by $rel (the lag's error)"
	else
		fail "2 peers, trapezoid, held boundary" "difference $rel: the reference mode should lag"
	fi
else
	fail "2 peers, trapezoid, held boundary" "a peer failed"
fi
