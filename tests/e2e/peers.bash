# tests/e2e/peers.bash — sourced by the scripts that run peers over LCM and
# compare a multi-peer run with a single process (peers-run.sh,
# peers-split.sh, peers-realtime.sh, peers-restart.sh, peers-owner.sh) or
# wait for what a peer says (peers-life.sh).

# pause: a random 0.05..0.4 s (an event at a random moment of a run that
# takes 1.1 s or more after its first step).
pause() { sleep "$(awk -v r=$RANDOM 'BEGIN{printf "%.2f", 0.05 + 0.35 * r / 32767}')"; }

# compare A B: the largest position difference of A from B over B's largest
# displacement, the number of peers in A's owner channel, A's and B's step.
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

# joiners N [options for every peer...]: after an owner started in the
# background (its pid the first of the array pids), N-1 joiners at faces 250,
# 600 and 900 (stderr in joinerK.err); then wait_peers N.
joiners() {
	local n=$1 k pois=(0 250 600 900)
	shift
	for ((k = 1; k < n; k++)); do
		simulate-peer --join --poi "${pois[$k]}" --start-timeout 30 "$@" 2>"joiner$k.err" &
		pids+=($!)
	done
	wait_peers "$n" "${pids[@]}"
}

# wait_peers N PID...: wait for the owner and its N-1 joiners (stderr in
# owner.err, joinerK.err); 0 when every one exits 0, else 1 after showing
# the last lines each wrote.
wait_peers() {
	local n=$1 bad=0 k
	shift
	local pids=("$@")
	for k in "${!pids[@]}"; do
		wait "${pids[$k]}" || { bad=1; echo "    peer $k: exit $?"; }
	done
	if [ $bad -ne 0 ]; then
		sed 's/^/    owner: /' owner.err | tail -3
		for ((k = 1; k < n; k++)); do sed "s/^/    joiner $k: /" "joiner$k.err" | tail -3; done
	fi
	return $bad
}

# wait_for FILE REGEX SECONDS: until a line of FILE matches; prints the
# time it took (fails after SECONDS).
wait_for() {
	local t0=$EPOCHREALTIME
	while ! grep -Eq -- "$2" "$1" 2>/dev/null; do
		awk "BEGIN{exit !($EPOCHREALTIME - $t0 > $3)}" && return 1
		sleep 0.02
	done
	awk "BEGIN{printf \"%.2f\", $EPOCHREALTIME - $t0}"
}
